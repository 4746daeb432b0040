#pragma once
// ServoDaemon's own parts shared by its source files (servo_daemon.cpp,
// servo_daemon_files.cpp): what the loader read, and a law with its files.
// Not for other code.

#include <memory>
#include <string>
#include <vector>

#include "commutation/calibration.hpp"
#include "commutation/classical.hpp"
#include "commutation/model_file.hpp"
#include "daemon/servod/servo_daemon.hpp"

namespace clm::servod {

// The reply to `command`: its sequence and client with `result` and `detail`.
inline CommandReply reply_to(const servo::Command& command, servo::CommandResult result, std::string detail = "") {
  return {command.sequence, command.client, result, std::move(detail)};
}

// What the loader read from one command's file.
struct ServoDaemon::Loaded {
  servo::Command command;
  std::string refusal;  // "" when loaded
  std::string canonical, sha256;
  std::unique_ptr<OwnedLaw> law;
  ProgramFile program;
};

// A law with the files it was built from; the law refers into them.
struct ServoDaemon::OwnedLaw {
  servo::CommutationMode mode = servo::CommutationMode::kOriginal;
  std::string source;  // canonical path of its file
  std::string sha256;  // of its file
  CalibrationFile calibration;
  std::vector<ClassicalEstimate> estimates;
  ModelFile model;
  std::unique_ptr<CommutationLaw> law;
};

}  // namespace clm::servod
