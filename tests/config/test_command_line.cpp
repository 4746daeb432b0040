// The command-line convention shared by clm and clm-servod
// (config/command_line.hpp): the edit distance and the nearest name, the
// readable range checks, and the message of a parse error on a small app.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "config/command_line.hpp"

using namespace clm;

namespace {

/// The message the validator gives for `input` ("" when accepted).
std::string check(const CLI::Validator& validator, std::string input) { return validator(input); }

/// A small app shaped like clm: two subcommands, one with a required option.
struct ToyApp {
  CLI::App app{"toy", "toy"};
  std::string config;
  double duration_s = 1.0;
  ToyApp() {
    app.require_subcommand(1);
    auto* commission = app.add_subcommand("commission", "");
    commission->add_option("--config", config, "")->required();
    commission->add_option("--duration-s", duration_s, "")->check(positive_number());
    app.add_subcommand("calibrate", "");
  }
  /// describe_parse_error of parsing `args`; "" when parsing succeeds.
  std::string message(std::vector<std::string> args) {
    args.insert(args.begin(), "toy");
    std::vector<const char*> argv;
    for (const auto& a : args) argv.push_back(a.c_str());
    try {
      app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
      return describe_parse_error(app, e);
    }
    return "";
  }
};

}  // namespace

TEST_CASE("edit_distance counts insertions, deletions, substitutions and adjacent transpositions", "[config]") {
  CHECK(edit_distance("", "") == 0);
  CHECK(edit_distance("abc", "") == 3);
  CHECK(edit_distance("", "abc") == 3);
  CHECK(edit_distance("commission", "commission") == 0);
  CHECK(edit_distance("comission", "commission") == 1);  // one insertion
  CHECK(edit_distance("--confg", "--config") == 1);
  CHECK(edit_distance("stauts", "status") == 1);  // one transposition
  CHECK(edit_distance("kitten", "sitting") == 3);
  CHECK(edit_distance("abc", "xyz") == 3);
}

TEST_CASE("nearest_name picks the closest candidate, the first on a tie, none when all are far", "[config]") {
  const std::vector<std::string> subcommands = {"calibrate", "identify", "ff-identify", "commutate", "commission"};
  CHECK(nearest_name("comission", subcommands) == "commission");
  CHECK(nearest_name("comutate", subcommands) == "commutate");
  CHECK(nearest_name("identfy", subcommands) == "identify");
  CHECK(nearest_name("xyzzy", subcommands).empty());
  CHECK(nearest_name("ab", {"ac", "bb"}) == "ac");  // both 1 away: the first
  CHECK(nearest_name("a", {"b"}) == "b");          // one edit is always allowed
  CHECK(nearest_name("anything", {}).empty());
}

TEST_CASE("the range checks print the typed value and readable bounds", "[config]") {
  CHECK(check(positive_number(), "2.5").empty());
  CHECK(check(positive_number(), "-1") == "-1 is not > 0");
  CHECK(check(positive_number(), "0") == "0 is not > 0");
  CHECK(check(non_negative_number(), "0").empty());
  CHECK(check(non_negative_number(), "-0.5") == "-0.5 is not >= 0");
  CHECK(check(at_least(1), "0") == "0 is not >= 1");
  CHECK(check(in_range(1, 127), "127").empty());
  CHECK(check(in_range(1, 127), "200") == "200 is not in [1, 127]");
  CHECK(check(in_range(0.01, 3600.0), "0.001") == "0.001 is not in [0.01, 3600]");
  CHECK(check(positive_number(), "abc") == "'abc' is not a number");
  CHECK(check(positive_number(), "") == "'' is not a number");
  CHECK(check(positive_number(), "3x") == "'3x' is not a number");
  CHECK(check(positive_number(), "inf") == "inf is not a finite number");
  CHECK(check(in_range(1, 127), "nan") == "nan is not a finite number");
}

TEST_CASE("a parse error names the mistyped subcommand or option with the nearest one", "[config]") {
  CHECK(ToyApp().message({"comission", "--config", "c.yaml"}) ==
        "unknown subcommand 'comission'; did you mean 'commission'?");
  CHECK(ToyApp().message({"frobnicate"}) == "unknown subcommand 'frobnicate' (one of: commission, calibrate)");
  CHECK(ToyApp().message({"commission", "--confg", "c.yaml"}) == "unknown option '--confg'; did you mean '--config'?");
  CHECK(ToyApp().message({"commission", "--config=c.yaml", "--duratoin-s=3"}) ==
        "unknown option '--duratoin-s'; did you mean '--duration-s'?");
  CHECK(ToyApp().message({"commission", "--config", "c.yaml", "--zzzzzzzz"}) == "unknown option '--zzzzzzzz'");
  CHECK(ToyApp().message({}) == "a subcommand is required: commission, calibrate");
  CHECK(ToyApp().message({"commission"}) == "--config is required");
  CHECK(ToyApp().message({"commission", "--config", "c.yaml", "--duration-s", "-1"}) == "--duration-s: -1 is not > 0");
  CHECK(ToyApp().message({"commission", "--config", "c.yaml"}).empty());
}
