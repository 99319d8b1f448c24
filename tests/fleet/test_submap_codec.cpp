// The compact submap form: round trips, the choice of compression, and every lie a sample can
// tell about its sizes refused before anything is allocated for it.
#include "mlmap/fleet/submap_codec.h"

#include <gtest/gtest.h>
#include <zstd.h>

#include <random>

namespace mlmap::fleet {
namespace {

constexpr std::uint64_t kVoxels = std::uint64_t{16} * 16 * 6;

std::vector<VoxelRecord> randomRecords(std::mt19937* rng, double density) {
  std::vector<VoxelRecord> records;
  std::bernoulli_distribution take(density);
  std::uniform_int_distribution<int> value(1, 3500);
  for (std::uint32_t o = 0; o < kVoxels; ++o) {
    if (take(*rng)) records.push_back({o, static_cast<LogOddsQ>(value(*rng))});
  }
  return records;
}

SubmapDecodeError decode(const SubmapPayload& p, std::vector<VoxelRecord>* out,
                         std::uint64_t voxels = kVoxels) {
  return decodeSubmapVoxels(p.voxel_count, static_cast<std::uint8_t>(p.encoding), p.raw_size,
                            p.data.data(), p.data.size(), voxels, out);
}

bool sameRecords(const std::vector<VoxelRecord>& a, const std::vector<VoxelRecord>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].offset != b[i].offset || a[i].log_odds != b[i].log_odds) return false;
  }
  return true;
}

TEST(SubmapCodec, RoundTripsAnyContentAndCompressesWhenThatIsSmaller) {
  std::mt19937 rng(7);
  for (const double density : {0.0, 0.001, 0.05, 0.3, 1.0}) {
    const std::vector<VoxelRecord> records = randomRecords(&rng, density);
    const SubmapPayload p = encodeSubmapVoxels(records);
    EXPECT_EQ(p.voxel_count, records.size());
    std::vector<VoxelRecord> back;
    ASSERT_EQ(decode(p, &back), SubmapDecodeError::kNone) << density;
    EXPECT_TRUE(sameRecords(records, back)) << density;
    if (p.encoding == SubmapEncoding::kZstd) {
      EXPECT_LT(p.data.size(), p.raw_size);
    } else {
      EXPECT_EQ(p.data.size(), p.raw_size);
    }
  }
  // A saturated wall (one value, neighbouring offsets) compresses well below 3 bytes per voxel.
  std::vector<VoxelRecord> wall;
  for (std::uint32_t o = 0; o < 600; ++o) wall.push_back({o * 2, 3500});
  const SubmapPayload p = encodeSubmapVoxels(wall);
  EXPECT_EQ(p.encoding, SubmapEncoding::kZstd);
  EXPECT_LT(p.data.size(), wall.size() / 4);
}

TEST(SubmapCodec, RefusesSizesThatLieBeforeAllocating) {
  std::mt19937 rng(3);
  const SubmapPayload good = encodeSubmapVoxels(randomRecords(&rng, 0.05));
  std::vector<VoxelRecord> out;

  SubmapPayload p = good;
  p.encoding = static_cast<SubmapEncoding>(7);
  EXPECT_EQ(decode(p, &out), SubmapDecodeError::kUnknownEncoding);

  p = good;
  p.voxel_count = kVoxels + 1;
  EXPECT_EQ(decode(p, &out), SubmapDecodeError::kTooManyVoxels);

  p = good;
  p.raw_size = 0xffffffffu;  // a 4 GB claim for a few hundred voxels
  EXPECT_EQ(decode(p, &out), SubmapDecodeError::kSizeMismatch);

  p = good;
  p.voxel_count += 1;  // one voxel more than the data holds
  EXPECT_NE(decode(p, &out), SubmapDecodeError::kNone);
  EXPECT_TRUE(out.empty());

  // Raw data whose length is not raw_size.
  p = encodeSubmapVoxels({{1, 5}, {9, 7}});
  ASSERT_EQ(p.encoding, SubmapEncoding::kRaw);
  p.data.push_back(0);
  EXPECT_EQ(decode(p, &out), SubmapDecodeError::kSizeMismatch);
}

TEST(SubmapCodec, RefusesDecompressionBombsAndFramesWithoutTheirSize) {
  std::vector<VoxelRecord> out;
  // 64 MB of zeros in a few kB: the frame says its size, which is not the stated raw_size.
  const std::vector<std::uint8_t> zeros(64u << 20, 0);
  std::vector<std::uint8_t> bomb(ZSTD_compressBound(zeros.size()));
  bomb.resize(ZSTD_compress(bomb.data(), bomb.size(), zeros.data(), zeros.size(), 1));
  EXPECT_EQ(decodeSubmapVoxels(10, 1, 30, bomb.data(), bomb.size(), kVoxels, &out),
            SubmapDecodeError::kBadCompression);
  // The same bytes claiming their true size: beyond what 10 voxels can take.
  EXPECT_EQ(decodeSubmapVoxels(10, 1, 64u << 20, bomb.data(), bomb.size(), kVoxels, &out),
            SubmapDecodeError::kSizeMismatch);

  // A frame that does not say its content size (streamed): refused, not decompressed blindly.
  const std::vector<std::uint8_t> raw = {1, 1, 1, 5, 0, 6, 0, 7, 0};  // 3 voxels
  std::vector<std::uint8_t> streamed(ZSTD_compressBound(raw.size()) + 64);
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 0);
  const std::size_t n =
      ZSTD_compress2(cctx, streamed.data(), streamed.size(), raw.data(), raw.size());
  ZSTD_freeCCtx(cctx);
  ASSERT_FALSE(ZSTD_isError(n));
  streamed.resize(n);
  EXPECT_EQ(decodeSubmapVoxels(3, 1, 9, streamed.data(), streamed.size(), kVoxels, &out),
            SubmapDecodeError::kBadCompression);
  EXPECT_EQ(decodeSubmapVoxels(3, 0, 9, raw.data(), raw.size(), kVoxels, &out),
            SubmapDecodeError::kNone);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].offset, 5u);  // gaps 1, 1, 1 from -1: offsets 1, 3, 5
  // Garbage behind a valid frame.
  std::vector<VoxelRecord> wall;
  for (std::uint32_t o = 0; o < 400; ++o) wall.push_back({o, 3500});
  SubmapPayload padded = encodeSubmapVoxels(wall);
  ASSERT_EQ(padded.encoding, SubmapEncoding::kZstd);
  padded.data.push_back(0);
  EXPECT_EQ(decode(padded, &out), SubmapDecodeError::kBadCompression);
}

TEST(SubmapCodec, RefusesOffsetsOutOfOrderOrBeyondTheSubmap) {
  std::vector<VoxelRecord> out;
  // Offsets 0 and 1000 in a submap of 1000 voxels.
  std::vector<std::uint8_t> beyond = {0, 0xe7, 0x07, 1, 0, 1, 0};  // gap 999 after 0: offset 1000
  EXPECT_EQ(decodeSubmapVoxels(2, 0, 7, beyond.data(), beyond.size(), 1000, &out),
            SubmapDecodeError::kBadOffsets);
  // A varint of six bytes.
  std::vector<std::uint8_t> long_varint = {0x80, 0x80, 0x80, 0x80, 0x80, 0x01, 0, 1, 0, 1, 0};
  EXPECT_EQ(decodeSubmapVoxels(2, 0, 11, long_varint.data(), long_varint.size(), kVoxels, &out),
            SubmapDecodeError::kBadOffsets);
  // Values missing, and one value too many.
  std::vector<std::uint8_t> short_values = {0, 0, 1, 0, 1};
  EXPECT_EQ(decodeSubmapVoxels(2, 0, 5, short_values.data(), short_values.size(), kVoxels, &out),
            SubmapDecodeError::kSizeMismatch);
  std::vector<std::uint8_t> extra = {0, 1, 0, 1, 0, 1, 0};
  EXPECT_EQ(decodeSubmapVoxels(2, 0, 7, extra.data(), extra.size(), kVoxels, &out),
            SubmapDecodeError::kTrailingBytes);
}

TEST(SubmapCodec, RandomBytesNeverCrashAndNeverYieldOffsetsOutsideTheSubmap) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<std::uint32_t> count(0, 50);
  std::vector<VoxelRecord> out;
  std::size_t accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<std::uint8_t> data(static_cast<std::size_t>(byte(rng) % 64));
    for (auto& b : data) b = static_cast<std::uint8_t>(byte(rng) % 8 == 0 ? 0 : byte(rng) % 4);
    const std::uint32_t n = count(rng);
    const auto raw_size = static_cast<std::uint32_t>(data.size());
    const SubmapDecodeError e = decodeSubmapVoxels(n, static_cast<std::uint8_t>(trial % 3),
                                                   raw_size, data.data(), data.size(), 200, &out);
    if (e == SubmapDecodeError::kNone) {
      ++accepted;
      ASSERT_EQ(out.size(), n);
      for (std::size_t i = 0; i < out.size(); ++i) {
        ASSERT_LT(out[i].offset, 200u);
        if (i > 0) {
          ASSERT_LT(out[i - 1].offset, out[i].offset);
        }
      }
    } else {
      ASSERT_TRUE(out.empty());
    }
  }
  EXPECT_GT(accepted, 0u);  // the generator reaches valid payloads too
}

}  // namespace
}  // namespace mlmap::fleet
