#pragma once
/// @file
/// Readers for trajectory files: stamped poses T_W_P of some frame P (the sensor, or the vehicle
/// when an extrinsic is given) in the world W.
///
/// - TUM (`t tx ty tz qx qy qz qw` per line, white-space separated, `#` comment lines and blank
///   lines ignored): the format of the TUM RGB-D benchmark and of evo.
/// - CSV with a header line naming the columns (comma separated; spaces around values and a
///   leading `#` on the header are ignored; extra columns are ignored). Accepted column names,
///   case-insensitive:
///   - time: `t`, `time`, `timestamp`, `stamp`, optionally with a unit: `_s` / ` [s]` (seconds,
///     the default), `_ms` / ` [ms]`, `_us` / ` [us]`, `_ns` / ` [ns]`;
///   - position: `x` `y` `z`, `tx` `ty` `tz`, `px` `py` `pz`, `pos_x` ..., `position_x` ...,
///     `p_x` ... (metres; a ` [m]` or `_m` unit suffix is accepted);
///   - orientation (Hamilton quaternion): `qx` `qy` `qz` `qw`, `q_x` ..., `rot_x` ...,
///     `orientation_x` ... .
///
/// Every pose is checked: values must be finite numbers, the quaternion of unit length (within
/// kQuaternionNormTolerance; it is then normalised) and stamps strictly increasing. A problem
/// throws std::runtime_error "<path>: line N: <what is wrong>".

#include "mlmap/core/types.h"

#include <string>
#include <vector>

namespace mlmap::datasets {

/// How far a quaternion's norm may be from 1 before a pose is refused.
inline constexpr double kQuaternionNormTolerance = 1e-3;

/// One pose of a trajectory: T_W_P at `stamp_s`, from line `line` of its file.
struct StampedPose {
  double stamp_s = 0.0;
  Transform T_W_P = Transform::Identity();
  int line = 0;
};

/// Trajectory file formats.
enum class PoseFileFormat {
  kTum,  ///< `t tx ty tz qx qy qz qw`
  kCsv,  ///< comma separated with a header line
};

/// Parses TUM text. @throws std::runtime_error "<source_name>: line N: ..." on any problem.
[[nodiscard]] std::vector<StampedPose> parseTumPoses(const std::string& text,
                                                     const std::string& source_name);

/// Parses CSV text with a header. @throws std::runtime_error "<source_name>: line N: ...".
[[nodiscard]] std::vector<StampedPose> parseCsvPoses(const std::string& text,
                                                     const std::string& source_name);

/// The format of a trajectory file: CSV when the name ends in `.csv` (any case) or the first
/// line that is not blank contains a comma; TUM otherwise.
[[nodiscard]] PoseFileFormat detectPoseFileFormat(const std::string& path, const std::string& text);

/// Reads a trajectory file in either format (detectPoseFileFormat()).
/// @throws std::runtime_error naming the path when it cannot be read, is malformed or has no pose.
[[nodiscard]] std::vector<StampedPose> readPoseFile(const std::string& path);

/// Parses a rigid transform written as `x y z qx qy qz qw` (spaces and/or commas between the
/// seven numbers; metres, Hamilton quaternion of unit length).
/// @throws std::invalid_argument saying what is wrong.
[[nodiscard]] Transform parseTransformXyzQuat(const std::string& text);

}  // namespace mlmap::datasets
