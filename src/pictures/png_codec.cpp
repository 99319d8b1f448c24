#include "mlmap/pictures/png_codec.h"

#include <png.h>
#include <zlib.h>

#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <vector>

// libpng reports errors by longjmp back to a setjmp: each function below that calls setjmp keeps
// no C++ object with a destructor in its own frame, and the objects it writes to live in its
// caller's frame, which the jump never leaves.

namespace mlmap::pictures {
namespace {

/// Largest image decoded [bytes of samples]: 256 MB, far above any depth image or picture.
constexpr std::uint64_t kMaxDecodedBytes = std::uint64_t{1} << 28;

/// libpng's last error message.
struct PngError {
  char message[256] = "unknown libpng error";
};

[[noreturn]] void onError(png_structp png, png_const_charp message) {
  auto* error = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(error->message, sizeof(error->message), "%s", message);
  png_longjmp(png, 1);
}

void onWarning(png_structp /*png*/, png_const_charp /*message*/) {}

constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

// ---- Encoding -----------------------------------------------------------------------------------

struct PngSink {
  std::string* bytes = nullptr;
  bool out_of_memory = false;
};

void writeBytes(png_structp png, png_bytep data, png_size_t size) {
  auto* sink = static_cast<PngSink*>(png_get_io_ptr(png));
  try {
    sink->bytes->append(reinterpret_cast<const char*>(data), size);
  } catch (const std::bad_alloc&) {
    sink->out_of_memory = true;
  }
  if (sink->out_of_memory) png_error(png, "out of memory");
}

void flushBytes(png_structp /*png*/) {}

/// Writes the header and `rows` (`height` of them); false on a libpng error.
bool writeImage(png_structp png, png_infop info, png_uint_32 width, png_uint_32 height,
                int bit_depth, int color_type, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png)) != 0) return false;
  png_set_IHDR(png, info, width, height, bit_depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, Z_BEST_SPEED);
  if (bit_depth == 16) {
    // Depth images: smooth, so the difference to the left neighbour compresses (OpenCV's way).
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_strategy(png, Z_RLE);
  } else {
    // Pictures: flat areas and repeated rows; unfiltered, zlib's fastest matching finds them
    // (a third smaller and faster than the above on a map picture).
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
  }
  png_write_info(png, info);
  if (color_type == PNG_COLOR_TYPE_RGB) png_set_bgr(png);
  if (bit_depth == 16 && kLittleEndian) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return true;
}

// ---- Decoding -----------------------------------------------------------------------------------

struct PngSource {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  std::size_t at = 0;
};

void readBytes(png_structp png, png_bytep out, png_size_t size) {
  auto* source = static_cast<PngSource*>(png_get_io_ptr(png));
  if (size > source->size - source->at) png_error(png, "the data end before the image (cut off)");
  std::memcpy(out, source->data + source->at, size);
  source->at += size;
}

struct PngHeader {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int bit_depth = 0;
  int color_type = 0;
};

/// Reads the chunks up to the image data; false on a libpng error.
bool readHeader(png_structp png, png_infop info, PngHeader* header) {
  if (setjmp(png_jmpbuf(png)) != 0) return false;
  png_read_info(png, info);
  png_get_IHDR(png, info, &header->width, &header->height, &header->bit_depth, &header->color_type,
               nullptr, nullptr, nullptr);
  return true;
}

/// Sets the transforms to OpenCV's layout and reads the image into `rows`; false on a libpng
/// error.
bool readImage(png_structp png, png_infop info, const PngHeader& header, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png)) != 0) return false;
  if (header.bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (header.bit_depth == 16 && kLittleEndian) png_set_swap(png);
  if (header.color_type == PNG_COLOR_TYPE_RGB) png_set_bgr(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  return true;
}

}  // namespace

std::string encodePng(const cv::Mat& image) {
  if (image.empty()) throw std::runtime_error("encodePng: the image is empty");
  int bit_depth = 8;
  int color_type = PNG_COLOR_TYPE_GRAY;
  switch (image.type()) {
    case CV_8UC1:
      break;
    case CV_8UC3:
      color_type = PNG_COLOR_TYPE_RGB;
      break;
    case CV_16UC1:
      bit_depth = 16;
      break;
    default:
      throw std::runtime_error("encodePng: cannot encode a " + cv::typeToString(image.type()) +
                               " image (8-bit gray or BGR, or 16-bit gray)");
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.rows));
  for (int r = 0; r < image.rows; ++r) {
    // libpng reads the rows only; its interface is not const.
    rows[static_cast<std::size_t>(r)] = const_cast<png_bytep>(image.ptr<png_byte>(r));
  }
  PngError error;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, onError, onWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error("encodePng: libpng could not start (out of memory)");
  }
  std::string bytes;
  bytes.reserve(image.total() * image.elemSize() / 8 + 1024);
  PngSink sink{&bytes, false};
  png_set_write_fn(png, &sink, writeBytes, flushBytes);
  const bool ok =
      writeImage(png, info, static_cast<png_uint_32>(image.cols),
                 static_cast<png_uint_32>(image.rows), bit_depth, color_type, rows.data());
  png_destroy_write_struct(&png, &info);
  if (!ok) throw std::runtime_error(std::string("encodePng: ") + error.message);
  return bytes;
}

cv::Mat decodePng(const void* bytes, std::size_t size) {
  if (size < 8 || png_sig_cmp(static_cast<png_const_bytep>(bytes), 0, 8) != 0) {
    throw std::runtime_error("decodePng: not a PNG (no PNG signature)");
  }
  PngError error;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, onError, onWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    throw std::runtime_error("decodePng: libpng could not start (out of memory)");
  }
  // Frees libpng's state on every way out.
  struct Guard {
    png_structp* png;
    png_infop* info;
    ~Guard() { png_destroy_read_struct(png, info, nullptr); }
  } guard{&png, &info};
  PngSource source{static_cast<const unsigned char*>(bytes), size, 0};
  png_set_read_fn(png, &source, readBytes);
  PngHeader header;
  if (!readHeader(png, info, &header))
    throw std::runtime_error(std::string("decodePng: ") + error.message);
  int channels = 0;
  if (header.color_type == PNG_COLOR_TYPE_GRAY) channels = 1;
  if (header.color_type == PNG_COLOR_TYPE_RGB) channels = 3;
  if (channels == 0) {
    throw std::runtime_error("decodePng: PNG colour type " + std::to_string(header.color_type) +
                             " (palette or alpha) is not read; gray or RGB are");
  }
  const int depth = header.bit_depth == 16 ? CV_16U : CV_8U;
  const std::uint64_t sample_bytes = header.bit_depth == 16 ? 2 : 1;
  if (std::uint64_t{header.width} * header.height * static_cast<std::uint64_t>(channels) *
          sample_bytes >
      kMaxDecodedBytes) {
    throw std::runtime_error("decodePng: the image (" + std::to_string(header.width) + " x " +
                             std::to_string(header.height) + ") is larger than " +
                             std::to_string(kMaxDecodedBytes >> 20) + " MB decoded");
  }
  cv::Mat image(static_cast<int>(header.height), static_cast<int>(header.width),
                CV_MAKETYPE(depth, channels));
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.rows));
  for (int r = 0; r < image.rows; ++r) rows[static_cast<std::size_t>(r)] = image.ptr<png_byte>(r);
  if (!readImage(png, info, header, rows.data())) {
    throw std::runtime_error(std::string("decodePng: ") + error.message);
  }
  return image;
}

}  // namespace mlmap::pictures
