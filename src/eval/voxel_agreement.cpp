#include "mlmap/eval/voxel_agreement.h"

namespace mlmap::eval {
namespace {

double ratio(double num, double den) { return den > 0.0 ? num / den : 0.0; }

}  // namespace

bool hasNeighbourWithinOne(const VoxelSet& set, const VoxelIndex& v) {
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        if (set.count(v + VoxelIndex(dx, dy, dz)) != 0) return true;
      }
    }
  }
  return false;
}

VoxelAgreement compareVoxels(const std::vector<VoxelIndex>& a, const std::vector<VoxelIndex>& b) {
  const VoxelSet set_a(a.begin(), a.end());
  const VoxelSet set_b(b.begin(), b.end());
  VoxelAgreement r;
  r.a = set_a.size();
  r.b = set_b.size();
  for (const VoxelIndex& v : set_a) {
    if (set_b.count(v) != 0) ++r.intersection;
    if (hasNeighbourWithinOne(set_b, v)) ++r.matched_a_1;
  }
  for (const VoxelIndex& v : set_b) {
    if (hasNeighbourWithinOne(set_a, v)) ++r.matched_b_1;
  }
  const double na = static_cast<double>(r.a), nb = static_cast<double>(r.b);
  const double inter = static_cast<double>(r.intersection);
  r.iou = ratio(inter, na + nb - inter);
  r.precision = ratio(inter, na);
  r.recall = ratio(inter, nb);
  const double m = 0.5 * static_cast<double>(r.matched_a_1 + r.matched_b_1);
  r.iou_1 = ratio(m, na + nb - m);
  r.precision_1 = ratio(static_cast<double>(r.matched_a_1), na);
  r.recall_1 = ratio(static_cast<double>(r.matched_b_1), nb);
  return r;
}

}  // namespace mlmap::eval
