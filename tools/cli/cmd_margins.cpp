// clm margins: the position loop's stability margins for a plant beyond the
// rigid mass (daemon/control/loop_analysis.hpp; docs/servod.md, "The
// position loop's margins").

#include <cstdio>
#include <memory>
#include <string>

#include "config/command_line.hpp"
#include "daemon/control/loop_analysis.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/servod/servod_config.hpp"
#include "tools/cli/commands.hpp"

namespace clm::cli {

void add_margins(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "margins", "stability and phase and gain margins of the position loop tuned for --mass-kg and --bandwidth-hz, on "
                 "a plant with a flexible mode, the drive's current loop and delays; or of a configuration's loop on "
                 "the plant its motor file describes (--config)");
  struct Options {
    double tuned_mass_kg = 15.0;
    double bandwidth_hz = 40.0;
    double period_s = 1e-3;
    control::PlantModel plant{.mass_kg = 15.0};
    std::string config_path;
  };
  auto o = std::make_shared<Options>();
  auto* config = sub->add_option("--config", o->config_path,
                                 "a clm-servod configuration: its control.mass_kg, control.bandwidth_hz and loop rate, "
                                 "on the plant its motor file describes (what clm-servod checks at start-up)")
                     ->check(CLI::ExistingFile);
  auto* mass = sub->add_option("--mass-kg", o->tuned_mass_kg, "mass the loop is tuned for (control.mass_kg)")
      ->check(clm::positive_number())
      ->capture_default_str();
  auto* bandwidth = sub->add_option("--bandwidth-hz", o->bandwidth_hz, "the loop's crossover it is tuned for (control.bandwidth_hz)")
      ->check(clm::positive_number())
      ->capture_default_str();
  auto* period = sub->add_option("--period-s", o->period_s, "the loop's period (1/loop.rate_hz)")
      ->check(clm::positive_number())
      ->capture_default_str();
  auto* plant_mass = sub->add_option("--plant-mass-kg", o->plant.mass_kg, "the translator's true mass")
      ->check(clm::positive_number())
      ->capture_default_str();
  auto* mode = sub->add_option("--mode-hz", o->plant.mode_frequency_Hz, "the flexible mode between motor and encoder; 0: rigid")
      ->check(clm::non_negative_number())
      ->capture_default_str();
  auto* damping = sub->add_option("--mode-damping", o->plant.mode_damping_ratio, "the mode's damping ratio")
      ->check(clm::in_range(1e-6, 1.0))
      ->capture_default_str();
  auto* current_loop = sub->add_option("--current-loop-hz", o->plant.current_loop_bandwidth_Hz, "the drive's current-loop bandwidth; 0: ideal")
      ->check(clm::non_negative_number())
      ->capture_default_str();
  auto* delay = sub->add_option("--delay-s", o->plant.delay_s, "pure delays: setpoint to force, encoder, computation")
      ->check(clm::non_negative_number())
      ->capture_default_str();
  for (CLI::Option* option : {mass, bandwidth, period, plant_mass, mode, damping, current_loop, delay}) {
    config->excludes(option);
  }
  sub->callback([o] {
    if (!o->config_path.empty()) {
      // The loader refuses a loop that is unstable or short of the margins, naming them.
      const servod::ServodConfig loaded = servod::load_servod_config(o->config_path);
      o->tuned_mass_kg = loaded.control_mass_kg;
      o->bandwidth_hz = loaded.control_bandwidth_hz;
      o->period_s = loaded.servo.period_s;
      o->plant = loaded.plant;
      std::printf("plant: described by %s (mode %g Hz, current loop %g Hz, delays %g s; 0: absent)\n",
                  loaded.motor_file.c_str(), o->plant.mode_frequency_Hz, o->plant.current_loop_bandwidth_Hz,
                  o->plant.delay_s);
    }
    const control::PidGains gains = control::tune_pid(o->tuned_mass_kg, o->bandwidth_hz);
    const control::LoopMargins m = control::loop_margins(gains, o->period_s, o->plant);
    std::printf("gains: k_p %.6g N/m, k_i %.6g N/(m s), k_d %.6g N s/m, low-pass %.6g Hz\n",
                gains.proportional_N_per_m, gains.integral_N_per_m_s, gains.derivative_N_s_per_m, gains.lowpass_hz);
    std::printf("stable: %s (the phase passes -180 deg where |L| > 1 a net %d times; a stable loop once)\n",
                m.stable() ? "yes" : "no", m.real_axis_crossings);
    std::printf("phase_margin_deg: %.1f (crossover %.1f Hz; %d gain crossover%s)\n", m.phase_margin_deg,
                m.crossover_Hz, m.gain_crossovers, m.gain_crossovers == 1 ? "" : "s");
    if (m.gain_margin_Hz > 0.0) {
      std::printf("gain_margin_dB: %.2f (at %.1f Hz)\n", m.gain_margin_dB, m.gain_margin_Hz);
    } else {
      std::printf("gain_margin_dB: inf (no phase crossover below the Nyquist frequency)\n");
    }
    std::printf("peak_sensitivity: %.2f\n", m.peak_sensitivity);
  });
}

}  // namespace clm::cli
