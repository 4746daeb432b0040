#pragma once
// The operators' key (docs/servod.md, "Who may command the axis"): the
// secret that clm-servod and its clients share to authenticate commands,
// acks and telemetry (HMAC-SHA256, config/sha256.hpp). It is a file of 32 to
// 4096 bytes, used as it is, that only its owner and group may read: on an
// installed axis /etc/clm-servo/command.key, root:clm-operators, mode 0640,
// made by the package; anywhere else, e.g.
//     (umask 077; head -c 32 /dev/urandom > command.key)

#include <string>

#include "config/sha256.hpp"

namespace clm {

inline constexpr const char* kDefaultCommandKeyPath = "/etc/clm-servo/command.key";
/// The environment variable that names the key file when neither the
/// configuration (commands.key_file) nor the command line (--key-file) does.
inline constexpr const char* kCommandKeyEnvironment = "CLM_SERVO_KEY_FILE";

/// The key file used when none is named: $CLM_SERVO_KEY_FILE when set and
/// not empty, else kDefaultCommandKeyPath.
std::string default_command_key_path();

/// The key in the file at `path`. Throws clm::FileError, one line naming the
/// file and the rule, when it is not a regular file, cannot be read, holds
/// fewer than 32 or more than 4096 bytes, or may be read or written by
/// others (mode & 0007).
HmacSha256 load_command_key(const std::string& path);

}  // namespace clm
