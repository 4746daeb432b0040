#pragma once
// SHA-256 of data files, recorded in model and calibration provenance.

#include <string>
#include <string_view>

namespace clm {

/// Lower-case hex SHA-256 (FIPS 180-4) of `data`.
std::string sha256_hex(std::string_view data);
/// SHA-256 of a regular file's bytes, read in blocks; throws std::runtime_error
/// (clm::FileError) if it is not a regular file or cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace clm
