#include "cli/cli_support.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "support/daemon_experiments.hpp"
#include "tools/data/csv_table.hpp"

extern char** environ;

namespace clm::cli_test {
namespace fs = std::filesystem;
using data::shortest_double;
using data::write_csv_atomically;

namespace {

std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  std::string cell;
  while (std::getline(stream, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

std::string join_cells(const std::vector<std::string>& cells) {
  std::string line;
  for (std::size_t c = 0; c < cells.size(); ++c) line += (c > 0 ? "," : "") + cells[c];
  return line;
}

}  // namespace

std::vector<std::string> ProcessResult::err_lines() const {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < err.size()) {
    const std::size_t end = err.find('\n', start);
    lines.push_back(err.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return lines;
}

ProcessResult run_program(const std::string& binary, const std::vector<std::string>& args) {
  // Captures live in a directory of their own so that listings of the
  // directory under test see only what the program wrote.
  static const TemporaryDirectory captures("clm_cli_tests");
  const std::string out_path = captures.file("stdout");
  const std::string err_path = captures.file("stderr");

  std::vector<std::string> argv_strings = {binary};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, binary.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error(binary + ": cannot spawn: " + std::strerror(spawned));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
  }
  ProcessResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = read_file(out_path);
  result.err = read_file(err_path);
  return result;
}

ProcessResult run_clm(const std::vector<std::string>& args) { return run_program(CLM_BINARY, args); }

ProcessResult run_servod(const std::vector<std::string>& args) { return run_program(CLM_SERVOD_BINARY, args); }

std::set<std::string> listing(const std::string& directory) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(directory)) names.insert(entry.path().filename().string());
  return names;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_file(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
  if (!out.flush()) throw std::runtime_error(path + ": cannot write");
}

std::string source_path(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

std::string join_lines(const CsvLines& lines) {
  std::string text;
  for (const auto& line : lines) text += line + "\n";
  return text;
}

std::size_t column_index(const CsvLines& lines, const std::string& column) {
  const auto header = split_cells(lines.at(0));
  for (std::size_t c = 0; c < header.size(); ++c) {
    if (header[c] == column) return c;
  }
  throw std::invalid_argument("no column " + column);
}

void set_cell(CsvLines& lines, std::size_t line_number, const std::string& column, const std::string& text) {
  const std::size_t c = column_index(lines, column);
  auto cells = split_cells(lines.at(line_number - 1));
  cells.at(c) = text;
  lines[line_number - 1] = join_cells(cells);
}

void drop_column(CsvLines& lines, const std::string& column) {
  const std::size_t c = column_index(lines, column);
  for (auto& line : lines) {
    auto cells = split_cells(line);
    cells.erase(cells.begin() + static_cast<std::ptrdiff_t>(c));
    line = join_cells(cells);
  }
}

CsvLines synthetic_experiment_lines(int coil_sets, int rows_per_offset) {
  CsvLines lines = {"t_s,coil_set,delta_rad,magnitude_N,y_m,Fy_N,Fx_N,Tz_Nm"};
  int k = 0;
  for (int l = 1; l <= coil_sets; ++l) {
    for (double delta : {-kPi / 4, kPi / 4}) {
      for (int r = 0; r < rows_per_offset; ++r, ++k) {
        const double y = -0.05 + 0.1 * r / rows_per_offset;
        const double magnitude = 20.0 * std::sin(0.7 * r);
        const double fy = 0.8 * magnitude * std::cos(delta);
        lines.push_back(shortest_double(0.001 * k) + "," + std::to_string(l) + "," + shortest_double(delta) + "," +
                        shortest_double(magnitude) + "," + shortest_double(y) + "," + shortest_double(fy) + ",0.1,0.01");
      }
    }
  }
  return lines;
}

CsvLines synthetic_feedforward_lines(int rows) {
  CsvLines lines = {"t_s,r_m,F_star_N"};
  for (int k = 0; k < rows; ++k) {
    const double t = 0.001 * k;
    const double r = 0.01 * std::sin(20.0 * t);
    const double force = 15.0 * -4.0 * std::sin(20.0 * t) + 40.0 * 0.2 * std::cos(20.0 * t) + 5.0;
    lines.push_back(shortest_double(t) + "," + shortest_double(r) + "," + shortest_double(force));
  }
  return lines;
}

namespace {
const char* const kExperimentsComplete = "complete";
}  // namespace

ExperimentFiles experiment_files_in(const std::string& directory) {
  const fs::path d(directory);
  return {(d / "experiments.csv").string(), (d / "experiments-tenth.csv").string(),
          (d / "experiments.lcm").string(), (d / "closed-loop.csv").string()};
}

void write_experiment_files(const std::string& directory) {
  fs::create_directories(directory);
  fs::remove(fs::path(directory) / kExperimentsComplete);
  const ExperimentFiles files = experiment_files_in(directory);
  const std::string lcm_partial = files.lcm + ".partial";
  const test::DaemonExperiments experiments = test::run_daemon_experiments(source_path("config/servod.yaml"), lcm_partial);
  fs::rename(lcm_partial, files.lcm);
  const auto all = test::experiment_columns(experiments);
  write_csv_atomically(files.csv, all.names, all.values);
  const auto tenth = test::experiment_columns(experiments, 0, 10);
  write_csv_atomically(files.tenth, tenth.names, tenth.values);
  std::vector<std::vector<double>> closed_loop(3);
  for (const auto& s : experiments.runs.front().samples) {
    closed_loop[0].push_back(s.program_time_s);
    closed_loop[1].push_back(s.r_m);
    closed_loop[2].push_back(s.F_star_N);
  }
  const std::vector<std::string> names = {"t_s", "r_m", "F_star_N"};
  write_csv_atomically(files.closed_loop, names, closed_loop);
  write_file((fs::path(directory) / kExperimentsComplete).string(), "");
}

const ExperimentFiles& experiment_files() {
  struct Holder {
    TemporaryDirectory directory;  // unused when the fixture's files are there
    ExperimentFiles files;
  };
  static const std::unique_ptr<Holder> holder = [] {
    auto h = std::make_unique<Holder>();
    const char* fixture = std::getenv("CLM_TEST_EXPERIMENTS");
    if (fixture != nullptr && *fixture != '\0') {
      if (!fs::exists(fs::path(fixture) / kExperimentsComplete))
        throw std::runtime_error(std::string("CLM_TEST_EXPERIMENTS=") + fixture +
                                 ": no complete experiments there (the CTest fixture cli_experiments writes them)");
      h->files = experiment_files_in(fixture);
    } else {
      write_experiment_files(h->directory.path());
      h->files = experiment_files_in(h->directory.path());
    }
    return h;
  }();
  return holder->files;
}

}  // namespace clm::cli_test
