// Input files are not trusted: every reader of the tools and the daemon (YAML,
// CSV, LCM logs, file hashes) reads only a regular file, opened without
// blocking, and no more than its size limit (config/regular_file.hpp); a CSV
// header names each column once and holds at most its row limit.
#include <catch2/catch.hpp>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>

#include "config/regular_file.hpp"
#include "support/bound_socket.hpp"
#include "config/yaml_reader.hpp"
#include "tools/data/csv_table.hpp"
#include "config/sha256.hpp"
#include "tools/lcmlog/data_input.hpp"
#include "tools/lcmlog/servo_log.hpp"

using namespace clm;
using namespace clm::data;
namespace fs = std::filesystem;

namespace {

class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    std::string pattern = (fs::temp_directory_path() / "clm_input_files_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TemporaryDirectory() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

void write_file(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
  REQUIRE(out.flush());
}

/// A file of `bytes` bytes that occupies no disk space (a hole).
void write_sparse_file(const std::string& path, std::uint64_t bytes) {
  write_file(path, "");
  fs::resize_file(path, bytes);
}

using clm::test::BoundSocket;

/// Runs `read` on `path` and checks it throws, within 5 s, a message that
/// starts with "<path>: not a regular file (<kind>)". A reader that blocked
/// on a FIFO would be killed by the alarm (SIGALRM), failing the test rather
/// than hanging it.
void check_refused_kind(const std::function<void(const std::string&)>& read, const std::string& path,
                        const std::string& kind) {
  INFO(path << " (" << kind << ")");
  const auto start = std::chrono::steady_clock::now();
  ::alarm(10);
  std::string message;
  try {
    read(path);
  } catch (const std::exception& e) {
    message = e.what();
  }
  ::alarm(0);
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));
  CHECK(message == path + ": not a regular file (" + kind + "); only regular files are read");
}

/// Every reader of input files, by name.
struct Reader {
  const char* name;
  std::function<void(const std::string&)> read;
};

std::vector<Reader> every_reader() {
  return {
      {"open_regular_file", [](const std::string& p) { open_regular_file(p, kUnlimitedBytes); }},
      {"read_regular_file", [](const std::string& p) { read_regular_file(p, 1000); }},
      {"sha256_file", [](const std::string& p) { sha256_file(p); }},
      {"yaml::Node::load_file", [](const std::string& p) { yaml::Node::load_file(p); }},
      {"CsvTable::load", [](const std::string& p) { CsvTable::load(p); }},
      {"lcmlog::is_lcm_log", [](const std::string& p) { lcmlog::is_lcm_log(p); }},
      {"lcmlog::read_servo_states", [](const std::string& p) { lcmlog::read_servo_states(p); }},
      {"lcmlog::load_data_table",
       [](const std::string& p) { lcmlog::load_data_table(p, lcmlog::CsvFormat::kExperiment); }},
  };
}

std::string message_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("a FIFO without a writer, a device, a directory and a socket are refused by every reader at once, "
          "naming the file and the kind",
          "[input_files]") {
  TemporaryDirectory dir;
  const std::string fifo = dir.file("data.fifo");
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const std::string socket_path = dir.file("data.sock");
  const BoundSocket socket(socket_path);
  const std::string directory = dir.file("data.d");
  fs::create_directory(directory);
  for (const Reader& reader : every_reader()) {
    INFO(reader.name);
    check_refused_kind(reader.read, fifo, "a FIFO");
    check_refused_kind(reader.read, "/dev/zero", "a character device");
    check_refused_kind(reader.read, "/dev/null", "a character device");
    check_refused_kind(reader.read, directory, "a directory");
    check_refused_kind(reader.read, socket_path, "a socket");
  }
  // The YAML reader's refusal is its own error type, as its other errors.
  CHECK_THROWS_AS(yaml::Node::load_file(fifo), yaml::Error);
  CHECK_THROWS_AS(open_regular_file(fifo, kUnlimitedBytes), FileError);
  // A missing file names the path and the system's reason.
  CHECK(message_of([&] { read_regular_file(dir.file("none"), 10); }) ==
        dir.file("none") + ": cannot open: No such file or directory");
}

TEST_CASE("read_regular_file gives a file's bytes up to its limit and refuses one byte more, naming file and limit",
          "[input_files]") {
  TemporaryDirectory dir;
  const std::string path = dir.file("text.bin");
  std::string content;
  for (int i = 0; i < 70000; ++i) content += static_cast<char>(i * 7 % 256);
  write_file(path, content);
  CHECK(read_regular_file(path, content.size()) == content);
  CHECK(read_regular_file(path, kUnlimitedBytes) == content);
  CHECK(message_of([&] { read_regular_file(path, content.size() - 1, " for a test (--max-bytes raises it)"); }) ==
        path + ": 70000 bytes, more than the limit of 69999 bytes for a test (--max-bytes raises it)");
  const RegularFile file = open_regular_file(path, content.size());
  CHECK(file.size_bytes() == content.size());
  CHECK(file.path() == path);
  write_file(path, "");
  CHECK(read_regular_file(path, 0).empty());
  // Files of /proc report size 0 and are read to their end.
  CHECK(read_regular_file("/proc/self/status", 1 << 20).find("Name:") != std::string::npos);
}

TEST_CASE("files beyond the default limits are refused at open, without being read", "[input_files]") {
  TemporaryDirectory dir;
  const std::string csv = dir.file("huge.csv");
  write_sparse_file(csv, DataLimits::kDefaultMaxBytes + 1);
  const auto start = std::chrono::steady_clock::now();
  const std::string expected = csv + ": " + std::to_string(DataLimits::kDefaultMaxBytes + 1) +
                               " bytes, more than the limit of " + std::to_string(DataLimits::kDefaultMaxBytes) +
                               " bytes for a data file (--max-bytes raises it)";
  CHECK(message_of([&] { CsvTable::load(csv); }) == expected);
  CHECK(message_of([&] { lcmlog::load_data_table(csv, lcmlog::CsvFormat::kExperiment); }) == expected);
  CHECK(message_of([&] { lcmlog::read_servo_states(csv); }) ==
        csv + ": " + std::to_string(DataLimits::kDefaultMaxBytes + 1) + " bytes, more than the limit of " +
            std::to_string(DataLimits::kDefaultMaxBytes) + " bytes for an LCM log (--max-bytes raises it)");
  const std::string yaml_file = dir.file("huge.yaml");
  write_sparse_file(yaml_file, yaml::Node::kMaxFileBytes + 1);
  CHECK(message_of([&] { yaml::Node::load_file(yaml_file); }) ==
        yaml_file + ": " + std::to_string(yaml::Node::kMaxFileBytes + 1) + " bytes, more than the limit of " +
            std::to_string(yaml::Node::kMaxFileBytes) + " bytes for a YAML file");
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(2));
  // With a raised limit the same file is read (and found to be no CSV).
  DataLimits limits;
  limits.max_bytes = DataLimits::kDefaultMaxBytes + 1;
  const std::string small = dir.file("small.csv");
  write_file(small, "a,b\n1,2\n");
  CHECK(CsvTable::load(small, limits).rows() == 1);
}

TEST_CASE("sha256_file streams the file: the FIPS 180-4 vectors and sha256_hex of the bytes at every block boundary",
          "[input_files]") {
  CHECK(sha256_hex("") == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  CHECK(sha256_hex("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  CHECK(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq") ==
        "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  TemporaryDirectory dir;
  const std::string path = dir.file("data.bin");
  write_file(path, "abc");
  CHECK(sha256_file(path) == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  const std::string million_a(1000000, 'a');
  write_file(path, million_a);
  CHECK(sha256_file(path) == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  for (std::size_t size : {0, 1, 55, 56, 63, 64, 65, 119, 120, 127, 128, 129, (1 << 20) - 1, 1 << 20, (1 << 20) + 65}) {
    std::string content(size, '\0');
    for (std::size_t i = 0; i < size; ++i) content[i] = static_cast<char>((i * 131 + 7) % 251);
    write_file(path, content);
    INFO(size << " bytes");
    CHECK(sha256_file(path) == sha256_hex(content));
  }
}

TEST_CASE("a CSV header naming a column twice is refused with the file, line 1 and the column", "[input_files]") {
  CHECK(message_of([] {
          CsvTable::parse("t_s,coil_set,delta_rad,magnitude_N,y_m,Fy_N,Fx_N,Tz_Nm,Fy_N\n0,1,0,1,0,1,0,0,2\n",
                          "data.csv");
        }) == "data.csv:1: column 'Fy_N' appears twice (columns 6 and 9)");
  // Names are compared after trimming, as they are looked up.
  CHECK(message_of([] { CsvTable::parse(" a ,b,a\t\n1,2,3\n", "x.csv"); }) ==
        "x.csv:1: column 'a' appears twice (columns 1 and 3)");
  // The header's own line, should blank lines come first.
  CHECK(message_of([] { CsvTable::parse("\n\na,a\n", "x.csv"); }) == "x.csv:3: column 'a' appears twice (columns 1 and 2)");
  CHECK(message_of([] { CsvTable::parse("a,,b,\n", "x.csv"); }) == "x.csv:1: column '' appears twice (columns 2 and 4)");
  // The first repeat in the header's order is named.
  CHECK(message_of([] { CsvTable::parse("a,b,b,a\n", "x.csv"); }) == "x.csv:1: column 'b' appears twice (columns 2 and 3)");
  CHECK_THROWS_AS(CsvTable::from_columns("run.lcm", {"t_s", "t_s"}, {{1.0}, {2.0}}), std::invalid_argument);
  const CsvTable table = CsvTable::parse("a,b,c\n1,2,3\n4, 5 ,6\r\n", "x.csv");
  CHECK(table.numbers("b") == std::vector<double>{2.0, 5.0});
  CHECK(table.numbers("c") == std::vector<double>{3.0, 6.0});
}

TEST_CASE("CsvTable reads up to its row limit and refuses one row more naming file, line and limit",
          "[input_files]") {
  std::string text = "t_s,y_m\n";
  for (int r = 0; r < 100; ++r) text += std::to_string(r) + "," + std::to_string(r * 0.5) + "\n";
  CHECK(CsvTable::parse(text, "data.csv", 100).rows() == 100);
  CHECK(message_of([&] { CsvTable::parse(text, "data.csv", 99); }) ==
        "data.csv:101: more than 99 data rows, the limit (--max-rows raises it)");
  CHECK(message_of([&] { CsvTable::parse(text, "data.csv", 0); }) ==
        "data.csv:2: more than 0 data rows, the limit (--max-rows raises it)");
  TemporaryDirectory dir;
  const std::string path = dir.file("data.csv");
  write_file(path, text);
  DataLimits limits;
  limits.max_rows = 99;
  CHECK(message_of([&] { CsvTable::load(path, limits); }) ==
        path + ":101: more than 99 data rows, the limit (--max-rows raises it)");
  limits.max_rows = 100;
  limits.max_bytes = text.size();
  const CsvTable table = CsvTable::load(path, limits);
  CHECK(table.rows() == 100);
  CHECK(table.numbers("y_m")[99] == 49.5);
  limits.max_bytes = text.size() - 1;
  CHECK(message_of([&] { CsvTable::load(path, limits); }) ==
        path + ": " + std::to_string(text.size()) + " bytes, more than the limit of " +
            std::to_string(text.size() - 1) + " bytes for a data file (--max-bytes raises it)");
}
