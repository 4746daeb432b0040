// clm scope: a live oscilloscope on the state stream of a running clm-servod
// (or on an LCM log): chosen channels, a time base, a trigger on any field,
// auto / normal / single, pause, export of the shown window to CSV and PNG.
// In the terminal (over ssh as at the machine); --batch captures to files
// without one (docs/scope.md).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "config/command_line.hpp"
#include "config/exit_status.hpp"
#include "tools/cli/commands.hpp"
#include "tools/cli/share_script.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/state_fields.hpp"
#include "tools/scope/acquisition.hpp"
#include "tools/scope/render.hpp"
#include "tools/scope/sources.hpp"
#include "tools/scope/terminal.hpp"
#include "tools/servod_client/client.hpp"
#include "tools/servod_client/stop_signals.hpp"

namespace clm::cli {

namespace {

struct ScopeOptions {
  std::string lcm_url = servod_client::default_lcm_url();
  std::string key_file;
  std::string log_path;
  double speed = 1.0;
  std::vector<std::string> channels{"y_m", "e_m", "F_star_N"};
  std::string trigger_field;
  double level = 0.0;
  std::string edge = "rising";
  std::string mode;  // default: auto without a trigger, normal with one
  double pre_trigger = 0.2;
  double window_s = 0.5;
  std::string out_dir = ".";
  std::string name;
  bool batch = false;
  int captures = 1;
  double timeout_s = 60.0;
  bool no_colour = false;
};

/// The channels drawn: those asked for, and the trigger's field when it is
/// not among them.
std::vector<lcmlog::StateField> channel_fields(const ScopeOptions& o) {
  std::vector<lcmlog::StateField> fields;
  for (const std::string& channel : o.channels) fields.push_back(lcmlog::find_state_field(channel));
  if (!o.trigger_field.empty() && std::none_of(fields.begin(), fields.end(), [&](const auto& f) {
        return f.name == o.trigger_field;
      })) {
    fields.push_back(lcmlog::find_state_field(o.trigger_field));
  }
  return fields;
}

std::string default_name() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[40];
  std::strftime(buffer, sizeof(buffer), "scope-%Y%m%dT%H%M%SZ", &utc);
  return buffer;
}

/// The shown window into DIR/NAME-<n>.csv (t_s, t_minus_trigger_s, the
/// channels) and .png; one line saying what was written.
std::string export_window(const scope::Window& window, const std::vector<lcmlog::StateField>& fields,
                          const scope::Trigger& trigger, const ScopeOptions& o, const std::string& name, int number) {
  if (window.empty()) return "nothing to export: no window shown yet";
  const std::string base = (std::filesystem::path(o.out_dir) / (name + "-" + std::to_string(number))).string();
  std::vector<std::string> columns{"t_s", "t_minus_trigger_s"};
  std::vector<std::vector<double>> values{window.t_s, window.t_s};
  const double reference_s = window.triggered() ? window.trigger_t_s : window.start_s + window.length_s;
  for (double& t : values[1]) t -= reference_s;
  for (std::size_t c = 0; c < fields.size(); ++c) {
    columns.push_back(fields[c].name);
    values.push_back(window.values[c]);
  }
  data::write_csv_atomically(base + ".csv", columns, values);
  std::vector<std::string> arguments{base + ".csv", base + ".png"};
  if (window.triggered() && trigger.channel >= 0) {
    char level[32];
    std::snprintf(level, sizeof(level), "%.17g", trigger.level);
    arguments.insert(arguments.end(), {"--trigger-channel", fields[static_cast<std::size_t>(trigger.channel)].name,
                                       "--level", level, "--edge", scope::name(trigger.edge)});
  }
  const bool png = run_share_script("plot_capture.py", arguments);
  return (window.triggered() ? "capture " + std::to_string(window.number) : std::string("rolling window")) + ", " +
         std::to_string(window.t_s.size()) + " states" + scope::missing_note(window) + ": " + base + ".csv" +
         (png ? ", " + base + ".png" : " (no PNG: plot_capture.py or python3-matplotlib missing)");
}

void push_all(std::vector<servo::CycleRecord>& states, const std::vector<lcmlog::StateField>& fields,
              scope::Acquisition& acquisition, const std::function<void()>& on_capture) {
  std::vector<double> values(fields.size());
  for (const auto& state : states) {
    for (std::size_t c = 0; c < fields.size(); ++c) values[c] = fields[c].value(state);
    const auto before = acquisition.captures();
    acquisition.push(state.t_s, state.cycle, values);
    if (acquisition.captures() != before) on_capture();
  }
  states.clear();
}

/// --batch: captures until `captures` windows are exported or the time is up.
void run_batch(const ScopeOptions& o, scope::StateSource& source, scope::Acquisition& acquisition,
               const std::vector<lcmlog::StateField>& fields, const std::string& name) {
  int exported = 0;
  const auto start = std::chrono::steady_clock::now();
  std::vector<servo::CycleRecord> states;
  while (exported < o.captures) {
    servod_client::throw_if_interrupted();
    source.take(states);
    const bool last = source.exhausted();
    push_all(states, fields, acquisition, [&] {
      if (exported >= o.captures) return;
      std::printf("%s\n", export_window(acquisition.shown(), fields, acquisition.trigger(), o, name, ++exported).c_str());
      std::fflush(stdout);
      if (acquisition.trigger().mode == scope::TriggerMode::kSingle) acquisition.arm();
    });
    if (exported >= o.captures) break;
    if (last) {
      throw RunTimeFailure(std::to_string(exported) + " of " + std::to_string(o.captures) +
                           " captures: the log ended (" + source.describe() + ")");
    }
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > o.timeout_s) {
      throw RunTimeFailure(std::to_string(exported) + " of " + std::to_string(o.captures) + " captures within " +
                           servod_client::seconds(o.timeout_s) + " (" + source.describe() + ")");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// In the terminal, until q or a signal.
void run_interactive(const ScopeOptions& o, scope::StateSource& source, scope::Acquisition& acquisition,
                     const std::vector<lcmlog::StateField>& fields, const std::string& name) {
  scope::Terminal terminal;
  scope::ScreenText text;
  for (const auto& f : fields) text.channels.push_back(f.name);
  text.colour = !o.no_colour && std::getenv("NO_COLOR") == nullptr;
  int exported = 0;
  std::vector<servo::CycleRecord> states;
  auto next_draw = std::chrono::steady_clock::now();
  while (servod_client::stop_signal() == 0) {
    source.take(states);
    push_all(states, fields, acquisition, [] {});
    if (const auto key = terminal.read_key(10)) {
      const scope::Trigger& trigger = acquisition.trigger();
      switch (*key) {
        case 'q': return;
        case ' ': acquisition.set_paused(acquisition.phase() != scope::Phase::kPaused); break;
        case 's': acquisition.set_mode(scope::TriggerMode::kSingle); break;
        case 'n': acquisition.set_mode(scope::TriggerMode::kNormal); break;
        case 'a': acquisition.set_mode(scope::TriggerMode::kAuto); break;
        case '+': acquisition.set_window(scope::step_window(acquisition.window_s(), +1)); break;
        case '-': acquisition.set_window(scope::step_window(acquisition.window_s(), -1)); break;
        case '[':
        case ']': {
          if (trigger.channel < 0) break;
          const auto& shown = acquisition.shown();
          const scope::Span span = scope::vertical_span(
              shown.empty() ? std::span<const double>() : std::span<const double>(shown.values[static_cast<std::size_t>(trigger.channel)]));
          acquisition.set_level(trigger.level + (*key == ']' ? 1.0 : -1.0) * (span.top - span.bottom) / 20.0);
          break;
        }
        case 'r':
          acquisition.set_edge(trigger.edge == scope::TriggerEdge::kRising    ? scope::TriggerEdge::kFalling
                               : trigger.edge == scope::TriggerEdge::kFalling ? scope::TriggerEdge::kEither
                                                                              : scope::TriggerEdge::kRising);
          break;
        case 'e':
          try {
            text.message = "exported " + export_window(acquisition.shown(), fields, acquisition.trigger(), o, name, ++exported);
          } catch (const std::exception& error) {
            text.message = std::string("export failed: ") + error.what();
          }
          break;
        default: break;
      }
      next_draw = std::chrono::steady_clock::now();
    }
    if (std::chrono::steady_clock::now() >= next_draw) {
      text.source = source.describe();
      terminal.draw(scope::render_screen(acquisition, text, terminal.columns(), terminal.rows()));
      next_draw += std::chrono::milliseconds(50);
      next_draw = std::max(next_draw, std::chrono::steady_clock::now());
    }
  }
}

void run_scope(const ScopeOptions& o) {
  if (o.channels.empty()) throw std::invalid_argument("--channels names no channel");
  const auto fields = channel_fields(o);
  scope::Trigger trigger;
  if (!o.trigger_field.empty()) {
    for (std::size_t c = 0; c < fields.size(); ++c) {
      if (fields[c].name == o.trigger_field) trigger.channel = static_cast<int>(c);
    }
  }
  trigger.level = o.level;
  trigger.edge = scope::parse_edge(o.edge);
  trigger.mode = o.mode.empty() ? (o.trigger_field.empty() ? scope::TriggerMode::kAuto : scope::TriggerMode::kNormal)
                                : scope::parse_mode(o.mode);
  trigger.pre_trigger = o.pre_trigger;
  if (trigger.channel < 0 && trigger.mode != scope::TriggerMode::kAuto) {
    throw std::invalid_argument(std::string("--mode ") + scope::name(trigger.mode) + " needs --trigger FIELD");
  }
  if (o.batch && trigger.channel < 0) throw std::invalid_argument("--batch needs --trigger FIELD");
  if (o.batch && trigger.mode == scope::TriggerMode::kAuto) trigger.mode = scope::TriggerMode::kNormal;
  if (!std::filesystem::is_directory(o.out_dir)) {
    throw std::invalid_argument("--out '" + o.out_dir + "' is not a directory");
  }
  scope::Acquisition acquisition(fields.size(), o.window_s, trigger);
  servod_client::install_stop_signals();
  const auto source = o.log_path.empty() ? scope::live_source(o.lcm_url, o.key_file) : scope::log_source(o.log_path, o.speed);
  const std::string name = o.name.empty() ? default_name() : o.name;
  if (o.batch) {
    run_batch(o, *source, acquisition, fields, name);
  } else {
    run_interactive(o, *source, acquisition, fields, name);
  }
}

}  // namespace

void add_scope(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "scope",
      "a live oscilloscope on clm-servod's state stream (or an LCM log): channels, time base, trigger, pause, "
      "export to CSV and PNG");
  sub->footer(
      "Keys: space pause/run, s single, n normal, a auto, + and - the time base (1-2-5), [ and ] the trigger level, "
      "r the edge, e export the shown window, q quit. Example, the following error of the next move: clm scope "
      "--channels e_m,r_m,F_star_N --trigger program_running --level 0.5 --mode single (docs/scope.md).");
  auto o = std::make_shared<ScopeOptions>();
  sub->add_option("--lcm-url", o->lcm_url,
                  "LCM URL of the daemon (its telemetry.lcm_url); default: $CLM_SERVO_LCM_URL, else the shipped one")
      ->capture_default_str();
  sub->add_option("--key-file", o->key_file,
                  "the operators' key (the daemon's commands.key_file): only states signed with it are shown; default: "
                  "$CLM_SERVO_KEY_FILE, else /etc/clm-servo/command.key");
  sub->add_option("--log", o->log_path, "read an LCM log (lcm-logger, clm ctl record) instead of the live stream")
      ->check(CLI::ExistingFile);
  sub->add_option("--speed", o->speed, "--log: replay at this many times the log's pace; 0: all at once")
      ->check(clm::non_negative_number())
      ->capture_default_str();
  sub->add_option("--channels", o->channels, "fields of CLM_SERVO_STATE to draw, as clm log2csv --format full names them")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--trigger", o->trigger_field, "the field to trigger on (drawn too); none: auto mode rolls");
  sub->add_option("--level", o->level, "trigger level, in the field's unit")->capture_default_str();
  sub->add_option("--edge", o->edge, "rising, falling or either")->capture_default_str();
  sub->add_option("--mode", o->mode, "auto, normal or single; default: normal with --trigger, else auto");
  sub->add_option("--pre-trigger", o->pre_trigger, "fraction of the window before the trigger")
      ->check(clm::in_range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--window-s", o->window_s, "the window's length, ten divisions [s]")
      ->check(clm::in_range(1e-3, 100.0))
      ->capture_default_str();
  sub->add_option("--out", o->out_dir, "directory for exported windows (NAME-<n>.csv and .png)")->capture_default_str();
  sub->add_option("--name", o->name, "exported files' name; default: scope-<UTC time>");
  sub->add_flag("--batch", o->batch,
                "no terminal: export each triggered window as it is captured, exit after --captures (exit 1 when the "
                "time or the log runs out first)");
  sub->add_option("--captures", o->captures, "--batch: windows to capture")->check(clm::at_least(1))->capture_default_str();
  sub->add_option("--timeout-s", o->timeout_s, "--batch: give up after this long [s]")
      ->check(clm::positive_number())
      ->capture_default_str();
  sub->add_flag("--no-colour", o->no_colour, "no ANSI colours (also when $NO_COLOR is set)");
  sub->callback([o] { run_scope(*o); });
}

}  // namespace clm::cli
