#pragma once
// Subcommands of `clm`. Each registers itself on the app; its callback throws
// std::exception with a one-line message on bad input, which main prints.

#include <CLI/CLI.hpp>
#include <chrono>
#include <string>

namespace clm::data {
struct PositionIdentification;
}

namespace clm::cli {

void add_calibrate(CLI::App& app);
void add_identify(CLI::App& app);
void add_ff_identify(CLI::App& app);
void add_commutate(CLI::App& app);
void add_commission(CLI::App& app);
void add_ctl(CLI::App& app);
void add_sim(CLI::App& app);
void add_scope(CLI::App& app);

/// The mechanics, knot choice and balance residuals of a position-based
/// identification, on stdout (clm identify and clm calibrate).
void print_position_identification(const data::PositionIdentification& identified);

/// --viscous-N-s-per-m and --direction-force-N: the friction that sets the
/// force scale of an identification from positions (clm identify, calibrate, commission).
void add_friction_options(CLI::App& sub, double& viscous_N_s_per_m, double& direction_N);

/// "clm <version>" for provenance records.
std::string generator_name(const std::string& subcommand);

/// Progress of a long step on stderr: a bar on a terminal, one line per
/// update otherwise.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  void update(double fraction, const std::string& detail);
  void finish();

 private:
  std::string label_;
  bool terminal_;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace clm::cli
