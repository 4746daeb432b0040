// drivers/can/clm-servo.dbc (drive profile magnitude_phase) and
// drivers/can/clm-servo-phase-current.dbc (phase_current) against the codec,
// every test for both files: the DBC is read by a small parser
// (dbc.cpp) and every frame and signal in it must be what the codec writes and
// reads, bit for bit, so that the file cannot drift from the code.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>

#include "dbc.hpp"
#include "drivers/can/can_protocol.hpp"

namespace {

using clm::can::CodecStatus;
using clm::can::Frame;
using clm::test::DbcFile;
using clm::test::DbcMessage;
using clm::test::DbcSignal;
using Values = std::map<std::string, double>;

using clm::DriveProfile;

// The profile every test below is run for (one DBC file each).
DriveProfile g_profile = DriveProfile::kMagnitudePhase;
constexpr std::array<DriveProfile, 2> kProfiles{DriveProfile::kMagnitudePhase, DriveProfile::kPhaseCurrent};

const DbcFile& dbc() {
  static const DbcFile magnitude_phase = clm::test::read_dbc(CLM_DBC_PATH);
  static const DbcFile phase_current = clm::test::read_dbc(CLM_DBC_PHASE_CURRENT_PATH);
  return g_profile == DriveProfile::kPhaseCurrent ? phase_current : magnitude_phase;
}

// Runs `body` once per DBC file, with dbc() and dbc_config() set to it.
#define FOR_EACH_PROFILE                                   \
  for (const DriveProfile profile_under_test : kProfiles) \
    if (g_profile = profile_under_test; true)

const DbcMessage& message_named(const std::string& name) {
  for (const auto& message : dbc().messages) {
    if (message.name == name) return message;
  }
  FAIL("no message " << name << " in the DBC");
  throw std::logic_error("unreachable");
}

// The DBC describes the default node IDs and all four coil sets.
clm::can::ProtocolConfig dbc_config() {
  clm::can::ProtocolConfig config;
  config.coil_sets = 4;
  config.drive_profile = g_profile;
  return config;
}

/// The codec seen through the DBC's signal names, one adapter per message.
struct MessageCodec {
  std::function<CodecStatus(const Values&, Frame&)> encode;
  std::function<CodecStatus(const Frame&, Values&)> decode;
};

double bit(std::uint32_t word, int index) { return static_cast<double>((word >> index) & 1u); }

clm::can::SetpointCommand command_from(const Values& v) {
  clm::can::SetpointCommand command;
  command.coil_sets = 4;
  const auto get = [&](const std::string& name) { return v.count(name) ? v.at(name) : 0.0; };
  command.enable = get("ControlEnable") != 0.0;
  command.clear_fault = get("ControlClearFault") != 0.0;
  command.arm_latch = get("ControlArmLatch") != 0.0;
  command.latch_on_switch = get("ControlLatchOnSwitch") != 0.0;
  command.alive_counter = static_cast<std::uint8_t>(get("AliveCounter"));
  for (int l = 0; l < 4; ++l) {
    command.setpoints[static_cast<std::size_t>(l)].magnitude_N = get("Magnitude" + std::to_string(l + 1) + "_N");
    command.setpoints[static_cast<std::size_t>(l)].delta_rad = get("Delta" + std::to_string(l + 1) + "_rad");
    command.currents[static_cast<std::size_t>(l)].ia_A = get("Ia" + std::to_string(l + 1) + "_A");
    command.currents[static_cast<std::size_t>(l)].ib_A = get("Ib" + std::to_string(l + 1) + "_A");
  }
  return command;
}

CodecStatus encode_setpoint_frame(const Values& v, std::size_t index, Frame& out) {
  std::array<Frame, clm::can::kMaxSetpointFrames> frames{};
  CodecStatus status = CodecStatus::kOk;
  const std::size_t count = clm::can::encode_setpoints(dbc_config(), command_from(v), frames, status);
  if (status == CodecStatus::kOk) {
    REQUIRE(count == 3);
    out = frames[index];
  }
  return status;
}

const std::map<std::string, MessageCodec>& codecs() {
  static const std::map<std::string, MessageCodec> table = [] {
    std::map<std::string, MessageCodec> t;
    t["Sync"] = {[](const Values& v, Frame& out) {
                   return clm::can::encode_sync(static_cast<std::uint8_t>(v.at("SyncCounter")), out);
                 },
                 [](const Frame& frame, Values& v) {
                   std::uint8_t counter = 0;
                   const CodecStatus status = clm::can::decode_sync(frame, counter);
                   v["SyncCounter"] = counter;
                   return status;
                 }};
    t["DriveFeedback"] = {
        [](const Values& v, Frame& out) {
          clm::can::DriveFeedback feedback;
          feedback.position_m = v.at("Position_m");
          feedback.status_word = static_cast<std::uint16_t>(
              static_cast<unsigned>(v.at("StatusEnabled")) << 0 | static_cast<unsigned>(v.at("StatusFault")) << 1 |
              static_cast<unsigned>(v.at("StatusWatchdogExpired")) << 2 |
              static_cast<unsigned>(v.at("StatusCurrentLimited")) << 3 |
              static_cast<unsigned>(v.at("StatusEndStop")) << 4 | static_cast<unsigned>(v.at("StatusLatched")) << 5 |
              static_cast<unsigned>(v.at("StatusReferenceSwitch")) << 6 |
              static_cast<unsigned>(v.at("StatusReserved")) << 7);
          feedback.alive_counter = static_cast<std::uint8_t>(v.at("AliveCounter"));
          return clm::can::encode_drive_feedback(dbc_config(), feedback, out);
        },
        [](const Frame& frame, Values& v) {
          clm::can::DriveFeedback feedback;
          const CodecStatus status = clm::can::decode_drive_feedback(dbc_config(), frame, feedback);
          v["Position_m"] = feedback.position_m;
          v["StatusEnabled"] = bit(feedback.status_word, 0);
          v["StatusFault"] = bit(feedback.status_word, 1);
          v["StatusWatchdogExpired"] = bit(feedback.status_word, 2);
          v["StatusCurrentLimited"] = bit(feedback.status_word, 3);
          v["StatusEndStop"] = bit(feedback.status_word, 4);
          v["StatusLatched"] = bit(feedback.status_word, 5);
          v["StatusReferenceSwitch"] = bit(feedback.status_word, 6);
          v["StatusReserved"] = static_cast<double>(feedback.status_word >> 7);
          v["AliveCounter"] = feedback.alive_counter;
          return status;
        }};
    t["DriveLatch"] = {[](const Values& v, Frame& out) {
                         clm::can::DriveLatch latch;
                         latch.position_m = v.at("LatchPosition_m");
                         latch.latch_count = static_cast<std::uint8_t>(v.at("LatchCount"));
                         return clm::can::encode_drive_latch(dbc_config(), latch, out);
                       },
                       [](const Frame& frame, Values& v) {
                         clm::can::DriveLatch latch;
                         const CodecStatus status = clm::can::decode_drive_latch(dbc_config(), frame, latch);
                         v["LatchPosition_m"] = latch.position_m;
                         v["LatchCount"] = latch.latch_count;
                         return status;
                       }};
    t["ForceFeedback"] = {[](const Values& v, Frame& out) {
                            clm::can::ForceFeedback feedback;
                            feedback.wrench = clm::Wrench(v.at("Fy_N"), v.at("Fx_N"), v.at("Tz_Nm"));
                            feedback.alive_counter = static_cast<std::uint8_t>(v.at("AliveCounter"));
                            return clm::can::encode_force_feedback(dbc_config(), feedback, out);
                          },
                          [](const Frame& frame, Values& v) {
                            clm::can::ForceFeedback feedback;
                            const CodecStatus status = clm::can::decode_force_feedback(dbc_config(), frame, feedback);
                            v["Fy_N"] = feedback.wrench[0];
                            v["Fx_N"] = feedback.wrench[1];
                            v["Tz_Nm"] = feedback.wrench[2];
                            v["AliveCounter"] = feedback.alive_counter;
                            return status;
                          }};
    const auto setpoint_decoder = [](std::vector<int> coil_sets, bool rpdo1) {
      return [coil_sets, rpdo1](const Frame& frame, Values& v) {
        clm::can::SetpointCommand command;
        const CodecStatus status = clm::can::decode_setpoint_frame(dbc_config(), frame, command);
        if (rpdo1) {
          v["ControlEnable"] = command.enable ? 1.0 : 0.0;
          v["ControlClearFault"] = command.clear_fault ? 1.0 : 0.0;
          v["ControlArmLatch"] = command.arm_latch ? 1.0 : 0.0;
          v["ControlLatchOnSwitch"] = command.latch_on_switch ? 1.0 : 0.0;
          v["ControlReserved"] = 0.0;  // a decoded command cannot carry reserved bits
          v["AliveCounter"] = command.alive_counter;
        }
        for (const int l : coil_sets) {
          const auto s = static_cast<std::size_t>(l - 1);
          if (g_profile == DriveProfile::kPhaseCurrent) {
            v["Ia" + std::to_string(l) + "_A"] = command.currents[s].ia_A;
            v["Ib" + std::to_string(l) + "_A"] = command.currents[s].ib_A;
          } else {
            v["Magnitude" + std::to_string(l) + "_N"] = command.setpoints[s].magnitude_N;
            v["Delta" + std::to_string(l) + "_rad"] = command.setpoints[s].delta_rad;
          }
        }
        return status;
      };
    };
    t["DriveSetpoint1"] = {[](const Values& v, Frame& out) { return encode_setpoint_frame(v, 0, out); },
                           setpoint_decoder({1}, true)};
    t["DriveSetpoint2"] = {[](const Values& v, Frame& out) { return encode_setpoint_frame(v, 1, out); },
                           setpoint_decoder({2, 3}, false)};
    t["DriveSetpoint3"] = {[](const Values& v, Frame& out) { return encode_setpoint_frame(v, 2, out); },
                           setpoint_decoder({4}, false)};
    return t;
  }();
  return table;
}

}  // namespace

TEST_CASE("the DBC names the three nodes and exactly the seven frames of the protocol", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    CHECK(dbc().nodes == std::vector<std::string>{"Daemon", "Drive", "ForceSensor"});
    std::set<std::string> names;
    for (const auto& message : dbc().messages) names.insert(message.name);
    CHECK(names == std::set<std::string>{"Sync", "DriveFeedback", "DriveLatch", "ForceFeedback", "DriveSetpoint1",
                                         "DriveSetpoint2", "DriveSetpoint3"});
    CHECK(dbc().messages.size() == 7);
  }
}

TEST_CASE("every DBC frame has the codec's identifier and DLC and sender for the default node IDs", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    const auto config = dbc_config();
    CHECK(message_named("Sync").id == clm::can::kSyncId);
    CHECK(message_named("DriveFeedback").id == clm::can::drive_feedback_id(config));
    CHECK(message_named("DriveLatch").id == clm::can::drive_latch_id(config));
    CHECK(message_named("ForceFeedback").id == clm::can::force_feedback_id(config));
    CHECK(message_named("DriveSetpoint1").id == clm::can::setpoint_id(config, 0));
    CHECK(message_named("DriveSetpoint2").id == clm::can::setpoint_id(config, 1));
    CHECK(message_named("DriveSetpoint3").id == clm::can::setpoint_id(config, 2));
    CHECK(message_named("Sync").sender == "Daemon");
    CHECK(message_named("DriveFeedback").sender == "Drive");
    CHECK(message_named("DriveLatch").sender == "Drive");
    CHECK(message_named("ForceFeedback").sender == "ForceSensor");
    for (const char* name : {"DriveSetpoint1", "DriveSetpoint2", "DriveSetpoint3"}) {
      CHECK(message_named(name).sender == "Daemon");
    }

    // The DLC of the frame the codec writes (all-zero values: in range everywhere but SYNC).
    for (const auto& message : dbc().messages) {
      INFO(message.name);
      Values zeros;
      for (const auto& signal : message.signals) zeros[signal.name] = static_cast<double>(signal.raw_minimum() < 0 ? 0 : signal.raw_minimum()) * signal.scale;
      Frame frame;
      REQUIRE(codecs().at(message.name).encode(zeros, frame) == CodecStatus::kOk);
      CHECK(frame.id == message.id);
      CHECK(frame.dlc == message.dlc);
    }
  }
}

TEST_CASE("every DBC signal is little-endian and covers its frame's bits exactly once and names its unit", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    const std::map<std::string, std::string> unit_of_suffix{{"_m", "m"}, {"_N", "N"}, {"_Nm", "Nm"}, {"_rad", "rad"}, {"_A", "A"}};
    for (const auto& message : dbc().messages) {
      INFO(message.name);
      std::vector<int> owners(static_cast<std::size_t>(8 * message.dlc), 0);
      for (const auto& signal : message.signals) {
        INFO(signal.name);
        CHECK(signal.little_endian);
        CHECK(signal.offset == 0.0);
        for (int b = signal.start_bit; b < signal.start_bit + signal.length_bits; ++b) {
          REQUIRE(b < 8 * message.dlc);
          ++owners[static_cast<std::size_t>(b)];
        }
        // Rule 1: the unit is in the name, and the DBC's unit string agrees.
        std::string expected_unit;
        for (const auto& [suffix, unit] : unit_of_suffix) {
          if (signal.name.size() > suffix.size() &&
              signal.name.compare(signal.name.size() - suffix.size(), suffix.size(), suffix) == 0) {
            expected_unit = unit;
          }
        }
        CHECK(signal.unit == expected_unit);
        // The range fits the field.
        const std::int64_t field_min = signal.is_signed ? -(std::int64_t{1} << (signal.length_bits - 1)) : 0;
        const std::int64_t field_max =
            signal.is_signed ? (std::int64_t{1} << (signal.length_bits - 1)) - 1 : (std::int64_t{1} << signal.length_bits) - 1;
        CHECK(signal.raw_minimum() >= field_min);
        CHECK(signal.raw_maximum() <= field_max);
        // Physical signals use the whole field (no range narrower than the codec's).
        if (!signal.unit.empty()) {
          CHECK(signal.raw_minimum() == field_min);
          CHECK(signal.raw_maximum() == field_max);
        }
        const std::string receiver = message.sender == "Daemon" ? "Drive" : "Daemon";
        CHECK(std::find(signal.receivers.begin(), signal.receivers.end(), receiver) != signal.receivers.end());
      }
      for (std::size_t b = 0; b < owners.size(); ++b) {
        INFO("bit " << b);
        CHECK(owners[b] == 1);
      }
    }
  }
}

TEST_CASE("codec and DBC agree bit for bit on random values of every signal", "[can][dbc][property]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    std::mt19937_64 random(20240611);
    for (const auto& message : dbc().messages) {
      INFO(message.name);
      const MessageCodec& codec = codecs().at(message.name);
      for (int trial = 0; trial < 2000; ++trial) {
        // Random raw values in each signal's DBC range; the trials start with the range ends.
        Values values;
        Frame packed;
        packed.id = message.id;
        packed.dlc = static_cast<std::uint8_t>(message.dlc);
        for (const auto& signal : message.signals) {
          std::int64_t raw = 0;
          if (trial == 0) {
            raw = signal.raw_minimum();
          } else if (trial == 1) {
            raw = signal.raw_maximum();
          } else {
            raw = std::uniform_int_distribution<std::int64_t>(signal.raw_minimum(), signal.raw_maximum())(random);
          }
          clm::test::insert_raw(signal, raw, packed);
          values[signal.name] = static_cast<double>(raw) * signal.scale + signal.offset;
        }

        // Decoding the DBC-packed frame gives the DBC's physical values.
        Values decoded;
        REQUIRE(codec.decode(packed, decoded) == CodecStatus::kOk);
        REQUIRE(decoded.size() == message.signals.size());
        for (const auto& signal : message.signals) {
          INFO(signal.name << " raw " << clm::test::extract_raw(signal, packed));
          REQUIRE(decoded.count(signal.name) == 1);
          CHECK(std::abs(decoded.at(signal.name) - values.at(signal.name)) <= 1e-6 * signal.scale);
        }

        // Encoding the physical values gives the DBC-packed bytes.
        Frame encoded;
        REQUIRE(codec.encode(values, encoded) == CodecStatus::kOk);
        INFO(clm::can::describe(packed) << " vs " << clm::can::describe(encoded));
        CHECK(encoded.id == packed.id);
        CHECK(encoded.dlc == packed.dlc);
        CHECK(encoded.data == packed.data);
      }
    }
  }
}

TEST_CASE("the codec refuses one LSB beyond each end of every physical DBC signal", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    for (const auto& message : dbc().messages) {
      const MessageCodec& codec = codecs().at(message.name);
      for (const auto& signal : message.signals) {
        if (signal.unit.empty()) continue;
        INFO(message.name << "." << signal.name);
        Values values;
        for (const auto& other : message.signals) values[other.name] = 0.0;
        Frame frame;
        frame.data.fill(0xA5);
        const Frame untouched = frame;
        values[signal.name] = signal.maximum + signal.scale;
        CHECK(codec.encode(values, frame) == CodecStatus::kOutOfRange);
        values[signal.name] = signal.minimum - signal.scale;
        CHECK(codec.encode(values, frame) == CodecStatus::kOutOfRange);
        CHECK(frame.data == untouched.data);
        values[signal.name] = signal.maximum;
        CHECK(codec.encode(values, frame) == CodecStatus::kOk);
        values[signal.name] = signal.minimum;
        CHECK(codec.encode(values, frame) == CodecStatus::kOk);
      }
    }
  }
}

TEST_CASE("the DBC's status and control bit signals sit at the codec's kStatus and kControl bits", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    // Bits of a signal relative to the first bit of its word: status word at bit 32, control byte at bit 0.
    const auto mask_of = [](const DbcMessage& message, const std::string& name, int word_start) {
      for (const auto& signal : message.signals) {
        if (signal.name == name) {
          return ((std::uint32_t{1} << signal.length_bits) - 1) << (signal.start_bit - word_start);
        }
      }
      FAIL("no signal " << name << " in " << message.name);
      return std::uint32_t{0};
    };
    const DbcMessage& feedback = message_named("DriveFeedback");
    const std::map<std::string, std::uint32_t> status{
        {"StatusEnabled", clm::can::kStatusEnabled},
        {"StatusFault", clm::can::kStatusFault},
        {"StatusWatchdogExpired", clm::can::kStatusWatchdogExpired},
        {"StatusCurrentLimited", clm::can::kStatusCurrentLimited},
        {"StatusEndStop", clm::can::kStatusEndStop},
        {"StatusLatched", clm::can::kStatusLatched},
        {"StatusReferenceSwitch", clm::can::kStatusReferenceSwitch},
        {"StatusReserved", clm::can::kStatusReservedMask}};
    for (const auto& [name, mask] : status) {
      INFO(name);
      CHECK(mask_of(feedback, name, 32) == mask);
    }
    const DbcMessage& rpdo1 = message_named("DriveSetpoint1");
    const std::map<std::string, std::uint32_t> control{
        {"ControlEnable", clm::can::kControlEnable},
        {"ControlClearFault", clm::can::kControlClearFault},
        {"ControlArmLatch", clm::can::kControlArmLatch},
        {"ControlLatchOnSwitch", clm::can::kControlLatchOnSwitch},
        {"ControlReserved", clm::can::kControlReservedMask}};
    for (const auto& [name, mask] : control) {
      INFO(name);
      CHECK(mask_of(rpdo1, name, 0) == mask);
    }
  }
}

TEST_CASE("the DBC's drive latch frame carries the position as the drive feedback does and a count", "[can][dbc]") {
  FOR_EACH_PROFILE {
    INFO("drive profile " << clm::name(profile_under_test));
    const DbcMessage& latch = message_named("DriveLatch");
    CHECK(latch.dlc == clm::can::kDriveLatchDlc);
    REQUIRE(latch.signals.size() == 2);
    const DbcSignal& position = latch.signals[0];
    const DbcSignal& count = latch.signals[1];
    CHECK(position.name == "LatchPosition_m");
    CHECK(count.name == "LatchCount");
    // The same field as DriveFeedback's Position_m: bits 0..31, signed, 1 nm, metres, full int32 range.
    const DbcMessage& feedback = message_named("DriveFeedback");
    const auto same_as = std::find_if(feedback.signals.begin(), feedback.signals.end(),
                                      [](const DbcSignal& s) { return s.name == "Position_m"; });
    REQUIRE(same_as != feedback.signals.end());
    CHECK(position.start_bit == same_as->start_bit);
    CHECK(position.length_bits == same_as->length_bits);
    CHECK(position.is_signed == same_as->is_signed);
    CHECK(position.scale == same_as->scale);
    CHECK(position.minimum == same_as->minimum);
    CHECK(position.maximum == same_as->maximum);
    CHECK(position.unit == same_as->unit);
    CHECK(count.start_bit == 32);
    CHECK(count.length_bits == 8);
    CHECK_FALSE(count.is_signed);
    CHECK(count.raw_minimum() == 0);
    CHECK(count.raw_maximum() == 255);
  }
}
