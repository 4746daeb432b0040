// HMAC-SHA256 against the test vectors of RFC 4231, and the rules of the
// operators' key file (config/command_key.hpp).

#include <sys/stat.h>

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "config/command_key.hpp"
#include "config/regular_file.hpp"
#include "config/sha256.hpp"
#include "support/temporary_directory.hpp"

namespace {

std::vector<std::uint8_t> bytes(const std::string& text) { return {text.begin(), text.end()}; }

std::string hex(const clm::Sha256Digest& digest) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (std::uint8_t b : digest) {
    out += kHex[b >> 4];
    out += kHex[b & 0xf];
  }
  return out;
}

void write_file(const std::string& path, const std::string& content, mode_t mode) {
  std::ofstream(path, std::ios::binary) << content;
  REQUIRE(::chmod(path.c_str(), mode) == 0);
}

}  // namespace

TEST_CASE("HMAC-SHA256 gives the MACs of RFC 4231", "[command_key]") {
  SECTION("test case 1: a 20-byte key") {
    const std::vector<std::uint8_t> key(20, 0x0b);
    const auto data = bytes("Hi There");
    CHECK(hex(clm::HmacSha256(key).mac({data})) == "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  }
  SECTION("test case 2: a key shorter than the MAC") {
    const auto key = bytes("Jefe");
    const auto data = bytes("what do ya want for nothing?");
    CHECK(hex(clm::HmacSha256(key).mac({data})) == "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
  }
  SECTION("test case 6: a 131-byte key, hashed first") {
    const std::vector<std::uint8_t> key(131, 0xaa);
    const auto data = bytes("Test Using Larger Than Block-Size Key - Hash Key First");
    CHECK(hex(clm::HmacSha256(key).mac({data})) == "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
  }
  SECTION("parts are MACed as their concatenation, and a copy gives the same MAC") {
    const clm::HmacSha256 hmac(bytes("Jefe"));
    const auto whole = bytes("what do ya want for nothing?");
    const auto head = bytes("what do ya"), tail = bytes(" want for nothing?");
    const clm::HmacSha256 copy = hmac;
    CHECK(hmac.mac({head, tail}) == hmac.mac({whole}));
    CHECK(copy.mac({whole}) == hmac.mac({whole}));
  }
}

TEST_CASE("equal_in_constant_time compares bytes and lengths", "[command_key]") {
  const auto a = bytes("abcdef"), b = bytes("abcdeg"), c = bytes("abcde");
  CHECK(clm::equal_in_constant_time(a, a));
  CHECK_FALSE(clm::equal_in_constant_time(a, b));
  CHECK_FALSE(clm::equal_in_constant_time(a, c));
}

TEST_CASE("the command key file: size and mode are checked", "[command_key]") {
  clm::test::TemporaryDirectory dir("clm_command_key");
  const std::string good = dir.file("good.key");
  write_file(good, std::string(32, 'k'), 0640);
  SECTION("a 32-byte file readable by owner and group is the key itself") {
    const auto key = bytes(std::string(32, 'k'));
    const auto data = bytes("status");
    CHECK(clm::load_command_key(good).mac({data}) == clm::HmacSha256(key).mac({data}));
  }
  SECTION("too short") {
    write_file(good, std::string(31, 'k'), 0600);
    CHECK_THROWS_AS(clm::load_command_key(good), clm::FileError);
  }
  SECTION("too long") {
    write_file(good, std::string(4097, 'k'), 0600);
    CHECK_THROWS_AS(clm::load_command_key(good), clm::FileError);
  }
  SECTION("readable by others") {
    REQUIRE(::chmod(good.c_str(), 0644) == 0);
    try {
      clm::load_command_key(good);
      FAIL("a world-readable key was accepted");
    } catch (const clm::FileError& e) {
      CHECK(std::string(e.what()).find("mode 0644") != std::string::npos);
    }
  }
  SECTION("missing") { CHECK_THROWS_AS(clm::load_command_key(dir.file("absent.key")), clm::FileError); }
  SECTION("the default path follows the environment") {
    ::setenv(clm::kCommandKeyEnvironment, good.c_str(), 1);
    CHECK(clm::default_command_key_path() == good);
    ::setenv(clm::kCommandKeyEnvironment, "", 1);
    CHECK(clm::default_command_key_path() == clm::kDefaultCommandKeyPath);
    ::unsetenv(clm::kCommandKeyEnvironment);
  }
}
