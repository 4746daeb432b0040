// clm ff-identify: m, f_v, f_c of eq. (40) from closed-loop data.
#include <cstdio>

#include "config/atomic_file.hpp"
#include "config/sha256.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "tools/cli/commands.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/lcmlog/data_input.hpp"

namespace clm::cli {

void add_ff_identify(CLI::App& app) {
  auto* sub = app.add_subcommand("ff-identify", "identify the feedforward (40): mass, viscous and Coulomb friction");
  struct Options {
    std::string data, output;
    data::DataLimits limits;
    lcmlog::GapPolicy gaps;
  };
  auto options = std::make_shared<Options>();
  sub->add_option("--data", options->data,
                  "closed-loop data: CSV with t_s, r_m, F_star_N, or an LCM log of clm-servod")->required()->check(lcmlog::existing_input_file());
  sub->add_option("--output", options->output, "feedforward file to write (YAML)")->required();
  lcmlog::add_data_limit_options(*sub, options->limits, "--data");
  lcmlog::add_gap_option(*sub, options->gaps);
  sub->callback([options] {
    const auto table =
        lcmlog::load_data_table(options->data, lcmlog::CsvFormat::kFeedforward, options->limits, options->gaps);
    const auto time = table.numbers("t_s");
    const auto reference = table.numbers("r_m");
    const auto force = table.numbers("F_star_N");
    for (std::size_t r = 1; r < time.size(); ++r) {
      if (!(time[r] > time[r - 1])) {
        throw std::runtime_error(table.where(r) + ": column 't_s': time does not increase");
      }
    }
    const auto samples = control::reference_from_positions(time, reference);
    servod::FeedforwardFile file;
    control::FeedforwardFit fit;
    try {
      fit = control::fit_feedforward(samples, force);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(options->data + ": " + e.what());
    }
    file.parameters = fit.parameters;
    file.data_sha256 = sha256_file(options->data);
    file.created_utc = data::utc_timestamp();
    file.generator = generator_name("ff-identify");
    write_file_atomically(options->output, servod::format_feedforward_file(file));
    const auto& e = fit.standard_error;
    std::printf("mass_kg %.6g +- %.2g  viscous_N_s_per_m %.6g +- %.2g  coulomb_N %.6g +- %.2g (one standard error)\n"
                "fit: %zu samples, residual RMS %.3g N, condition %.3g of the normalised regressors [a, v, sgn v]\n",
                file.parameters.mass_kg, e.mass_kg, file.parameters.viscous_N_s_per_m, e.viscous_N_s_per_m,
                file.parameters.coulomb_N, e.coulomb_N, fit.samples, fit.residual_rms_N, fit.condition);
    for (const auto& name : control::unexcited_parameters(fit)) {
      std::fprintf(stderr,
                   "clm ff-identify: warning: %s is not excited by these data (standard error over 10 %% of the "
                   "value); record moves with more acceleration, speeds and both directions\n",
                   name.c_str());
    }
    // The standard errors assume independent residuals; a model mismatch that
    // follows the motion is not in them, and collinear regressors let the
    // values trade against each other whatever the noise.
    constexpr double kMaxCondition = 20.0;
    if (fit.condition > kMaxCondition) {
      std::fprintf(stderr,
                   "clm ff-identify: warning: the regressors [a, v, sgn v] move together (condition %.3g > %.3g): "
                   "the three values trade against each other; record moves at several speeds and accelerations in "
                   "both directions\n",
                   fit.condition, kMaxCondition);
    }
    std::printf("wrote %s\n", options->output.c_str());
  });
}

}  // namespace clm::cli
