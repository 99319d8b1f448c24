#include "mlmap/datasets/pose_file.h"

#include "mlmap/datasets/point_cloud_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace mlmap::datasets {
namespace {

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    out.push_back(line);
  }
  return out;
}

std::string at(const std::string& source, int line) {
  return source + ": line " + std::to_string(line) + ": ";
}

double number(const std::string& token, const std::string& source, int line, const char* what) {
  const std::string t = trim(token);
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size()) {
    throw std::runtime_error(at(source, line) + what + " '" + t + "' is not a number");
  }
  if (!std::isfinite(v))
    throw std::runtime_error(at(source, line) + what + " is not finite (" + t + ")");
  return v;
}

/// Builds and checks one pose; `v` = t, x, y, z, qx, qy, qz, qw. `previous` is the stamp before.
StampedPose makeStamped(const std::array<double, 8>& v, const std::string& source, int line,
                        const std::vector<StampedPose>& so_far) {
  StampedPose p;
  p.stamp_s = v[0];
  p.line = line;
  const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
  if (!makePose(Eigen::Vector3d(v[1], v[2], v[3]), q, &p.T_W_P, kQuaternionNormTolerance)) {
    std::ostringstream m;
    m << at(source, line) << "quaternion (qx qy qz qw) = (" << v[4] << ' ' << v[5] << ' ' << v[6]
      << ' ' << v[7] << ") has norm " << q.norm() << ", not 1";
    throw std::runtime_error(m.str());
  }
  if (!so_far.empty() && !(p.stamp_s > so_far.back().stamp_s)) {
    std::ostringstream m;
    m.precision(17);
    m << at(source, line) << "stamp " << p.stamp_s << " s is not after the previous one ("
      << so_far.back().stamp_s << " s, line " << so_far.back().line << ")";
    throw std::runtime_error(m.str());
  }
  return p;
}

void requireSome(const std::vector<StampedPose>& poses, const std::string& source) {
  if (poses.empty()) throw std::runtime_error(source + ": no poses");
}

/// Column role of a CSV header name: 0 = time, 1..3 = x y z, 4..7 = qx qy qz qw, -1 = other.
/// `time_scale` receives the factor to seconds for time columns.
int columnRole(std::string name, double* time_scale) {
  name = lower(trim(name));
  if (!name.empty() && name[0] == '#') name = trim(name.substr(1));
  // A unit in brackets: "timestamp [ns]", "x [m]".
  std::string unit;
  const std::size_t bracket = name.find('[');
  if (bracket != std::string::npos && name.back() == ']') {
    unit = trim(name.substr(bracket + 1, name.size() - bracket - 2));
    name = trim(name.substr(0, bracket));
  }
  static const char* kTimeNames[] = {"t", "time", "timestamp", "stamp"};
  static const struct {
    const char* suffix;
    double scale;
  } kTimeUnits[] = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"ns", 1e-9}};
  for (const char* base : kTimeNames) {
    if (name == base && (unit.empty() || unit == "s")) {
      *time_scale = 1.0;
      return 0;
    }
    for (const auto& u : kTimeUnits) {
      if ((name == std::string(base) + "_" + u.suffix && unit.empty()) ||
          (name == base && unit == u.suffix)) {
        *time_scale = u.scale;
        return 0;
      }
    }
  }
  if (!unit.empty() && unit != "m") return -1;
  if (name.size() > 2 && name.compare(name.size() - 2, 2, "_m") == 0) name.resize(name.size() - 2);
  static const char* kPositionPrefixes[] = {"", "t", "p", "pos_", "position_", "p_", "t_"};
  static const char* kRotationPrefixes[] = {"q", "q_", "rot_", "orientation_", "quat_"};
  for (int a = 0; a < 3; ++a) {
    const std::string axis(1, static_cast<char>('x' + a));
    for (const char* prefix : kPositionPrefixes) {
      if (name == prefix + axis) return 1 + a;
    }
  }
  for (int a = 0; a < 4; ++a) {
    const std::string axis(1, "xyzw"[a]);
    for (const char* prefix : kRotationPrefixes) {
      if (name == prefix + axis) return 4 + a;
    }
  }
  return -1;
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    out.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

}  // namespace

std::vector<StampedPose> parseTumPoses(const std::string& text, const std::string& source) {
  std::vector<StampedPose> poses;
  const std::vector<std::string> all = lines(text);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const int line = static_cast<int>(i + 1);
    const std::string t = trim(all[i]);
    if (t.empty() || t[0] == '#') continue;
    std::istringstream in(t);
    std::vector<std::string> tokens;
    std::string token;
    while (in >> token) tokens.push_back(token);
    if (tokens.size() != 8) {
      throw std::runtime_error(at(source, line) +
                               "expected 8 values 't tx ty tz qx qy qz qw', got " +
                               std::to_string(tokens.size()));
    }
    static const char* kNames[] = {"t", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    std::array<double, 8> v{};
    for (std::size_t k = 0; k < 8; ++k) v[k] = number(tokens[k], source, line, kNames[k]);
    poses.push_back(makeStamped(v, source, line, poses));
  }
  requireSome(poses, source);
  return poses;
}

std::vector<StampedPose> parseCsvPoses(const std::string& text, const std::string& source) {
  const std::vector<std::string> all = lines(text);
  std::size_t header = 0;
  while (header < all.size() && trim(all[header]).empty()) ++header;
  if (header == all.size()) throw std::runtime_error(source + ": empty file (no CSV header)");
  const std::vector<std::string> names = splitCsv(all[header]);
  std::array<int, 8> column;
  column.fill(-1);
  double time_scale = 1.0;
  for (std::size_t c = 0; c < names.size(); ++c) {
    double scale = 1.0;
    const int role = columnRole(names[c], &scale);
    if (role < 0) continue;
    if (column[static_cast<std::size_t>(role)] >= 0) {
      throw std::runtime_error(at(source, static_cast<int>(header + 1)) + "column '" +
                               trim(names[c]) +
                               "' names a value that an earlier column already gives");
    }
    column[static_cast<std::size_t>(role)] = static_cast<int>(c);
    if (role == 0) time_scale = scale;
  }
  static const char* kRoles[] = {
      "time (t, time, timestamp or stamp)", "x", "y", "z", "qx", "qy", "qz", "qw"};
  for (std::size_t r = 0; r < 8; ++r) {
    if (column[r] < 0) {
      throw std::runtime_error(at(source, static_cast<int>(header + 1)) + "the CSV header has no " +
                               kRoles[r] + " column (header: '" + trim(all[header]) + "')");
    }
  }
  std::vector<StampedPose> poses;
  for (std::size_t i = header + 1; i < all.size(); ++i) {
    const int line = static_cast<int>(i + 1);
    if (trim(all[i]).empty()) continue;
    const std::vector<std::string> cells = splitCsv(all[i]);
    if (cells.size() != names.size()) {
      throw std::runtime_error(at(source, line) + "expected " + std::to_string(names.size()) +
                               " comma-separated values (as the header), got " +
                               std::to_string(cells.size()));
    }
    std::array<double, 8> v{};
    for (std::size_t r = 0; r < 8; ++r) {
      v[r] = number(cells[static_cast<std::size_t>(column[r])], source, line,
                    r == 0 ? "time" : kRoles[r]);
    }
    v[0] *= time_scale;
    poses.push_back(makeStamped(v, source, line, poses));
  }
  requireSome(poses, source);
  return poses;
}

PoseFileFormat detectPoseFileFormat(const std::string& path, const std::string& text) {
  if (path.size() >= 4 && lower(path.substr(path.size() - 4)) == ".csv")
    return PoseFileFormat::kCsv;
  for (const std::string& line : lines(text)) {
    if (trim(line).empty()) continue;
    return line.find(',') != std::string::npos ? PoseFileFormat::kCsv : PoseFileFormat::kTum;
  }
  return PoseFileFormat::kTum;
}

std::vector<StampedPose> readPoseFile(const std::string& path) {
  const std::string text = readFileBytes(path);
  return detectPoseFileFormat(path, text) == PoseFileFormat::kCsv ? parseCsvPoses(text, path)
                                                                  : parseTumPoses(text, path);
}

Transform parseTransformXyzQuat(const std::string& text) {
  std::string spaced = text;
  std::replace(spaced.begin(), spaced.end(), ',', ' ');
  std::istringstream in(spaced);
  std::vector<double> v;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end != token.c_str() + token.size() || !std::isfinite(value)) {
      throw std::invalid_argument("'" + token +
                                  "' is not a finite number (expected 'x y z qx qy qz qw')");
    }
    v.push_back(value);
  }
  if (v.size() != 7) {
    throw std::invalid_argument("expected 7 numbers 'x y z qx qy qz qw', got " +
                                std::to_string(v.size()));
  }
  Transform T = Transform::Identity();
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (!makePose(Eigen::Vector3d(v[0], v[1], v[2]), q, &T, kQuaternionNormTolerance)) {
    throw std::invalid_argument("the quaternion (qx qy qz qw) has norm " +
                                std::to_string(q.norm()) + ", not 1");
  }
  return T;
}

}  // namespace mlmap::datasets
