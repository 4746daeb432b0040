// clm log2csv: LCM log of clm-servod → CSV for calibrate/identify, ff-identify, or analysis.
#include "tools/lcmlog/cmd_log2csv.hpp"

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/data_input.hpp"
#include "tools/lcmlog/servo_log.hpp"

namespace clm::lcmlog {

void add_log2csv(CLI::App& app) {
  auto* sub = app.add_subcommand("log2csv", "convert the CLM_SERVO_STATE messages of an LCM log to CSV");
  struct Options {
    std::string log, output, format;
    data::DataLimits limits;
    lcmlog::GapPolicy gaps;
  };
  auto options = std::make_shared<Options>();
  sub->add_option("--log", options->log, "LCM log of clm-servod (lcm-logger or the commissioning recorder)")
      ->required()
      ->check(lcmlog::existing_input_file());
  sub->add_option("--output", options->output, "CSV file to write")->required();
  sub->add_option("--format", options->format,
                  "experiment: t_s, coil_set, delta_rad, magnitude_N, y_m, Fy_N, Fx_N, Tz_Nm, ia_A, ib_A "
                  "(calibrate, identify); feedforward: t_s, r_m, F_star_N (ff-identify); full: every field")
      ->required()
      ->check(CLI::IsMember({"experiment", "feedforward", "full"}));
  lcmlog::add_data_limit_options(*sub, options->limits, "--log");
  lcmlog::add_gap_option(*sub, options->gaps);
  sub->callback([options] {
    const auto format = lcmlog::parse_csv_format(options->format);
    const lcmlog::ServoStateLog log = lcmlog::read_servo_state_log(options->log, options->limits);
    lcmlog::report_gaps(options->log, log.gaps, options->gaps);
    const auto& states = log.states;
    lcmlog::CsvColumns columns;
    try {
      columns = lcmlog::to_csv_columns(states, format);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(options->log + ": " + e.what());
    }
    data::write_csv_atomically(options->output, columns.names, columns.values);
    std::printf("wrote %s: %zu rows, %zu columns from %zu CLM_SERVO_STATE messages\n", options->output.c_str(),
                columns.rows(), columns.names.size(), states.size());
  });
}

}  // namespace clm::lcmlog
