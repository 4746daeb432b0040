#pragma once
// The Python scripts clm runs to draw PNGs (share/clm-servo/ beside the
// executable's bin/; the build tree mirrors the installed layout), run by
// Debian's python3 with python3-matplotlib, without a shell.

#include <string>
#include <vector>

namespace clm::cli {

/// Runs share/clm-servo/`script` with `arguments`; true when it exited 0.
/// False (and nothing run) when the script is not installed beside clm.
bool run_share_script(const std::string& script, const std::vector<std::string>& arguments);

}  // namespace clm::cli
