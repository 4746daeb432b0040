// Input files the tools do not trust, on the real binary: a FIFO without a
// writer, a device, a directory or a socket given as input, a CSV header that
// names a column twice, and data beyond --max-bytes or --max-rows are refused
// at once with status 2, exactly one line on stderr naming the file and the
// rule, and nothing written (no output, no temporary file, an existing output
// left byte for byte).
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "cli/cli_support.hpp"
#include "commutation/model_file.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/servo_log.hpp"
#include "support/bound_socket.hpp"

extern char** environ;

using namespace clm;
using namespace clm::cli_test;
namespace fs = std::filesystem;

namespace {

const std::string kMotor = source_path("config/motor-sim.yaml");

std::string output_of(const std::vector<std::string>& args) {
  const auto at = std::find(args.begin(), args.end(), "--output");
  REQUIRE(at + 1 < args.end());
  return *(at + 1);
}

/// Runs clm with `args`; should it still run after 10 s (a reader blocked on
/// the FIFO `fifo`), opens the FIFO for writing and closes it, so that the
/// reader sees an end of file and the test fails instead of hanging.
ProcessResult run_clm_unblocking(const std::vector<std::string>& args, const std::string& fifo) {
  std::atomic<bool> done{false};
  std::thread unblocker([&] {
    const auto start = std::chrono::steady_clock::now();
    while (!done) {
      if (!fifo.empty() && std::chrono::steady_clock::now() - start > std::chrono::seconds(10)) {
        const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
        if (fd >= 0) ::close(fd);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  const ProcessResult result = run_clm(args);
  done = true;
  unblocker.join();
  return result;
}

/// The refusal contract with status 2: run without and with an existing
/// output; stderr exactly "clm <subcommand>: error: <expected>"; the output's
/// directory unchanged; within 5 s (nothing waits on a FIFO, nothing reads
/// a huge file).
void check_refused(const std::vector<std::string>& args, const std::string& expected, const std::string& fifo = "") {
  const std::string output = output_of(args);
  const std::string directory = fs::path(output).parent_path().string();
  fs::remove(output);
  const auto before = listing(directory);
  std::string command = "clm";
  for (const auto& a : args) command += " " + a;
  INFO(command);
  {
    const auto start = std::chrono::steady_clock::now();
    const ProcessResult result = run_clm_unblocking(args, fifo);
    CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));
    INFO("stderr: " << result.err);
    CHECK(result.exit_code == 2);
    const auto lines = result.err_lines();
    REQUIRE(lines.size() == 1);
    CHECK(lines[0] == "clm " + args[0] + ": error: " + expected);
    CHECK(listing(directory) == before);
  }
  const std::string previous = "an output of an earlier run\n";
  write_file(output, previous);
  const ProcessResult again = run_clm_unblocking(args, fifo);
  INFO("stderr: " << again.err);
  CHECK(again.exit_code == 2);
  CHECK(again.err_lines().size() == 1);
  CHECK(read_file(output) == previous);
  auto with_output = before;
  with_output.insert(fs::path(output).filename().string());
  CHECK(listing(directory) == with_output);
  fs::remove(output);
}

void require_success(const std::vector<std::string>& args) {
  const ProcessResult result = run_clm(args);
  INFO("clm " << args.front() << ": " << result.err);
  REQUIRE(result.exit_code == 0);
}

/// A calibration of config/motor-sim.yaml's shape, in `out`, for commutate.
std::string calibration_in(const std::string& out) {
  CalibrationFile file;
  file.pole_pitch_m = 0.03;
  file.drive = {67.0, -0.52};
  file.method = "algorithm1";
  for (int l = 0; l < 3; ++l) {
    CalibrationFile::CoilSet c;
    c.estimate = {61.0 - l, -0.54};
    c.delta_rad = {-kPi / 4, kPi / 4};
    c.gain_ratio = {0.9, 0.9};
    c.residual_rms_N = {1.0, 1.0};
    file.coil_sets.push_back(c);
  }
  const std::string path = out + "/calibration-in.yaml";
  write_file(path, format_calibration_file(file));
  return path;
}

/// Every subcommand that reads a data file, with `data` as that file, writing into `out`.
std::vector<std::vector<std::string>> data_readers(const std::string& out, const std::string& data) {
  return {{"calibrate", "--motor", kMotor, "--data", data, "--output", out + "/calibration.yaml"},
          {"identify", "--motor", kMotor, "--data", data, "--output", out + "/model.yaml", "--model", "spline"},
          {"ff-identify", "--data", data, "--output", out + "/feedforward.yaml"},
          {"commutate", "--motor", kMotor, "--calibration", calibration_in(out), "--input", data,
           "--output", out + "/setpoints.csv"},
          {"log2csv", "--log", data, "--output", out + "/log.csv", "--format", "full"}};
}

using clm::test::BoundSocket;

/// Runs clm with `args` (output to /dev/null) and returns its exit status and
/// its peak resident memory, VmHWM of /proc/<pid>/status read every 2 ms until
/// it exits. (wait4's ru_maxrss would not do: it includes this process's own
/// peak, which the child shares until its exec.)
std::pair<int, long> run_clm_peak_kB(const std::vector<std::string>& args) {
  std::vector<std::string> argv_strings = {CLM_BINARY};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, CLM_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  REQUIRE(spawned == 0);
  const std::string status_path = "/proc/" + std::to_string(pid) + "/status";
  long peak = 0;
  int status = 0;
  while (true) {
    {
      std::ifstream in(status_path);
      std::string line;
      while (std::getline(in, line)) {
        if (line.rfind("VmHWM:", 0) == 0) peak = std::max(peak, std::stol(line.substr(6)));
      }
    }
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    REQUIRE(done == 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), peak};
}

std::string not_regular(const std::string& path, const std::string& kind) {
  return path + ": not a regular file (" + kind + "); only regular files are read";
}

}  // namespace

TEST_CASE("a FIFO without a writer, /dev/zero, a directory or a socket as input is refused at once with status 2, "
          "one line naming the file and the rule, nothing written",
          "[cli][input_files]") {
  TemporaryDirectory dir;
  const std::string fifo = dir.file("data.fifo");
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const std::string socket_path = dir.file("data.sock");
  const BoundSocket socket(socket_path);
  const std::string directory = dir.file("data.d");
  fs::create_directory(directory);
  TemporaryDirectory out;
  for (const auto& [path, kind] : {std::pair<std::string, std::string>{fifo, "a FIFO"},
                                   {"/dev/zero", "a character device"},
                                   {directory, "a directory"},
                                   {socket_path, "a socket"}}) {
    for (const auto& args : data_readers(out.path(), path)) check_refused(args, not_regular(path, kind), fifo);
  }
  // The YAML files are read through the same function: a FIFO as the motor file.
  const std::string data = dir.file("data.csv");
  write_file(data, join_lines(synthetic_experiment_lines(3)));
  check_refused({"calibrate", "--motor", fifo, "--data", data, "--output", out.file("calibration.yaml")},
                not_regular(fifo, "a FIFO"), fifo);
  check_refused({"identify", "--motor", "/dev/zero", "--data", data, "--output", out.file("model.yaml")},
                not_regular("/dev/zero", "a character device"));
  const std::string motor_directory = dir.file("motor.d");
  fs::create_directory(motor_directory);
  check_refused({"commutate", "--motor", motor_directory, "--calibration", calibration_in(out.path()), "--input", data,
                 "--output", out.file("setpoints.csv")},
                not_regular(motor_directory, "a directory"));
  check_refused({"commutate", "--motor", kMotor, "--model", fifo, "--input", data, "--output", out.file("setpoints.csv")},
                not_regular(fifo, "a FIFO"), fifo);
}

TEST_CASE("a CSV naming a column twice is refused by every reader with the file, line 1 and the column",
          "[cli][input_files]") {
  TemporaryDirectory dir;
  // Fy_N twice, the second a copy of Fx_N: read as Fy_N, it used to give
  // calibrate's k = 0.24 N/A with status 0.
  auto lines = synthetic_experiment_lines(3);
  const std::size_t fx = column_index(lines, "Fx_N");
  for (auto& line : lines) {
    std::size_t at = 0;
    for (std::size_t c = 0; c < fx; ++c) at = line.find(',', at) + 1;
    line += "," + line.substr(at, line.find(',', at) - at);
  }
  lines[0] = "t_s,coil_set,delta_rad,magnitude_N,y_m,Fy_N,Fx_N,Tz_Nm,Fy_N";
  const std::string data = dir.file("data.csv");
  write_file(data, join_lines(lines));
  TemporaryDirectory out;
  const auto readers = data_readers(out.path(), data);
  for (std::size_t k = 0; k < 2; ++k) check_refused(readers[k], data + ":1: column 'Fy_N' appears twice (columns 6 and 9)");
  // ff-identify and commutate read their own columns, but the rule is the header's.
  auto feedforward = synthetic_feedforward_lines();
  feedforward[0] = "t_s,r_m,r_m";
  write_file(data, join_lines(feedforward));
  check_refused(readers[2], data + ":1: column 'r_m' appears twice (columns 2 and 3)");
  write_file(data, "y_m,Fy_N,Fx_N,Tz_Nm,y_m\n0,1,2,3,4\n");
  check_refused(readers[3], data + ":1: column 'y_m' appears twice (columns 1 and 5)");
}

TEST_CASE("a CSV beyond --max-bytes or --max-rows is refused naming the file, the limit and the option, at the "
          "limit it is read",
          "[cli][input_files]") {
  TemporaryDirectory dir;
  const std::string data = dir.file("data.csv");
  const auto lines = synthetic_experiment_lines(3);  // 48 data rows
  const std::string text = join_lines(lines);
  write_file(data, text);
  const std::string bytes = std::to_string(text.size());
  const std::string fewer_bytes = std::to_string(text.size() - 1);
  TemporaryDirectory out;
  for (std::size_t k = 0; k < 2; ++k) {
    auto args = data_readers(out.path(), data)[k];
    auto rows = args;
    rows.insert(rows.end(), {"--max-rows", "47"});
    check_refused(rows, data + ":49: more than 47 data rows, the limit (--max-rows raises it)");
    auto size = args;
    size.insert(size.end(), {"--max-bytes", fewer_bytes});
    check_refused(size, data + ": " + bytes + " bytes, more than the limit of " + fewer_bytes +
                            " bytes for a data file (--max-bytes raises it)");
    args.insert(args.end(), {"--max-rows", "48", "--max-bytes", bytes});
    require_success(args);
  }
  // commutate's --input and ff-identify's --data take the same limits.
  write_file(data, join_lines(synthetic_feedforward_lines(50)));
  auto ff = data_readers(out.path(), data)[2];
  ff.insert(ff.end(), {"--max-rows", "49"});
  check_refused(ff, data + ":51: more than 49 data rows, the limit (--max-rows raises it)");
  write_file(data, "y_m,Fy_N,Fx_N,Tz_Nm\n0,1,2,3\n0.01,1,2,3\n");
  auto commutate = data_readers(out.path(), data)[3];
  commutate.insert(commutate.end(), {"--max-rows", "1"});
  check_refused(commutate, data + ":3: more than 1 data rows, the limit (--max-rows raises it)");
}

TEST_CASE("a file beyond the default size limit is refused at open without being read", "[cli][input_files]") {
  TemporaryDirectory dir;
  const std::string data = dir.file("huge.csv");
  write_file(data, "");
  fs::resize_file(data, data::DataLimits::kDefaultMaxBytes + 1);  // a hole: no disk space, no memory
  TemporaryDirectory out;
  const std::string limit = " bytes, more than the limit of " + std::to_string(data::DataLimits::kDefaultMaxBytes);
  const std::string size = std::to_string(data::DataLimits::kDefaultMaxBytes + 1);
  for (const auto& args : data_readers(out.path(), data)) {
    check_refused(args, data + ": " + size + limit +
                            (args[0] == "log2csv" ? " bytes for an LCM log (--max-bytes raises it)"
                                                  : " bytes for a data file (--max-bytes raises it)"));
  }
}

TEST_CASE("an LCM log beyond --max-bytes or --max-rows is refused naming the log, the limit and the option",
          "[cli][input_files][lcm]") {
  const ExperimentFiles& files = experiment_files();
  const lcmlog::ServoStateLog log = lcmlog::read_servo_state_log(files.lcm);
  REQUIRE(log.states.size() > 1000);
  const std::string bytes = std::to_string(fs::file_size(files.lcm));
  const std::string fewer_bytes = std::to_string(fs::file_size(files.lcm) - 1);
  TemporaryDirectory out;
  auto readers = data_readers(out.path(), files.lcm);
  readers.erase(readers.begin() + 3);  // commutate reads CSV only
  for (auto args : readers) {
    auto rows = args;
    rows.insert(rows.end(), {"--max-rows", "1000"});
    check_refused(rows, files.lcm + ": event " + std::to_string(log.events[1000]) +
                            ": more than 1000 CLM_SERVO_STATE messages, the limit (--max-rows raises it)");
    auto size = args;
    size.insert(size.end(), {"--max-bytes", fewer_bytes});
    check_refused(size, files.lcm + ": " + bytes + " bytes, more than the limit of " + fewer_bytes +
                            " bytes for an LCM log (--max-bytes raises it)");
  }
  auto args = readers[0];
  args.insert(args.end(), {"--max-rows", std::to_string(log.states.size()), "--max-bytes", bytes});
  require_success(args);
}

#if defined(__SANITIZE_ADDRESS__)
#define CLM_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CLM_ADDRESS_SANITIZER 1
#endif
#endif

TEST_CASE("identify's peak memory grows linearly with the rows, at most 0.35 GB per million CSV rows with the spline",
          "[cli][input_files][memory]") {
#ifdef CLM_ADDRESS_SANITIZER
  // AddressSanitizer's shadow memory and quarantine are not the program's
  // memory: the figure is measured on the normal build only.
  WARN("not measured under AddressSanitizer");
  return;
#endif
  // The commissioning's experiments tiled to 200 000, 400 000 and 800 000
  // rows, each copy's t_s shifted by 200 s (as tests/bench/tile_experiments.py;
  // docs/benchmarks.md, "Memory of clm identify": 0.24 GB per million rows).
  TemporaryDirectory dir;
  const std::vector<std::size_t> sizes = {200000, 400000, 800000};
  {
    const std::string source = read_file(experiment_files().csv);
    const std::size_t header_end = source.find('\n') + 1;
    std::vector<std::pair<double, std::string>> rows;
    for (std::size_t at = header_end; at < source.size();) {
      const std::size_t end = source.find('\n', at);
      const std::string line = source.substr(at, end - at);
      const std::size_t comma = line.find(',');
      rows.emplace_back(std::stod(line.substr(0, comma)), line.substr(comma));
      at = end + 1;
    }
    for (std::size_t n : sizes) {
      std::string text = source.substr(0, header_end);
      text.reserve(n * 90);
      for (std::size_t k = 0; k < n; ++k) {
        const auto& [t, rest] = rows[k % rows.size()];
        text += data::shortest_double(t + 200.0 * static_cast<double>(k / rows.size())) + rest + "\n";
      }
      write_file(dir.file("exp-" + std::to_string(n) + ".csv"), text);
    }
  }
  std::vector<long> peak_kB;
  for (std::size_t n : sizes) {
    const auto [status, peak] = run_clm_peak_kB({"identify", "--motor", kMotor, "--data",
                                                 dir.file("exp-" + std::to_string(n) + ".csv"), "--output",
                                                 dir.file("model.yaml"), "--model", "spline"});
    INFO(n << " rows");
    REQUIRE(status == 0);
    peak_kB.push_back(peak);
  }
  INFO("peak resident memory [kB] at 200k, 400k, 800k rows: " << peak_kB[0] << ", " << peak_kB[1] << ", " << peak_kB[2]);
  // No faster than linear: twice and four times the rows, at most twice and
  // four times the memory.
  CHECK(peak_kB[1] <= 2 * peak_kB[0]);
  CHECK(peak_kB[2] <= 4 * peak_kB[0]);
  // At most 350 bytes a row more.
  CHECK(static_cast<double>(peak_kB[2] - peak_kB[0]) * 1024.0 <= 350.0 * static_cast<double>(sizes[2] - sizes[0]));
}
