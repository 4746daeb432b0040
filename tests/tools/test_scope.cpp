// clm scope's acquisition and drawing (tools/scope): the trigger against the
// analytic crossing of a sine, the modes, the 1-2-5 time bases, braille dots
// read back against the linear map of time and value, the screen's size,
// and the state fields by name.
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "tools/lcmlog/state_fields.hpp"
#include "tools/scope/acquisition.hpp"
#include "tools/scope/render.hpp"

using namespace clm::scope;

namespace {

constexpr double kPeriod_s = 0.001;

/// The sample's sequence number at `t_s`: one a period.
std::int64_t sequence_at(double t_s) { return std::llround(t_s / kPeriod_s); }

/// Pushes a sine of `frequency_Hz` and amplitude 1 on channel 0 and t on
/// channel 1, from t = `from_s` for `duration_s`, leaving out the samples
/// `lost` says are lost.
void push_sine(Acquisition& a, double frequency_Hz, double from_s, double duration_s,
               const std::function<bool(double)>& lost = [](double) { return false; }) {
  for (double t = from_s; t < from_s + duration_s - 1e-12; t += kPeriod_s) {
    if (lost(t)) continue;
    const double values[] = {std::sin(2.0 * std::numbers::pi * frequency_Hz * t), t};
    a.push(t, sequence_at(t), values);
  }
}

/// The braille cells of `lines` as lit dots: dots[x][y].
std::vector<std::vector<bool>> read_dots(const std::vector<std::string>& lines, int width_cells) {
  std::vector<std::vector<bool>> dots(static_cast<std::size_t>(2 * width_cells),
                                      std::vector<bool>(4 * lines.size(), false));
  for (std::size_t row = 0; row < lines.size(); ++row) {
    REQUIRE(lines[row].size() == static_cast<std::size_t>(3 * width_cells));  // 3 UTF-8 bytes a cell
    for (int cell = 0; cell < width_cells; ++cell) {
      const auto* b = reinterpret_cast<const unsigned char*>(lines[row].data() + 3 * cell);
      const int code = ((b[0] & 0x0F) << 12) | ((b[1] & 0x3F) << 6) | (b[2] & 0x3F);
      REQUIRE(code >= 0x2800);
      REQUIRE(code <= 0x28FF);
      for (int dx = 0; dx < 2; ++dx) {
        for (int dy = 0; dy < 4; ++dy) {
          if ((code - 0x2800) & braille_bit(dx, dy)) dots[static_cast<std::size_t>(2 * cell + dx)][4 * row + dy] = true;
        }
      }
    }
  }
  return dots;
}

/// Display cells of a line without its colour codes (braille: one cell per 3 bytes).
std::size_t cells(const std::string& line) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < line.size(); ++k) {
    if (line[k] == '\x1b') {
      while (k < line.size() && line[k] != 'm') ++k;
      continue;
    }
    if ((static_cast<unsigned char>(line[k]) & 0xC0) != 0x80) ++n;  // not a continuation byte
  }
  return n;
}

}  // namespace

TEST_CASE("A rising trigger sits at the sine's analytic crossing, with the pre-trigger part before it", "[scope]") {
  // sin(2π·5·t) rises through 0.5 at t = asin(0.5)/(2π·5) + k/5.
  Trigger trigger{.channel = 0, .level = 0.5, .edge = TriggerEdge::kRising, .mode = TriggerMode::kSingle, .pre_trigger = 0.25};
  Acquisition a(2, 0.1, trigger);
  push_sine(a, 5.0, 0.0, 1.0);
  REQUIRE(a.captures() == 1);
  CHECK(a.phase() == Phase::kHeld);
  const Window& w = a.shown();
  // The first crossing with 25 ms recorded before it: the one at k = 0 (16.7 ms) has not.
  const double expected_s = std::asin(0.5) / (2.0 * std::numbers::pi * 5.0) + 0.2;
  CHECK(w.trigger_t_s == Approx(expected_s).margin(1e-4));  // linear between samples 1 ms apart
  CHECK(w.start_s == Approx(expected_s - 0.025).margin(1e-4));
  CHECK(w.t_s.front() >= w.start_s);
  CHECK(w.t_s.back() <= w.start_s + 0.1);
  CHECK(w.t_s.size() == Approx(100).margin(1));
  // Channel 1 is t itself: the window's samples are those of their times.
  for (std::size_t k = 0; k < w.t_s.size(); ++k) CHECK(w.values[1][k] == w.t_s[k]);
  // Held: no more captures until armed.
  push_sine(a, 5.0, 1.0, 1.0);
  CHECK(a.captures() == 1);
  a.arm();
  push_sine(a, 5.0, 2.0, 1.0);
  CHECK(a.captures() == 2);
}

TEST_CASE("Armed, the scope says it is filling until the part before a trigger is recorded", "[scope]") {
  Trigger trigger{.channel = 0, .level = 2.0, .mode = TriggerMode::kSingle, .pre_trigger = 0.25};  // never reached
  Acquisition a(2, 0.1, trigger);
  CHECK(a.phase() == Phase::kFilling);
  push_sine(a, 5.0, 0.0, 0.020);  // 20 of the 25 ms before a trigger
  CHECK(a.phase() == Phase::kFilling);
  push_sine(a, 5.0, 0.020, 0.010);
  CHECK(a.phase() == Phase::kArmed);
  a.arm();  // rearming starts the part before a trigger afresh
  CHECK(a.phase() == Phase::kFilling);
}

TEST_CASE("A window counts the states lost in transit within it, by the gaps in their sequence", "[scope]") {
  Trigger trigger{.channel = 0, .level = 0.5, .edge = TriggerEdge::kRising, .mode = TriggerMode::kSingle, .pre_trigger = 0.25};
  // The same capture as above (trigger at 216.7 ms, window from 191.7 ms to
  // 291.7 ms), but samples lost: 3 at the window's very start (192, 193,
  // 194 ms), 5 within it (250..254 ms), 4 before it (100..103 ms) and 2
  // after it (300, 301 ms).
  const auto lost = [](double t) {
    const std::int64_t k = sequence_at(t);
    return (k >= 192 && k <= 194) || (k >= 250 && k <= 254) || (k >= 100 && k <= 103) || k == 300 || k == 301;
  };
  Acquisition a(2, 0.1, trigger);
  push_sine(a, 5.0, 0.0, 0.4, lost);
  REQUIRE(a.captures() == 1);
  const Window& w = a.shown();
  CHECK(w.start_s == Approx(std::asin(0.5) / (2.0 * std::numbers::pi * 5.0) + 0.2 - 0.025).margin(1e-4));
  CHECK(w.missing == 8);
  CHECK(w.t_s.front() == Approx(0.195).margin(1e-9));  // the first that arrived
  CHECK(w.t_s.size() + 8 == 100);
  // Every 2nd sample arriving (a decimation of 2) is not a loss.
  Acquisition b(2, 0.1, trigger);
  push_sine(b, 5.0, 0.0, 0.4, [](double t) { return sequence_at(t) % 2 == 1; });
  REQUIRE(b.captures() == 1);
  CHECK(b.shown().missing == 0);
  CHECK(missing_note(a.shown()) == ", 8 missing (lost in transit)");
  CHECK(missing_note(b.shown()).empty());
}

TEST_CASE("Normal mode captures every crossing whose window does not overlap the last one's", "[scope]") {
  Trigger trigger{.channel = 0, .level = 0.0, .edge = TriggerEdge::kFalling, .mode = TriggerMode::kNormal, .pre_trigger = 0.5};
  Acquisition a(2, 0.1, trigger);
  // Falling zero crossings of a 2 Hz sine every 0.5 s, at 0.25 + 0.5·k: in
  // 10 s the first (0.25 s) and then one every 0.5 s up to 9.75 s.
  push_sine(a, 2.0, 0.0, 10.0);
  CHECK(a.captures() == 20);
  CHECK(a.shown().trigger_t_s == Approx(9.75).margin(1e-6));
  CHECK(a.phase() == Phase::kArmed);
}

TEST_CASE("Either edge triggers on both, NaN never triggers", "[scope]") {
  Acquisition a(2, 0.1, Trigger{.channel = 0, .level = 0.0, .edge = TriggerEdge::kEither, .mode = TriggerMode::kNormal});
  push_sine(a, 2.0, 0.0, 2.0);
  CHECK(a.captures() == 7);  // crossings at 0.25, 0.5, ..., 1.75 s; the one at 0 s has nothing before it
  Acquisition b(2, 0.1, Trigger{.channel = 0, .level = 0.0, .edge = TriggerEdge::kEither, .mode = TriggerMode::kNormal});
  for (double t = 0.0; t < 1.0; t += kPeriod_s) {
    const double values[] = {std::nan(""), t};
    b.push(t, sequence_at(t), values);
  }
  CHECK(b.captures() == 0);
}

TEST_CASE("Auto mode rolls without a trigger, pause keeps the window, time going back starts afresh", "[scope]") {
  Acquisition a(2, 0.2, Trigger{.channel = 0, .level = 5.0, .mode = TriggerMode::kAuto});  // never reached
  push_sine(a, 1.0, 0.0, 1.0);
  CHECK(a.captures() == 0);
  Window w = a.shown();
  CHECK_FALSE(w.triggered());
  CHECK(w.t_s.back() == Approx(0.999).margin(1e-9));
  CHECK(w.t_s.front() >= 0.999 - 0.2 - 1e-9);
  a.set_paused(true);
  push_sine(a, 1.0, 1.0, 1.0);
  CHECK(a.shown().t_s.back() == w.t_s.back());
  a.set_paused(false);
  push_sine(a, 1.0, 0.0, 0.5);  // a new run: t starts again at 0
  CHECK(a.shown().t_s.back() == Approx(0.499).margin(1e-9));
  CHECK(a.shown().t_s.front() >= 0.499 - 0.2 - 1e-9);
}

TEST_CASE("Settings out of range are refused", "[scope]") {
  CHECK_THROWS_AS(Acquisition(2, 0.0, Trigger{}), std::invalid_argument);
  CHECK_THROWS_AS(Acquisition(2, 0.1, Trigger{.channel = 2}), std::invalid_argument);
  CHECK_THROWS_AS(Acquisition(2, 0.1, Trigger{.channel = 0, .pre_trigger = 1.5}), std::invalid_argument);
  CHECK_THROWS_AS(parse_edge("up"), std::invalid_argument);
  CHECK_THROWS_AS(parse_mode("once"), std::invalid_argument);
}

TEST_CASE("Time bases step along 1-2-5", "[scope]") {
  CHECK(step_window(0.5, +1) == Approx(1.0));
  CHECK(step_window(0.5, -1) == Approx(0.2));
  CHECK(step_window(1.0, -1) == Approx(0.5));
  CHECK(step_window(0.02, +1) == Approx(0.05));
  CHECK(step_window(0.3, +1) == Approx(0.5));  // off the sequence: to the next on it
  CHECK(step_window(0.3, -1) == Approx(0.2));
  CHECK(step_window(0.001, -1) == Approx(0.001));  // the shortest
  CHECK(step_window(100.0, +1) == Approx(100.0));  // the longest
}

TEST_CASE("Braille cells are U+2800 plus the dots' bits", "[scope]") {
  CHECK(braille_cell(0) == "\xE2\xA0\x80");
  CHECK(braille_cell(0xFF) == "\xE2\xA3\xBF");
  std::set<int> bits;
  for (int x = 0; x < 2; ++x) {
    for (int y = 0; y < 4; ++y) bits.insert(braille_bit(x, y));
  }
  CHECK(bits == std::set<int>{1, 2, 4, 8, 16, 32, 64, 128});
}

TEST_CASE("A drawn trace lights the dot of every sample under the linear map of time and value", "[scope]") {
  const int width = 40, height = 5;
  std::vector<double> t, v;
  for (int k = 0; k < 400; ++k) {
    t.push_back(1.0 + k * 0.0025);
    v.push_back(std::sin(k * 0.03) * 3.0);
  }
  const auto lines = braille_trace(t, v, 1.0, 1.0, -3.0, 3.0, width, height);
  REQUIRE(lines.size() == static_cast<std::size_t>(height));
  const auto dots = read_dots(lines, width);
  int lit_columns = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const auto x = static_cast<std::size_t>(std::floor((t[k] - 1.0) / 1.0 * 2 * width));
    const auto y = static_cast<std::size_t>(std::lround((3.0 - v[k]) / 6.0 * (4 * height - 1)));
    INFO("sample " << k << " at dot " << x << ", " << y);
    CHECK(dots[x][y]);
  }
  for (const auto& column : dots) lit_columns += std::count(column.begin(), column.end(), true) > 0;
  CHECK(lit_columns == 2 * width);  // joined: no column of the span is empty
  // Nothing lit far from the curve: every lit dot lies between the rows of its column's samples ± the join.
  for (std::size_t x = 0; x < dots.size(); ++x) {
    for (std::size_t y = 0; y < dots[x].size(); ++y) {
      if (!dots[x][y]) continue;
      const double t_mid = 1.0 + (x + 0.5) / (2.0 * width);
      const double expected_y = (3.0 - std::sin((t_mid - 1.0) / 0.0025 * 0.03) * 3.0) / 6.0 * (4 * height - 1);
      INFO("dot " << x << ", " << y);
      CHECK(std::fabs(static_cast<double>(y) - expected_y) <= 2.5);
    }
  }
}

TEST_CASE("The screen fills the terminal exactly and names what it shows", "[scope]") {
  Acquisition a(2, 0.1, Trigger{.channel = 0, .level = 0.5, .mode = TriggerMode::kSingle});
  push_sine(a, 5.0, 0.0, 1.0);
  ScreenText text{.source = "log test.lcm", .message = "", .channels = {"e_m", "t_s"}, .colour = true};
  for (const auto& [columns, rows] : {std::pair{80, 24}, std::pair{132, 50}, std::pair{40, 12}}) {
    const auto lines = render_screen(a, text, columns, rows);
    INFO(columns << "x" << rows);
    REQUIRE(lines.size() == static_cast<std::size_t>(rows));
    for (const auto& line : lines) CHECK(cells(line) <= static_cast<std::size_t>(columns));
  }
  const auto lines = render_screen(a, text, 100, 30);
  CHECK(lines[1].find("capture 1: trigger at t_s = 0.2167") == 0);
  CHECK(lines[0].find("single, trigger e_m rising 0.5") != std::string::npos);
  CHECK(lines[2].find("e_m") == 0);
  const auto tiny = render_screen(a, text, 20, 5);
  CHECK(tiny[2].find("too small") != std::string::npos);
}

TEST_CASE("State fields by name are unique, in log2csv order, the nearest suggested", "[scope][lcmlog]") {
  const auto fields = clm::lcmlog::state_fields(2);
  std::set<std::string> names;
  for (const auto& f : fields) names.insert(f.name);
  CHECK(names.size() == fields.size());
  CHECK(fields.front().name == "utime");
  CHECK(fields.back().name == "drive_profile");
  clm::servo::CycleRecord s;
  s.coil_sets = 1;
  s.e_m = 1.5e-6;
  s.ia_A[0] = 2.0;
  s.program_running = true;
  CHECK(clm::lcmlog::find_state_field("e_m").value(s) == 1.5e-6);
  CHECK(clm::lcmlog::find_state_field("ia_A_1").value(s) == 2.0);
  CHECK(std::isnan(clm::lcmlog::find_state_field("ia_A_2").value(s)));  // a coil set the state does not have
  CHECK(clm::lcmlog::find_state_field("program_running").value(s) == 1.0);
  CHECK_THROWS_WITH(clm::lcmlog::find_state_field("e_mm"), Catch::Contains("did you mean 'e_m'?"));
}
