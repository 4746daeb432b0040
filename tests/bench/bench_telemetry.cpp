// What the mac of the operators' key costs the publisher thread
// (daemon/telemetry/message_mac.hpp; docs/design-decisions.md): converting a
// cycle's record to servo_state_t and encoding it, with and without signing,
// and verifying a signed one as a client does. Run:
//   build/bin/bench_telemetry --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdint>
#include <string>
#include <vector>

#include "config/sha256.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/message_mac.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace {

const clm::HmacSha256& key() {
  static const std::string text(32, 'k');
  static const clm::HmacSha256 hmac(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  return hmac;
}

clm::servo::CycleRecord three_coil_record() {
  clm::servo::CycleRecord record{};
  record.cycle = 123456;
  record.coil_sets = 3;
  return record;
}

std::vector<std::uint8_t> encoded_state(bool sign) {
  const auto message = clm::telemetry::to_message(three_coil_record());
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  if (sign) clm::telemetry::sign_encoded(key(), clm::telemetry::kStateChannel, buffer);
  return buffer;
}

void state_encode(benchmark::State& state) {
  const bool sign = state.range(0) != 0;
  for (auto _ : state) benchmark::DoNotOptimize(encoded_state(sign));
}

void state_verify(benchmark::State& state) {
  const std::vector<std::uint8_t> signed_state = encoded_state(true);
  for (auto _ : state) {
    benchmark::DoNotOptimize(clm::telemetry::verify_encoded(key(), clm::telemetry::kStateChannel, signed_state));
  }
  state.counters["bytes"] = static_cast<double>(signed_state.size());
}

}  // namespace

BENCHMARK(state_encode)->Name("state/encode")->Arg(0);
BENCHMARK(state_encode)->Name("state/encode_and_sign")->Arg(1);
BENCHMARK(state_verify)->Name("state/verify");
BENCHMARK_MAIN();
