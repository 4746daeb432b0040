#pragma once
// clm-servod's telemetry and commands over LCM (docs/telemetry.md), every
// part at once:
//   messages.hpp        channels, status/event/ack samples
//   lcm_conversion.hpp  the one conversion each way to the clm_lcm types
//   sink.hpp            where telemetry goes; lcm_sink.hpp, lcm_log_writer.hpp,
//                       memory_sink.hpp: LCM, an LCM log, memory
//   publisher.hpp       the publisher thread and its queues
// The cycle's record and the command type are daemon/servo's
// (cycle_record.hpp, command.hpp).

#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/lcm_log_writer.hpp"
#include "daemon/telemetry/lcm_sink.hpp"
#include "daemon/telemetry/memory_sink.hpp"
#include "daemon/telemetry/messages.hpp"
#include "daemon/telemetry/publisher.hpp"
#include "daemon/telemetry/sink.hpp"
