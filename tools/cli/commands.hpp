#pragma once
// Subcommands of `clm`. Each registers itself on the app; its callback throws
// std::exception with a one-line message on bad input, which main prints.

#include <CLI/CLI.hpp>
#include <string>

#include "commutation/model_file.hpp"
#include "tools/cli/progress.hpp"

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
void add_margins(CLI::App& app);

/// The mechanics, knot choice and balance residuals of a position-based
/// identification, on stdout (clm identify and clm calibrate).
void print_position_identification(const data::PositionIdentification& identified);

/// --viscous-N-s-per-m and --direction-force-N: the friction that sets the
/// force scale of an identification from positions (clm identify, calibrate, commission).
void add_friction_options(CLI::App& sub, double& viscous_N_s_per_m, double& direction_N);

/// --encoder-reference and --reference-position-m: the frame the data's
/// positions are in, recorded in the file written (docs/model-format.md,
/// "The encoder reference"; clm identify, calibrate).
void add_encoder_reference_options(CLI::App& sub, EncoderReference& reference);

}  // namespace clm::cli
