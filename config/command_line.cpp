#include "config/command_line.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>

namespace clm {
namespace {

/// The app and the subcommands parsed below it, outermost first.
std::vector<const CLI::App*> parsed_chain(const CLI::App& app) {
  std::vector<const CLI::App*> chain{&app};
  while (!chain.back()->get_subcommands().empty()) chain.push_back(chain.back()->get_subcommands().front());
  return chain;
}

/// "-x", "--name", "--name=value"; not a negative number.
bool is_option(const std::string& argument) {
  return argument.size() > 1 && argument[0] == '-' && !(std::isdigit(static_cast<unsigned char>(argument[1])) != 0) &&
         argument[1] != '.';
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

/// "unknown <what> 'typed'; did you mean 'nearest'?", or without a near one
/// the list of `known` when `list_known`.
std::string unknown(const char* what, const std::string& typed, const std::vector<std::string>& known,
                    bool list_known) {
  const std::string nearest = nearest_name(typed, known);
  const std::string text = std::string("unknown ") + what + " '" + typed + "'";
  if (!nearest.empty()) return text + "; did you mean '" + nearest + "'?";
  return list_known && !known.empty() ? text + " (one of: " + join(known) + ")" : text;
}

/// "%g": short and readable (CLI11 prints a range with std::to_string, up to 300 digits).
std::string readable(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

/// The number `input` holds, or a message; the whole text must be a finite number.
std::optional<double> parse_number(const std::string& input, std::string& message) {
  const char* begin = input.c_str();
  char* end = nullptr;
  const double value = std::strtod(begin, &end);
  if (input.empty() || end != begin + input.size() || std::isspace(static_cast<unsigned char>(input[0])) != 0) {
    message = "'" + input + "' is not a number";
    return std::nullopt;
  }
  if (!std::isfinite(value)) {
    message = input + " is not a finite number";
    return std::nullopt;
  }
  return value;
}

CLI::Validator number_check(std::string description, std::function<bool(double)> accept, std::string refusal) {
  return CLI::Validator(
      [accept = std::move(accept), refusal = std::move(refusal)](std::string& input) -> std::string {
        std::string message;
        const auto value = parse_number(input, message);
        if (!value) return message;
        return accept(*value) ? std::string() : input + " " + refusal;
      },
      std::move(description));
}

void print_error(const CLI::App& app, const std::string& what) {
  const auto subcommands = app.get_subcommands();
  std::string prefix = app.get_name();
  if (!subcommands.empty()) prefix += " " + subcommands.front()->get_name();
  std::fprintf(stderr, "%s: error: %s\n", prefix.c_str(), what.c_str());
}

}  // namespace

std::string describe_parse_error(const CLI::App& app, const CLI::ParseError& error) {
  // Only these two leave arguments unparsed: a required subcommand or option
  // that a mistyped one stood for, or arguments nobody takes.
  if (dynamic_cast<const CLI::RequiredError*>(&error) == nullptr &&
      dynamic_cast<const CLI::ExtrasError*>(&error) == nullptr) {
    return error.what();
  }
  const auto chain = parsed_chain(app);
  std::vector<std::string> subcommands;
  for (const CLI::App* sub : chain.back()->get_subcommands([](const CLI::App*) { return true; })) {
    subcommands.push_back(sub->get_name());
  }
  const std::vector<std::string> arguments = app.remaining(true);
  for (const std::string& argument : arguments) {
    if (is_option(argument)) {
      std::vector<std::string> options;  // every app on the chain takes its options (fallthrough)
      for (const CLI::App* level : chain) {
        for (const CLI::Option* option : level->get_options()) {
          for (const auto& name : option->get_lnames()) options.push_back("--" + name);
        }
      }
      const std::string typed = argument.substr(0, argument.find('='));
      return unknown("option", typed, typed.rfind("--", 0) == 0 ? options : std::vector<std::string>{}, false);
    }
    if (!subcommands.empty()) return unknown("subcommand", argument, subcommands, true);
  }
  if (arguments.empty() && !subcommands.empty() && std::string(error.what()).find("subcommand") != std::string::npos) {
    return "a subcommand is required: " + join(subcommands);
  }
  return error.what();
}

int run_command_line(CLI::App& app, int argc, const char* const* argv, const std::function<int()>& run) {
  try {
    app.parse(argc, argv);
    return run ? run() : kExitSuccess;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help, --version
    print_error(app, describe_parse_error(app, e));
    return kExitBadInput;
  } catch (const RunTimeFailure& e) {
    print_error(app, e.what());
    return kExitFailure;
  } catch (const std::exception& e) {
    print_error(app, e.what());
    return kExitBadInput;
  }
}

CLI::Validator positive_number() {
  return number_check("POSITIVE", [](double x) { return x > 0.0; }, "is not > 0");
}

CLI::Validator non_negative_number() {
  return number_check("NONNEGATIVE", [](double x) { return x >= 0.0; }, "is not >= 0");
}

CLI::Validator at_least(double min) {
  return number_check(">= " + readable(min), [min](double x) { return x >= min; }, "is not >= " + readable(min));
}

CLI::Validator in_range(double min, double max) {
  const std::string range = "[" + readable(min) + ", " + readable(max) + "]";
  return number_check("in " + range, [min, max](double x) { return x >= min && x <= max; }, "is not in " + range);
}

}  // namespace clm
