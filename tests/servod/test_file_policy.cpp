// Which files a command may load (daemon/servod/file_policy.hpp): inside the
// configured directories after resolving links and "..", regular, within the
// size limit; refusals name the path and the rule, never the contents.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "daemon/servod/file_policy.hpp"

using namespace clm::servod;
namespace fs = std::filesystem;

namespace {

struct Tree {
  fs::path root = fs::temp_directory_path() / ("clm_file_policy_" + std::to_string(::getpid()));
  Tree() {
    fs::remove_all(root);
    fs::create_directories(root / "allowed" / "sub");
    fs::create_directories(root / "private");
    std::ofstream(root / "allowed" / "model.yaml") << "kind: pgnn\n";
    std::ofstream(root / "allowed" / "sub" / "big.yaml") << std::string(5000, 'x');
    std::ofstream(root / "private" / "secret.yaml") << "kind: SECRET\n";
    fs::create_symlink(root / "private" / "secret.yaml", root / "allowed" / "link.yaml");
    fs::create_directories(root / "allowed-not");
    std::ofstream(root / "allowed-not" / "x.yaml") << "kind: pgnn\n";
  }
  ~Tree() { fs::remove_all(root); }
  FilePolicy policy() const { return {{fs::canonical(root / "allowed").string()}, 4096}; }
};

}  // namespace

TEST_CASE("a regular file inside a configured directory is loadable, by its canonical path", "[files]") {
  Tree tree;
  std::string canonical;
  CHECK(check_loadable(tree.policy(), (tree.root / "allowed" / "model.yaml").string(), canonical) == "");
  CHECK(canonical == fs::canonical(tree.root / "allowed" / "model.yaml").string());
  CHECK(check_loadable(tree.policy(), (tree.root / "allowed" / "sub" / ".." / "model.yaml").string(), canonical) == "");
}

TEST_CASE("paths outside, through links or '..', directories, large files and relative paths are refused",
          "[files]") {
  Tree tree;
  std::string canonical = "unchanged";
  const auto refused = [&](const fs::path& path, const char* rule) {
    const std::string reason = check_loadable(tree.policy(), path.string(), canonical);
    INFO(reason);
    CHECK_THAT(reason, Catch::Contains(path.string()) && Catch::Contains(rule));
    CHECK_FALSE(Catch::Contains("SECRET").match(reason));
  };
  refused(tree.root / "private" / "secret.yaml", "outside");
  refused(tree.root / "allowed" / "link.yaml", "outside");
  refused(tree.root / "allowed" / ".." / "private" / "secret.yaml", "outside");
  refused(tree.root / "allowed-not" / "x.yaml", "outside");  // a prefix of the name is not the directory
  refused(tree.root / "allowed" / "sub", "not a regular file");
  refused(tree.root / "allowed" / "sub" / "big.yaml", "over the limit");
  refused(tree.root / "allowed" / "missing.yaml", "No such file");
  CHECK_THAT(check_loadable(tree.policy(), "model.yaml", canonical), Catch::Contains("absolute"));
  CHECK(canonical == "unchanged");
}
