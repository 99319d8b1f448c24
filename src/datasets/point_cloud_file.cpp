#include "mlmap/datasets/point_cloud_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace mlmap::datasets {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw std::runtime_error(source + ": " + what);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  std::string w;
  while (in >> w) words.push_back(w);
  return words;
}

/// Parses a whole token as a double ("nan", "inf" accepted: such points are dropped later).
bool parseDouble(const std::string& token, double* value) {
  if (token.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(token.c_str(), &end);
  return end == token.c_str() + token.size();
}

bool parseCount(const std::string& token, std::uint64_t* value) {
  if (token.empty() || !std::all_of(token.begin(), token.end(), [](char c) {
        return std::isdigit(static_cast<unsigned char>(c));
      })) {
    return false;
  }
  if (token.size() > 12) return false;  // > 10^12 points: not a real file
  *value = std::strtoull(token.c_str(), nullptr, 10);
  return true;
}

/// A scalar value type of a file: its size and how to read it.
enum class Kind { kInt, kUint, kFloat };
struct ScalarType {
  Kind kind = Kind::kFloat;
  std::size_t size = 4;
};

/// Reads one scalar of `type` at `p` (`big_endian` byte order) as a double.
double loadScalar(const unsigned char* p, const ScalarType& type, bool big_endian) {
  unsigned char b[8];
  for (std::size_t i = 0; i < type.size; ++i) b[i] = big_endian ? p[type.size - 1 - i] : p[i];
  switch (type.kind) {
    case Kind::kFloat:
      if (type.size == 4) {
        float f;
        std::memcpy(&f, b, 4);
        return f;
      } else {
        double d;
        std::memcpy(&d, b, 8);
        return d;
      }
    case Kind::kUint: {
      std::uint64_t u = 0;
      for (std::size_t i = type.size; i-- > 0;) u = (u << 8) | b[i];
      return static_cast<double>(u);
    }
    case Kind::kInt: {
      std::uint64_t u = 0;
      for (std::size_t i = type.size; i-- > 0;) u = (u << 8) | b[i];
      const unsigned bits = static_cast<unsigned>(8 * type.size);
      if (bits < 64 && (u >> (bits - 1)) != 0) u |= ~std::uint64_t{0} << bits;  // sign-extend
      std::int64_t s;
      std::memcpy(&s, &u, 8);
      return static_cast<double>(s);
    }
  }
  return 0.0;
}

/// Appends the point (x, y, z) if finite; counts it as dropped otherwise.
void addPoint(double x, double y, double z, PointCloudFile* cloud) {
  const Eigen::Vector3f p(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  if (p.allFinite()) {
    cloud->points_C.push_back(p);
  } else {
    ++cloud->non_finite_dropped;
  }
}

/// Splits off the next line of `content` from `pos` (without '\n' and a trailing '\r').
/// Returns false at the end of the content.
bool nextLine(const std::string& content, std::size_t* pos, std::string* line) {
  if (*pos >= content.size()) return false;
  std::size_t end = content.find('\n', *pos);
  const std::size_t next = end == std::string::npos ? content.size() : end + 1;
  if (end == std::string::npos) end = content.size();
  *line = content.substr(*pos, end - *pos);
  if (!line->empty() && line->back() == '\r') line->pop_back();
  *pos = next;
  return true;
}

// ---- PCD ------------------------------------------------------------------------------------

struct PcdField {
  std::string name;
  ScalarType type;
  std::size_t count = 1;
  std::size_t offset = 0;  ///< byte offset in a binary point record
};

}  // namespace

bool lzfDecompress(const unsigned char* in, std::size_t in_size, std::size_t expected_size,
                   std::vector<unsigned char>* out) {
  out->assign(expected_size, 0);
  std::size_t ip = 0;
  std::size_t op = 0;
  while (ip < in_size) {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const std::size_t len = ctrl + 1u;
      if (ip + len > in_size || op + len > expected_size) return false;
      std::memcpy(out->data() + op, in + ip, len);
      ip += len;
      op += len;
    } else {  // back reference
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) return false;
        len += in[ip++];
      }
      len += 2;
      if (ip >= in_size) return false;
      const std::size_t distance = ((ctrl & 0x1fu) << 8) + in[ip++] + 1u;
      if (distance > op || op + len > expected_size) return false;
      for (std::size_t i = 0; i < len; ++i, ++op)
        (*out)[op] = (*out)[op - distance];  // may overlap
    }
  }
  return op == expected_size;
}

namespace {

/// A PCD header as written, checked line by line (readPcdHeader()).
struct PcdHeader {
  std::vector<PcdField> fields;  ///< names only; types and sizes come from pcdLayout()
  std::vector<std::string> sizes, types, counts;
  std::uint64_t width = 0, height = 1, points = 0;
  bool have_width = false, have_points = false, have_fields = false;
  std::string data;               ///< ascii, binary or binary_compressed (checked by the reader)
  std::vector<double> viewpoint;  ///< empty or tx ty tz qw qx qy qz
};

/// The header's WIDTH, HEIGHT or POINTS value (one non-negative integer).
std::uint64_t pcdCount(const std::vector<std::string>& args, const std::string& source,
                       const std::string& where) {
  std::uint64_t v = 0;
  if (args.size() != 1 || !parseCount(args[0], &v))
    fail(source, where + ": expected one non-negative integer");
  return v;
}

/// The header's VIEWPOINT: 7 finite numbers.
std::vector<double> pcdViewpoint(const std::vector<std::string>& args, const std::string& source,
                                 const std::string& where) {
  std::vector<double> viewpoint;
  for (const std::string& a : args) {
    double v = 0.0;
    if (!parseDouble(a, &v) || !std::isfinite(v))
      fail(source, where + ": '" + a + "' is not a finite number");
    viewpoint.push_back(v);
  }
  if (viewpoint.size() != 7) fail(source, where + ": expected 7 values tx ty tz qw qx qy qz");
  return viewpoint;
}

/// Applies one header line (`key` and its `args`) to `h`.
void applyPcdHeaderLine(const std::string& key, const std::vector<std::string>& args, int line_no,
                        const std::string& source, PcdHeader* h) {
  const std::string where = "PCD header line " + std::to_string(line_no) + " (" + key + ")";
  if (key == "VERSION") {
    return;
  } else if (key == "FIELDS") {
    if (args.empty()) fail(source, where + ": no field names");
    for (const std::string& a : args) h->fields.push_back({a, {}, 1, 0});
    h->have_fields = true;
  } else if (key == "SIZE") {
    h->sizes = args;
  } else if (key == "TYPE") {
    h->types = args;
  } else if (key == "COUNT") {
    h->counts = args;
  } else if (key == "WIDTH") {
    h->width = pcdCount(args, source, where);
    h->have_width = true;
  } else if (key == "HEIGHT") {
    h->height = pcdCount(args, source, where);
  } else if (key == "POINTS") {
    h->points = pcdCount(args, source, where);
    h->have_points = true;
  } else if (key == "VIEWPOINT") {
    h->viewpoint = pcdViewpoint(args, source, where);
  } else if (key == "DATA") {
    if (args.size() != 1) fail(source, where + ": expected ascii, binary or binary_compressed");
    h->data = args[0];
  } else {
    fail(source, "PCD header line " + std::to_string(line_no) + ": unknown keyword '" + key + "'");
  }
}

/// Reads the header lines up to and including DATA; `pos` and `line_no` end after it.
PcdHeader readPcdHeader(const std::string& content, const std::string& source, std::size_t* pos,
                        int* line_no) {
  PcdHeader h;
  std::string line;
  while (h.data.empty()) {
    if (!nextLine(content, pos, &line)) fail(source, "PCD header ends before its DATA line");
    ++*line_no;
    const std::vector<std::string> w = splitWords(line);
    if (w.empty() || w[0][0] == '#') continue;
    applyPcdHeaderLine(w[0], std::vector<std::string>(w.begin() + 1, w.end()), *line_no, source,
                       &h);
  }
  return h;
}

/// Checks that the header's lines agree: as many sizes, types (and counts) as fields, WIDTH
/// given, WIDTH x HEIGHT within 32 bits each and equal to POINTS.
void checkPcdSize(const PcdHeader& h, const std::string& source) {
  if (!h.have_fields) fail(source, "PCD header has no FIELDS line");
  if (h.sizes.size() != h.fields.size() || h.types.size() != h.fields.size()) {
    fail(source, "PCD header: FIELDS names " + std::to_string(h.fields.size()) +
                     " fields but SIZE has " + std::to_string(h.sizes.size()) + " and TYPE " +
                     std::to_string(h.types.size()));
  }
  if (!h.counts.empty() && h.counts.size() != h.fields.size()) {
    fail(source, "PCD header: COUNT has " + std::to_string(h.counts.size()) + " entries for " +
                     std::to_string(h.fields.size()) + " fields");
  }
  if (!h.have_width) fail(source, "PCD header has no WIDTH line");
  if (h.width > std::numeric_limits<std::uint32_t>::max() ||
      h.height > std::numeric_limits<std::uint32_t>::max()) {
    fail(source, "PCD header: WIDTH " + std::to_string(h.width) + " x HEIGHT " +
                     std::to_string(h.height) + " is beyond 32 bits per dimension");
  }
  const std::uint64_t points = h.have_points ? h.points : h.width * h.height;
  if (points != h.width * h.height) {
    fail(source, "PCD header: POINTS " + std::to_string(points) + " is not WIDTH x HEIGHT = " +
                     std::to_string(h.width) + " x " + std::to_string(h.height));
  }
}

/// Where each field lies in a point record, and which fields are x, y and z.
struct PcdLayout {
  std::vector<PcdField> fields;
  std::size_t record = 0;            ///< bytes per point (binary)
  std::size_t values_per_point = 0;  ///< numbers per line (ascii)
  std::size_t xyz[3] = {0, 0, 0};    ///< field index of x, y, z
  [[nodiscard]] const PcdField& axis(int a) const { return fields[xyz[a]]; }
};

/// Field `f`'s type from its SIZE, TYPE and COUNT entries.
void setPcdFieldType(const PcdHeader& h, std::size_t f, const std::string& source,
                     PcdField* field) {
  std::uint64_t size = 0, count = 1;
  if (!parseCount(h.sizes[f], &size) || (size != 1 && size != 2 && size != 4 && size != 8)) {
    fail(source, "PCD field '" + field->name + "': SIZE '" + h.sizes[f] + "' is not 1, 2, 4 or 8");
  }
  if (!h.counts.empty() && (!parseCount(h.counts[f], &count) || count == 0 || count > 1000000)) {
    fail(source,
         "PCD field '" + field->name + "': COUNT '" + h.counts[f] + "' is not a positive integer");
  }
  const std::string& t = h.types[f];
  if (t == "F") {
    field->type.kind = Kind::kFloat;
    if (size != 4 && size != 8)
      fail(source, "PCD field '" + field->name + "': TYPE F needs SIZE 4 or 8, got " + h.sizes[f]);
  } else if (t == "I") {
    field->type.kind = Kind::kInt;
  } else if (t == "U") {
    field->type.kind = Kind::kUint;
  } else {
    fail(source, "PCD field '" + field->name + "': TYPE '" + t + "' is not F, I or U");
  }
  field->type.size = static_cast<std::size_t>(size);
  field->count = static_cast<std::size_t>(count);
}

/// The fields' types and offsets; x, y and z each exactly once, TYPE F with COUNT 1.
PcdLayout pcdLayout(const PcdHeader& h, const std::string& source) {
  PcdLayout layout;
  layout.fields = h.fields;
  int xyz[3] = {-1, -1, -1};
  for (std::size_t f = 0; f < layout.fields.size(); ++f) {
    PcdField& field = layout.fields[f];
    setPcdFieldType(h, f, source, &field);
    field.offset = layout.record;
    layout.record += field.type.size * field.count;
    layout.values_per_point += field.count;
    for (int a = 0; a < 3; ++a) {
      if (field.name != std::string(1, static_cast<char>('x' + a))) continue;
      if (xyz[a] >= 0) fail(source, "PCD header: field '" + field.name + "' appears twice");
      if (field.type.kind != Kind::kFloat || field.count != 1) {
        fail(source, "PCD field '" + field.name +
                         "' must be TYPE F (SIZE 4 or 8) with COUNT 1, got TYPE " + h.types[f] +
                         " SIZE " + h.sizes[f] + " COUNT " + std::to_string(field.count));
      }
      xyz[a] = static_cast<int>(f);
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (xyz[a] < 0)
      fail(source, std::string("PCD file has no field '") + static_cast<char>('x' + a) + "'");
    layout.xyz[a] = static_cast<std::size_t>(xyz[a]);
  }
  return layout;
}

/// The cloud the header describes, without its points.
PointCloudFile pcdCloud(const PcdHeader& h, const std::string& source) {
  PointCloudFile cloud;
  cloud.points_in_file = static_cast<std::size_t>(h.width * h.height);
  cloud.width = static_cast<std::uint32_t>(h.width);
  cloud.height = static_cast<std::uint32_t>(h.height);
  if (!h.viewpoint.empty()) {
    const std::vector<double>& v = h.viewpoint;
    const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    if (!makePose(Eigen::Vector3d(v[0], v[1], v[2]), q, &cloud.T_C_V)) {
      fail(source, "PCD VIEWPOINT: the quaternion qw qx qy qz is not of unit length");
    }
  }
  cloud.encoding = "pcd " + h.data;
  return cloud;
}

/// DATA ascii: one line of numbers per point, from `pos` (header line `line_no`) on.
void readPcdAscii(const std::string& content, const std::string& source, const PcdLayout& layout,
                  std::size_t pos, int line_no, PointCloudFile* cloud) {
  const std::size_t n = cloud->points_in_file;
  std::size_t column[3];
  for (int a = 0; a < 3; ++a) {
    std::size_t c = 0;
    for (std::size_t f = 0; f < layout.xyz[a]; ++f) c += layout.fields[f].count;
    column[a] = c;
  }
  std::size_t read = 0;
  std::string line;
  while (nextLine(content, &pos, &line)) {
    ++line_no;
    const std::vector<std::string> w = splitWords(line);
    if (w.empty()) continue;
    if (read == n) {
      fail(source, "line " + std::to_string(line_no) + ": more data than the " + std::to_string(n) +
                       " points the header declares");
    }
    if (w.size() != layout.values_per_point) {
      fail(source, "line " + std::to_string(line_no) + " (point " + std::to_string(read) +
                       "): expected " + std::to_string(layout.values_per_point) + " values, got " +
                       std::to_string(w.size()));
    }
    double v[3];
    for (int a = 0; a < 3; ++a) {
      if (!parseDouble(w[column[a]], &v[a])) {
        fail(source,
             "line " + std::to_string(line_no) + ": '" + w[column[a]] + "' is not a number");
      }
    }
    addPoint(v[0], v[1], v[2], cloud);
    ++read;
  }
  if (read != n) {
    fail(source, "truncated: the file ends after " + std::to_string(read) + " of " +
                     std::to_string(n) + " points");
  }
}

/// DATA binary: `available` bytes of point records from `bytes` on.
void readPcdBinary(const unsigned char* bytes, std::size_t available, const std::string& source,
                   const PcdLayout& layout, PointCloudFile* cloud) {
  const std::size_t n = cloud->points_in_file;
  const std::size_t needed = n * layout.record;
  if (available < needed) {
    fail(source, "truncated: binary data holds " + std::to_string(available) + " bytes, " +
                     std::to_string(n) + " points of " + std::to_string(layout.record) +
                     " bytes need " + std::to_string(needed));
  }
  if (available > needed) {
    fail(source, std::to_string(available - needed) + " bytes of unexpected data after the " +
                     std::to_string(n) + " points");
  }
  const PcdField& fx = layout.axis(0);
  const PcdField& fy = layout.axis(1);
  const PcdField& fz = layout.axis(2);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* p = bytes + i * layout.record;
    addPoint(loadScalar(p + fx.offset, fx.type, false), loadScalar(p + fy.offset, fy.type, false),
             loadScalar(p + fz.offset, fz.type, false), cloud);
  }
}

/// DATA binary_compressed: sizes, then LZF data of the field-major records.
void readPcdCompressed(const unsigned char* bytes, std::size_t available, const std::string& source,
                       const PcdLayout& layout, PointCloudFile* cloud) {
  const std::size_t n = cloud->points_in_file;
  const std::size_t needed = n * layout.record;
  if (available < 8) fail(source, "truncated: binary_compressed data has no size header");
  std::uint32_t compressed = 0, uncompressed = 0;
  std::memcpy(&compressed, bytes, 4);  // little endian, as the rest
  std::memcpy(&uncompressed, bytes + 4, 4);
  if (uncompressed != needed) {
    fail(source, "binary_compressed: uncompressed size " + std::to_string(uncompressed) +
                     " is not " + std::to_string(n) + " points x " + std::to_string(layout.record) +
                     " bytes");
  }
  if (available - 8 < compressed) {
    fail(source, "truncated: binary_compressed data holds " + std::to_string(available - 8) +
                     " bytes of the " + std::to_string(compressed) + " the header declares");
  }
  if (available - 8 > compressed) {
    fail(source, std::to_string(available - 8 - compressed) +
                     " bytes of unexpected data after the compressed block");
  }
  // An LZF back reference of 3 bytes expands to at most 264: anything that claims more than 88
  // times its compressed size is corrupt, and is refused before its buffer is allocated.
  if (needed > std::size_t{88} * compressed) {
    fail(source, "binary_compressed: " + std::to_string(compressed) +
                     " bytes of LZF data cannot decode to " + std::to_string(needed) + " bytes");
  }
  std::vector<unsigned char> raw;
  if (!lzfDecompress(bytes + 8, compressed, needed, &raw)) {
    fail(source, "binary_compressed: the LZF data is corrupt (does not decode to " +
                     std::to_string(needed) + " bytes)");
  }
  // Field-major layout: every point's x, then every point's y, ...
  const PcdField& fx = layout.axis(0);
  const PcdField& fy = layout.axis(1);
  const PcdField& fz = layout.axis(2);
  const unsigned char* px = raw.data() + n * fx.offset;
  const unsigned char* py = raw.data() + n * fy.offset;
  const unsigned char* pz = raw.data() + n * fz.offset;
  for (std::size_t i = 0; i < n; ++i) {
    addPoint(loadScalar(px + i * fx.type.size, fx.type, false),
             loadScalar(py + i * fy.type.size, fy.type, false),
             loadScalar(pz + i * fz.type.size, fz.type, false), cloud);
  }
}

}  // namespace

PointCloudFile parsePcd(const std::string& content, const std::string& source) {
  std::size_t pos = 0;
  int line_no = 0;
  const PcdHeader header = readPcdHeader(content, source, &pos, &line_no);
  checkPcdSize(header, source);
  const PcdLayout layout = pcdLayout(header, source);
  PointCloudFile cloud = pcdCloud(header, source);
  cloud.points_C.reserve(std::min(cloud.points_in_file, content.size() - pos));  // >= 1 byte each
  if (header.data == "ascii") {
    readPcdAscii(content, source, layout, pos, line_no, &cloud);
    return cloud;
  }
  const auto* bytes = reinterpret_cast<const unsigned char*>(content.data()) + pos;
  const std::size_t available = content.size() - pos;
  const std::size_t n = cloud.points_in_file;
  if (n > std::numeric_limits<std::uint32_t>::max() / layout.record) {
    fail(source,
         std::to_string(n) + " points of " + std::to_string(layout.record) + " bytes: too large");
  }
  if (header.data == "binary") {
    readPcdBinary(bytes, available, source, layout, &cloud);
    return cloud;
  }
  if (header.data == "binary_compressed") {
    readPcdCompressed(bytes, available, source, layout, &cloud);
    return cloud;
  }
  fail(source, "PCD DATA '" + header.data + "' is not ascii, binary or binary_compressed");
}

// ---- PLY ------------------------------------------------------------------------------------

namespace {

bool plyType(const std::string& name, ScalarType* type) {
  static const struct {
    const char* name;
    Kind kind;
    std::size_t size;
  } kTypes[] = {
      {"char", Kind::kInt, 1},     {"int8", Kind::kInt, 1},      {"uchar", Kind::kUint, 1},
      {"uint8", Kind::kUint, 1},   {"short", Kind::kInt, 2},     {"int16", Kind::kInt, 2},
      {"ushort", Kind::kUint, 2},  {"uint16", Kind::kUint, 2},   {"int", Kind::kInt, 4},
      {"int32", Kind::kInt, 4},    {"uint", Kind::kUint, 4},     {"uint32", Kind::kUint, 4},
      {"float", Kind::kFloat, 4},  {"float32", Kind::kFloat, 4}, {"double", Kind::kFloat, 8},
      {"float64", Kind::kFloat, 8}};
  for (const auto& t : kTypes) {
    if (name == t.name) {
      *type = {t.kind, t.size};
      return true;
    }
  }
  return false;
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  ScalarType count_type;  ///< lists: type of the item count
  ScalarType type;        ///< the value (lists: each item)
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

/// Reads values one at a time from PLY body data, ascii or binary.
class PlyBody {
 public:
  PlyBody(const std::string& content, std::size_t pos, bool ascii, bool big_endian,
          const std::string& source)
      : content_(content), pos_(pos), ascii_(ascii), big_endian_(big_endian), source_(source) {}

  /// Next value of `type`; `what` describes it for errors.
  double next(const ScalarType& type, const std::string& what) {
    if (ascii_) {
      while (pos_ < content_.size() && std::isspace(static_cast<unsigned char>(content_[pos_])))
        ++pos_;
      const std::size_t begin = pos_;
      while (pos_ < content_.size() && !std::isspace(static_cast<unsigned char>(content_[pos_])))
        ++pos_;
      if (begin == pos_) fail(source_, "truncated: the file ends before " + what);
      const std::string token = content_.substr(begin, pos_ - begin);
      double v = 0.0;
      if (!parseDouble(token, &v)) fail(source_, what + ": '" + token + "' is not a number");
      return v;
    }
    if (content_.size() - pos_ < type.size)
      fail(source_, "truncated: the file ends before " + what);
    const double v = loadScalar(reinterpret_cast<const unsigned char*>(content_.data()) + pos_,
                                type, big_endian_);
    pos_ += type.size;
    return v;
  }

  /// Throws unless only white space (ascii) or nothing (binary) is left.
  void expectEnd() {
    if (ascii_) {
      while (pos_ < content_.size() && std::isspace(static_cast<unsigned char>(content_[pos_])))
        ++pos_;
    }
    if (pos_ != content_.size()) {
      fail(source_, std::to_string(content_.size() - pos_) +
                        " bytes of unexpected data after the last element");
    }
  }

 private:
  const std::string& content_;
  std::size_t pos_;
  bool ascii_;
  bool big_endian_;
  const std::string& source_;
};

}  // namespace

PointCloudFile parsePly(const std::string& content, const std::string& source) {
  std::size_t pos = 0;
  std::string line;
  if (!nextLine(content, &pos, &line) || line != "ply")
    fail(source, "not a PLY file (no 'ply' first line)");
  std::string format;
  std::vector<PlyElement> elements;
  int line_no = 1;
  for (;;) {
    if (!nextLine(content, &pos, &line)) fail(source, "PLY header ends before 'end_header'");
    ++line_no;
    const std::vector<std::string> w = splitWords(line);
    const std::string where = "PLY header line " + std::to_string(line_no);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() != 3 || w[2] != "1.0")
        fail(source, where + ": expected 'format <encoding> 1.0'");
      format = w[1];
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
        fail(source, where + ": unknown format '" + format + "'");
      }
    } else if (w[0] == "element") {
      std::uint64_t count = 0;
      if (w.size() != 3 || !parseCount(w[2], &count))
        fail(source, where + ": expected 'element <name> <count>'");
      elements.push_back({w[1], count, {}});
    } else if (w[0] == "property") {
      if (elements.empty()) fail(source, where + ": property before any element");
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        p.is_list = true;
        p.name = w[4];
        if (!plyType(w[2], &p.count_type) || p.count_type.kind == Kind::kFloat) {
          fail(source, where + ": list count type '" + w[2] + "' is not an integer type");
        }
        if (!plyType(w[3], &p.type)) fail(source, where + ": unknown type '" + w[3] + "'");
      } else if (w.size() == 3) {
        p.name = w[2];
        if (!plyType(w[1], &p.type)) fail(source, where + ": unknown type '" + w[1] + "'");
      } else {
        fail(source, where +
                         ": expected 'property <type> <name>' or 'property list <count type> "
                         "<type> <name>'");
      }
      elements.back().properties.push_back(p);
    } else {
      fail(source, where + ": unknown keyword '" + w[0] + "'");
    }
  }
  if (format.empty()) fail(source, "PLY header has no format line");
  // Every item of an element with properties takes at least one byte of the body; an item of one
  // without properties takes none, so its count could only spin.
  for (const PlyElement& e : elements) {
    if (e.count > 0 && e.properties.empty()) {
      fail(source, "PLY element '" + e.name + "' has " + std::to_string(e.count) +
                       " items but no properties");
    }
    if (e.count > content.size() - pos) {
      fail(source, "truncated: PLY element '" + e.name + "' declares " + std::to_string(e.count) +
                       " items, the body holds " + std::to_string(content.size() - pos) + " bytes");
    }
  }
  const PlyElement* vertex = nullptr;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") vertex = &e;
  }
  if (vertex == nullptr) fail(source, "PLY file has no 'vertex' element");
  int xyz[3] = {-1, -1, -1};
  for (std::size_t i = 0; i < vertex->properties.size(); ++i) {
    const PlyProperty& p = vertex->properties[i];
    for (int a = 0; a < 3; ++a) {
      if (p.name != std::string(1, static_cast<char>('x' + a))) continue;
      if (p.is_list || p.type.kind != Kind::kFloat) {
        fail(source, "PLY vertex property '" + p.name + "' must be a float or double scalar");
      }
      xyz[a] = static_cast<int>(i);
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (xyz[a] < 0)
      fail(source,
           std::string("PLY vertex element has no property '") + static_cast<char>('x' + a) + "'");
  }

  PointCloudFile cloud;
  cloud.encoding = "ply " + format;
  cloud.points_in_file = static_cast<std::size_t>(vertex->count);
  cloud.width = static_cast<std::uint32_t>(vertex->count);
  cloud.points_C.reserve(std::min(cloud.points_in_file, content.size() - pos));  // >= 1 byte each
  PlyBody body(content, pos, format == "ascii", format == "binary_big_endian", source);
  for (const PlyElement& e : elements) {
    const bool is_vertex = &e == vertex;
    for (std::uint64_t item = 0; item < e.count; ++item) {
      double v[3] = {0.0, 0.0, 0.0};
      for (std::size_t i = 0; i < e.properties.size(); ++i) {
        const PlyProperty& p = e.properties[i];
        const std::string what = e.name + " " + std::to_string(item) + " property '" + p.name + "'";
        if (p.is_list) {
          const double count = body.next(p.count_type, what + " (list count)");
          if (!(count >= 0.0) || count > 1e9 || count != std::floor(count)) {
            fail(source, what + ": bad list count " + std::to_string(count));
          }
          for (std::uint64_t k = 0; k < static_cast<std::uint64_t>(count); ++k)
            body.next(p.type, what);
        } else {
          const double value = body.next(p.type, what);
          for (int a = 0; a < 3; ++a) {
            if (is_vertex && static_cast<int>(i) == xyz[a]) v[a] = value;
          }
        }
      }
      if (is_vertex) addPoint(v[0], v[1], v[2], &cloud);
    }
  }
  body.expectEnd();
  return cloud;
}

std::string readFileBytes(const std::string& path, std::uintmax_t max_bytes) {
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (ec) throw std::runtime_error(path + ": cannot open (" + ec.message() + ")");
  if (!std::filesystem::is_regular_file(status)) {
    throw std::runtime_error(path + (std::filesystem::is_directory(status)
                                         ? ": is a directory, not a file"
                                         : ": is not a regular file (a device, pipe or socket)"));
  }
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw std::runtime_error(path + ": cannot read its size (" + ec.message() + ")");
  if (size > max_bytes) {
    throw std::runtime_error(path + ": " + std::to_string(size) + " bytes, more than the " +
                             std::to_string(max_bytes) + " this reader accepts");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string content(static_cast<std::size_t>(size), '\0');
  in.read(content.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    throw std::runtime_error(path + ": read error after " + std::to_string(in.gcount()) + " of " +
                             std::to_string(size) + " bytes (did the file change?)");
  }
  return content;
}

bool isPointCloudFileName(const std::string& file_name) {
  if (file_name.size() < 5) return false;
  const std::string ext = lower(file_name.substr(file_name.size() - 4));
  return ext == ".pcd" || ext == ".ply";
}

PointCloudFile readPointCloudFile(const std::string& path) {
  if (!isPointCloudFileName(path)) throw std::runtime_error(path + ": not a .pcd or .ply file");
  const std::string content = readFileBytes(path);
  return lower(path.substr(path.size() - 4)) == ".pcd" ? parsePcd(content, path)
                                                       : parsePly(content, path);
}

}  // namespace mlmap::datasets
