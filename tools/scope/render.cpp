#include "tools/scope/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace clm::scope {

int braille_bit(int column, int row) noexcept {
  static constexpr int kBits[2][4] = {{0x01, 0x02, 0x04, 0x40}, {0x08, 0x10, 0x20, 0x80}};
  return kBits[column & 1][row & 3];
}

std::string braille_cell(int bits) {
  const int code = 0x2800 + (bits & 0xFF);
  return {static_cast<char>(0xE0 | (code >> 12)), static_cast<char>(0x80 | ((code >> 6) & 0x3F)),
          static_cast<char>(0x80 | (code & 0x3F))};
}

std::vector<std::string> braille_trace(std::span<const double> t_s, std::span<const double> values, double start_s,
                                       double length_s, double bottom, double top, int width_cells, int height_cells) {
  const int width = 2 * std::max(width_cells, 0), height = 4 * std::max(height_cells, 0);
  std::vector<int> cells(static_cast<std::size_t>(std::max(width_cells, 0) * std::max(height_cells, 0)), 0);
  const auto set = [&](int x, int y) {
    if (x < 0 || x >= width || y < 0 || y >= height) return;
    cells[static_cast<std::size_t>((y / 4) * width_cells + x / 2)] |= braille_bit(x % 2, y % 4);
  };
  const auto column_of = [&](double t) {
    return static_cast<int>(std::floor((t - start_s) / length_s * width));
  };
  const auto row_of = [&](double v) {
    const double r = std::round((top - v) / (top - bottom) * (height - 1));
    return static_cast<int>(std::clamp(r, 0.0, static_cast<double>(height - 1)));
  };
  bool have_previous = false;
  int px = 0, py = 0;
  const std::size_t n = std::min(t_s.size(), values.size());
  for (std::size_t k = 0; k < n && width > 0 && height > 0; ++k) {
    if (!std::isfinite(values[k]) || !std::isfinite(t_s[k])) {
      have_previous = false;
      continue;
    }
    const int x = column_of(t_s[k]), y = row_of(values[k]);
    if (x < 0 || x >= width) {
      have_previous = false;
      continue;
    }
    if (!have_previous) {
      set(x, y);
    } else {
      // Joined: each column from px to x gets the rows the straight line
      // between the two samples passes in it.
      const int steps = std::max(x - px, 0);
      for (int c = 0; c <= steps; ++c) {
        const double f0 = steps == 0 ? 0.0 : std::max(c - 0.5, 0.0) / steps;
        const double f1 = steps == 0 ? 1.0 : std::min(c + 0.5, static_cast<double>(steps)) / steps;
        const int y0 = static_cast<int>(std::lround(py + f0 * (y - py)));
        const int y1 = static_cast<int>(std::lround(py + f1 * (y - py)));
        for (int r = std::min(y0, y1); r <= std::max(y0, y1); ++r) set(px + c, r);
      }
    }
    have_previous = true;
    px = x;
    py = y;
  }
  std::vector<std::string> lines(static_cast<std::size_t>(std::max(height_cells, 0)));
  for (int row = 0; row < height_cells; ++row) {
    for (int col = 0; col < width_cells; ++col) {
      lines[static_cast<std::size_t>(row)] += braille_cell(cells[static_cast<std::size_t>(row * width_cells + col)]);
    }
  }
  return lines;
}

Span vertical_span(std::span<const double> values) {
  double lo = INFINITY, hi = -INFINITY;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!(lo <= hi)) return {};
  if (hi == lo) {
    const double half = lo == 0.0 ? 1.0 : 0.1 * std::fabs(lo);
    return {lo - half, hi + half};
  }
  const double margin = 0.05 * (hi - lo);
  return {lo - margin, hi + margin};
}

std::string format_seconds(double t_s) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g s", t_s);
  return buffer;
}

namespace {

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.4g", v);
  return buffer;
}

/// `text` cut or padded to `cells` cells (ASCII text: one byte a cell).
std::string fit(const std::string& text, int cells) {
  const auto n = static_cast<std::size_t>(std::max(cells, 0));
  std::string out = text.substr(0, n);
  out.resize(n, ' ');
  return out;
}

constexpr int kLabelCells = 14;
constexpr const char* kColours[] = {"\x1b[33m", "\x1b[36m", "\x1b[35m", "\x1b[32m", "\x1b[31m", "\x1b[34m"};

}  // namespace

std::string missing_note(const Window& window) {
  return window.missing > 0 ? ", " + std::to_string(window.missing) + " missing (lost in transit)" : "";
}

std::vector<std::string> render_screen(const Acquisition& acquisition, const ScreenText& text, int columns, int rows) {
  const Window& window = acquisition.shown();
  const Trigger& trigger = acquisition.trigger();
  const auto channels = static_cast<int>(text.channels.size());
  std::vector<std::string> lines;
  // Header: where from, the trigger, the time base and the phase.
  std::string trig = "no trigger";
  if (trigger.channel >= 0) {
    trig = "trigger " + text.channels[static_cast<std::size_t>(trigger.channel)] + " " + name(trigger.edge) + " " +
           number(trigger.level) + ", pre " + number(100.0 * trigger.pre_trigger) + " %";
  }
  lines.push_back(fit(std::string("clm scope  [") + name(acquisition.phase()) + "]  " + name(trigger.mode) + ", " +
                          trig + "  |  " + format_seconds(acquisition.window_s() / 10.0) + "/div  |  " + text.source,
                      columns));
  std::string about = acquisition.phase() == Phase::kFilling
                          ? "recording the " + format_seconds(trigger.pre_trigger * acquisition.window_s()) +
                                " before a trigger: none counts yet"
                          : "waiting for a trigger";
  if (window.triggered()) {
    about = "capture " + std::to_string(window.number) + ": trigger at t_s = " + number(window.trigger_t_s) + ", " +
            std::to_string(window.t_s.size()) + " states" + missing_note(window);
  } else if (!window.empty()) {
    about = "rolling (no trigger): the latest " + format_seconds(window.length_s) + ", " +
            std::to_string(window.t_s.size()) + " states" + missing_note(window);
  }
  lines.push_back(fit(about, columns));

  const int plot_cells = columns - kLabelCells - 1;
  const int strip_rows = channels > 0 ? (rows - 6) / channels : 0;
  if (channels == 0 || plot_cells < 10 || strip_rows < 2) {
    lines.push_back(fit("too small: " + std::to_string(columns) + "x" + std::to_string(rows) + " cells for " +
                            std::to_string(channels) + " channels",
                        columns));
    lines.resize(static_cast<std::size_t>(std::max(rows, 0)));
    return lines;
  }
  for (int c = 0; c < channels; ++c) {
    const auto channel = static_cast<std::size_t>(c);
    const std::span<const double> values =
        window.empty() ? std::span<const double>() : std::span<const double>(window.values[channel]);
    const Span span = vertical_span(values);
    const auto trace = braille_trace(window.t_s, values, window.start_s, window.length_s, span.bottom, span.top,
                                     plot_cells, strip_rows);
    // The trigger level's row on the trigger channel's strip.
    int level_row = -1;
    if (c == trigger.channel && trigger.level >= span.bottom && trigger.level <= span.top) {
      level_row = static_cast<int>(std::lround((span.top - trigger.level) / (span.top - span.bottom) * (strip_rows - 1)));
    }
    for (int r = 0; r < strip_rows; ++r) {
      std::string label = r == 0 ? text.channels[channel] : r == 1 ? "max " + number(span.top) : "";
      if (r == strip_rows - 1 && strip_rows >= 3) label = "min " + number(span.bottom);
      if (r == 1 && strip_rows == 2) label = "min " + number(span.bottom);
      std::string line = fit(label, kLabelCells) + (r == level_row ? ">" : "|");
      const std::string& plot = trace[static_cast<std::size_t>(r)];
      line += text.colour ? kColours[c % 6] + plot + "\x1b[0m" : plot;
      lines.push_back(std::move(line));
    }
  }
  // Ruler: ten divisions, T at the trigger.
  std::string ruler(static_cast<std::size_t>(plot_cells), '-');
  for (int d = 0; d <= 10; ++d) {
    ruler[static_cast<std::size_t>(std::min(static_cast<int>(std::lround(d * plot_cells / 10.0)), plot_cells - 1))] = '+';
  }
  const double reference_s = window.triggered() ? window.trigger_t_s : window.start_s + window.length_s;
  if (window.triggered()) {
    const int at = static_cast<int>(std::lround((window.trigger_t_s - window.start_s) / window.length_s * plot_cells));
    ruler[static_cast<std::size_t>(std::clamp(at, 0, plot_cells - 1))] = 'T';
  }
  lines.push_back(fit(window.triggered() ? "t - trigger" : "t - latest", kLabelCells) + " " + ruler);
  const std::string left = window.empty() ? "" : format_seconds(window.start_s - reference_s);
  const std::string right = window.empty() ? "" : format_seconds(window.start_s + window.length_s - reference_s);
  std::string scale = fit(left, plot_cells);
  const std::string per_div = format_seconds(acquisition.window_s() / 10.0) + "/div";
  scale.replace(static_cast<std::size_t>(std::max(0, (plot_cells - static_cast<int>(per_div.size())) / 2)),
                std::min(per_div.size(), scale.size()), per_div.substr(0, scale.size()));
  if (static_cast<int>(right.size()) < plot_cells) {
    scale.replace(scale.size() - right.size(), right.size(), right);
  }
  lines.push_back(fit("", kLabelCells) + " " + scale);
  lines.push_back(fit("space pause/run  s single  n normal  a auto  + - time base  [ ] level  r edge  e export  q quit",
                      columns));
  lines.push_back(fit(text.message, columns));
  lines.resize(static_cast<std::size_t>(std::max(rows, 0)));
  return lines;
}

}  // namespace clm::scope
