#pragma once
// Test-only writers of PCD and PLY content (plain, obvious code: the readers are checked
// against them) and a small LZF compressor for PCD binary_compressed.

#include <Eigen/Core>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace mlmap::testing {

/// Appends the bytes of `v`, little or big endian.
template <typename T>
void putBytes(std::string* out, T v, bool big_endian = false) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T); ++i)
    out->push_back(static_cast<char>(b[big_endian ? sizeof(T) - 1 - i : i]));
}

inline std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

/// Greedy LZF compressor (brute-force match search): literal runs of up to 32 bytes, back
/// references of 3..264 bytes up to 8192 bytes back.
inline std::string lzfCompress(const std::string& in) {
  std::string out;
  std::string literal;
  auto flushLiteral = [&]() {
    for (std::size_t i = 0; i < literal.size(); i += 32) {
      const std::size_t n = std::min<std::size_t>(32, literal.size() - i);
      out.push_back(static_cast<char>(n - 1));
      out += literal.substr(i, n);
    }
    literal.clear();
  };
  // Candidates: the last position of each 3-byte prefix, and the 16 positions before i.
  std::vector<long> last(1 << 16, -1);
  auto key = [&](std::size_t at) {
    return (static_cast<unsigned char>(in[at]) << 8 ^ static_cast<unsigned char>(in[at + 1]) << 4 ^
            static_cast<unsigned char>(in[at + 2])) &
           0xffff;
  };
  auto matchLength = [&](std::size_t i, std::size_t d) {
    std::size_t len = 0;
    while (len < 264 && i + len < in.size() && in[i + len] == in[i - d + len]) ++len;
    return len;
  };
  std::size_t i = 0;
  while (i < in.size()) {
    std::size_t best_len = 0, best_dist = 0;
    std::vector<std::size_t> distances;
    for (std::size_t d = 1; d <= std::min<std::size_t>(i, 16); ++d) distances.push_back(d);
    if (i + 2 < in.size()) {
      const long at = last[static_cast<std::size_t>(key(i))];
      if (at >= 0 && i - static_cast<std::size_t>(at) <= 8192)
        distances.push_back(i - static_cast<std::size_t>(at));
      last[static_cast<std::size_t>(key(i))] = static_cast<long>(i);
    }
    for (std::size_t d : distances) {
      const std::size_t len = matchLength(i, d);
      if (len > best_len) {
        best_len = len;
        best_dist = d;
      }
    }
    if (best_len >= 3) {
      flushLiteral();
      const std::size_t off = best_dist - 1;
      const std::size_t l = best_len - 2;
      if (l < 7) {
        out.push_back(static_cast<char>((l << 5) | (off >> 8)));
      } else {
        out.push_back(static_cast<char>((7u << 5) | (off >> 8)));
        out.push_back(static_cast<char>(l - 7));
      }
      out.push_back(static_cast<char>(off & 0xff));
      i += best_len;
    } else {
      literal.push_back(in[i++]);
    }
  }
  flushLiteral();
  return out;
}

/// PCD encodings the writer knows.
enum class PcdData { kAscii, kBinary, kBinaryCompressed };

/// Options of the PCD writer.
struct PcdOptions {
  PcdData data = PcdData::kAscii;
  bool f8 = false;  ///< x y z as F8 instead of F4
  bool extra_fields =
      true;  ///< intensity (F4) before x, a COUNT 3 U1 field, a U2 and an I8 after z
  std::uint32_t height = 1;  ///< organised when > 1 (the point count must divide)
  std::string viewpoint = "0 0 0 1 0 0 0";
};

/// A PCD file of `points` (NaN coordinates allowed).
inline std::string makePcd(const std::vector<Eigen::Vector3d>& points, const PcdOptions& o) {
  const std::size_t n = points.size();
  std::string h = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  const char* xyz_size = o.f8 ? "8" : "4";
  if (o.extra_fields) {
    h += "FIELDS intensity x y z rgb_bytes ring stamp\n";
    h += std::string("SIZE 4 ") + xyz_size + " " + xyz_size + " " + xyz_size + " 1 2 8\n";
    h += "TYPE F F F F U U I\nCOUNT 1 1 1 1 3 1 1\n";
  } else {
    h += std::string("FIELDS x y z\nSIZE ") + xyz_size + " " + xyz_size + " " + xyz_size +
         "\nTYPE F F F\nCOUNT 1 1 1\n";
  }
  h += "WIDTH " + std::to_string(n / o.height) + "\nHEIGHT " + std::to_string(o.height) +
       "\nVIEWPOINT " + o.viewpoint + "\nPOINTS " + std::to_string(n) + "\n";
  auto putXyz = [&](std::string* out, double v) {
    if (o.f8) {
      putBytes(out, v);
    } else {
      putBytes(out, static_cast<float>(v));
    }
  };
  if (o.data == PcdData::kAscii) {
    h += "DATA ascii\n";
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d& p = points[i];
      auto num = [&](double v) { return o.f8 ? fmt(v) : fmt(static_cast<float>(v)); };
      std::string line;
      if (o.extra_fields) line += std::to_string(0.5 * static_cast<double>(i)) + " ";
      line += num(p.x()) + " " + num(p.y()) + " " + num(p.z());
      if (o.extra_fields) line += " 1 2 3 " + std::to_string(i % 64) + " -" + std::to_string(i);
      h += line + "\n";
    }
    return h;
  }
  // Record layout (array of structures).
  std::vector<std::string> records(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::string& r = records[i];
    if (o.extra_fields) putBytes(&r, 0.5f * static_cast<float>(i));
    putXyz(&r, points[i].x());
    putXyz(&r, points[i].y());
    putXyz(&r, points[i].z());
    if (o.extra_fields) {
      r += "\x01\x02\x03";
      putBytes(&r, static_cast<std::uint16_t>(i % 64));
      putBytes(&r, -static_cast<std::int64_t>(i));
    }
  }
  if (o.data == PcdData::kBinary) {
    h += "DATA binary\n";
    for (const std::string& r : records) h += r;
    return h;
  }
  // binary_compressed: field-major (every point's first field, then the second, ...).
  std::vector<std::size_t> field_sizes;
  const std::size_t s = o.f8 ? 8 : 4;
  if (o.extra_fields) {
    field_sizes = {4, s, s, s, 3, 2, 8};
  } else {
    field_sizes = {s, s, s};
  }
  std::string soa;
  std::size_t offset = 0;
  for (std::size_t f : field_sizes) {
    for (std::size_t i = 0; i < n; ++i) soa += records[i].substr(offset, f);
    offset += f;
  }
  const std::string packed = lzfCompress(soa);
  h += "DATA binary_compressed\n";
  putBytes(&h, static_cast<std::uint32_t>(packed.size()));
  putBytes(&h, static_cast<std::uint32_t>(soa.size()));
  return h + packed;
}

/// PLY encodings.
enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

/// A PLY file of `points`: a `material` element with a list before the vertices, vertices with
/// extra properties (nx, red, a list) and x y z as float or double, and faces (lists) after.
inline std::string makePly(const std::vector<Eigen::Vector3d>& points, PlyFormat format,
                           bool doubles) {
  const bool ascii = format == PlyFormat::kAscii;
  const bool be = format == PlyFormat::kBinaryBigEndian;
  const char* t = doubles ? "double" : "float";
  std::string h = "ply\nformat ";
  h += ascii ? "ascii" : be ? "binary_big_endian" : "binary_little_endian";
  h += " 1.0\ncomment written by mlmap's tests\nobj_info nothing\n";
  h += "element material 2\nproperty uchar id\nproperty list uchar float coeffs\n";
  h += "element vertex " + std::to_string(points.size()) + "\n";
  h += "property float nx\nproperty " + std::string(t) + " x\nproperty uchar red\nproperty " + t +
       " y\nproperty list uint8 int16 tags\nproperty " + t + " z\nproperty ushort intensity\n";
  h += "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  auto coord = [&](std::string* out, double v) {
    if (ascii) {
      *out += (doubles ? fmt(v) : fmt(static_cast<float>(v))) + " ";
    } else if (doubles) {
      putBytes(out, v, be);
    } else {
      putBytes(out, static_cast<float>(v), be);
    }
  };
  // materials: id, list of k floats
  for (int m = 0; m < 2; ++m) {
    if (ascii) {
      h += std::to_string(m) + " " + std::to_string(m + 1);
      for (int k = 0; k <= m; ++k) h += " 0.25";
      h += "\n";
    } else {
      putBytes(&h, static_cast<std::uint8_t>(m), be);
      putBytes(&h, static_cast<std::uint8_t>(m + 1), be);
      for (int k = 0; k <= m; ++k) putBytes(&h, 0.25f, be);
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::uint8_t ntags = static_cast<std::uint8_t>(i % 3);
    if (ascii) {
      h += "0.5 ";
      coord(&h, points[i].x());
      h += "200 ";
      coord(&h, points[i].y());
      h += std::to_string(ntags);
      for (int k = 0; k < ntags; ++k) h += " -7";
      h += " ";
      coord(&h, points[i].z());
      h += std::to_string(i % 1000) + "\n";
    } else {
      putBytes(&h, 0.5f, be);
      coord(&h, points[i].x());
      putBytes(&h, static_cast<std::uint8_t>(200), be);
      coord(&h, points[i].y());
      putBytes(&h, ntags, be);
      for (int k = 0; k < ntags; ++k) putBytes(&h, static_cast<std::int16_t>(-7), be);
      coord(&h, points[i].z());
      putBytes(&h, static_cast<std::uint16_t>(i % 1000), be);
    }
  }
  for (int f = 0; f < 2; ++f) {
    if (ascii) {
      h += "3 0 1 2\n";
    } else {
      putBytes(&h, static_cast<std::uint8_t>(3), be);
      for (int k = 0; k < 3; ++k) putBytes(&h, static_cast<std::int32_t>(k), be);
    }
  }
  return h;
}

inline void writeFile(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary);
  out << content;
}

}  // namespace mlmap::testing
