#pragma once
// The encoder reference a calibration or model file's positions are in
// (docs/model-format.md, "The encoder reference"), and the homing methods'
// names: one list, which the files, the command line and the daemon's
// homing (control::HomingMethod) read.

#include <array>
#include <string>
#include <string_view>

namespace clm {

/// The homing methods, in control::HomingMethod's order: "none" is an absolute encoder.
inline constexpr std::array<std::string_view, 4> kReferenceMethods{"none", "index", "reference_switch", "hard_stop"};

struct EncoderReference {
  std::string method = "none";  ///< "none" (an absolute encoder), "index", "reference_switch" or "hard_stop"
  double position_m = 0.0;      ///< homing.reference_position_m (meaningless for "none") [m]
  /// The same frame: the same method and, when homed, the same position within 1 nm.
  bool same_frame(const EncoderReference& other) const noexcept;
  /// e.g. "index at 0.000000000 m", "none (an absolute encoder)".
  std::string describe() const;
};

}  // namespace clm
