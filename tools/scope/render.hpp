#pragma once
// What `clm scope` draws: the shown window as text for a terminal, one strip
// per channel in braille dots (2 × 4 per character cell), with the values at
// the strip's top and bottom, a time ruler of ten divisions marking the
// trigger, a header and a footer. Pure: strings out, no terminal I/O.

#include <span>
#include <string>
#include <vector>

#include "tools/scope/acquisition.hpp"

namespace clm::scope {

/// Braille dots of one cell: bit of dot (column 0..1, row 0..3), Unicode's
/// numbering (U+2800 + bits).
int braille_bit(int column, int row) noexcept;
/// The UTF-8 bytes of the braille cell with `bits`.
std::string braille_cell(int bits);

/// A trace drawn into `width_cells` × `height_cells` braille cells (one
/// string of UTF-8 per text row). Sample k sits in dot column
/// floor((t_k − start_s)/length_s · 2·width_cells) and dot row
/// round((top − v)/(top − bottom) · (4·height_cells − 1)), clamped to the
/// area; consecutive samples are joined; a NaN breaks the trace.
std::vector<std::string> braille_trace(std::span<const double> t_s, std::span<const double> values, double start_s,
                                       double length_s, double bottom, double top, int width_cells, int height_cells);

/// The vertical span a strip shows for `values`: their finite minimum and
/// maximum, widened by 5 % of the span (a constant by 10 % of its size, or
/// ±1 when it is 0); {−1, 1} when none is finite.
struct Span {
  double bottom = -1.0;
  double top = 1.0;
};
Span vertical_span(std::span<const double> values);

struct ScreenText {
  std::string source;   ///< "live udpm://…" or "log run.lcm at 1×"
  std::string message;  ///< the last action's result ("exported …")
  std::vector<std::string> channels;  ///< the channels' names, as the acquisition's channels
  bool colour = true;   ///< ANSI colours, one per channel
};

/// The whole screen, `rows` lines no wider than `columns` cells (without the
/// colour codes). A terminal too small for the channels gets one line saying so.
std::vector<std::string> render_screen(const Acquisition& acquisition, const ScreenText& text, int columns, int rows);

/// ", 3 missing (lost in transit)" for a window with states missing; "" without.
std::string missing_note(const Window& window);

/// "0.05 s" style: the time with 3 significant digits and its unit.
std::string format_seconds(double t_s);

}  // namespace clm::scope
