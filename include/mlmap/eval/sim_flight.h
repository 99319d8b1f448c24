#pragma once
/// @file
/// Flying the engine through a simulated scenario and scoring the map against ground truth.
/// Shared by the demo, the benchmark and the tests.

#include "mlmap/core/voxel_bitset.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"

#include <functional>
#include <limits>
#include <unordered_set>
#include <vector>

namespace mlmap::eval {

/// Hash of a voxel index for unordered containers.
struct VoxelHash {
  std::size_t operator()(const VoxelIndex& v) const {
    return (static_cast<std::size_t>(static_cast<std::uint32_t>(v.x())) * 73856093u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(v.y())) * 19349663u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(v.z())) * 83492791u);
  }
};
using VoxelSet = std::unordered_set<VoxelIndex, VoxelHash>;

/// Occupied-voxel agreement with ground truth. A voxel is truly occupied when its interior
/// overlaps a static solid; recall asks for those that received a measured point. A mapped voxel
/// is right when it touches a solid (a surface lying on its face is an acceptable answer).
struct Accuracy {
  std::size_t mapped = 0;          ///< occupied voxels in the map
  std::size_t observed_truth = 0;  ///< truly occupied voxels that received a measured point
  std::size_t true_positives = 0;  ///< mapped voxels that touch a static solid
  std::size_t recalled = 0;        ///< observed true voxels that are mapped occupied
  double precision = 0.0;          ///< true_positives / mapped
  double recall = 0.0;             ///< recalled / observed_truth
  double f1 = 0.0;
};

/// How to fly.
struct FlightOptions {
  int max_frames = std::numeric_limits<int>::max();  ///< stop after this many frames
  double start_time_s = 0.0;                         ///< first frame time on the trajectory
  /// Called after each frame with (frames done, frames planned).
  std::function<void(int, int)> progress;
  /// Called just before each frame is submitted (after rendering), with its index in the
  /// flight: lets a caller time the engine alone.
  std::function<void(int)> before_submit;
};

/// What a flight produced.
struct FlightResult {
  int frames = 0;
  std::vector<Eigen::Vector3d> trajectory_W;  ///< body positions of the frames
  VoxelSet observed_truth;                    ///< true voxels that received a measured point
  double render_ms_median = 0.0;              ///< simulator cost per frame (not mapping)
};

/// True when the interior of voxel `v` overlaps a static solid (ground truth "occupied").
[[nodiscard]] bool overlapsSolid(const sim::World& world, const VoxelIndex& v, double resolution_m);
/// True when voxel `v` touches a static solid, if only with a face (an acceptable "occupied").
[[nodiscard]] bool touchesSolid(const sim::World& world, const VoxelIndex& v, double resolution_m);

/// Number of frames the scenario's trajectory yields at its frame rate.
[[nodiscard]] int frameCount(const datasets::Scenario& scenario);
/// Body pose and time of frame `i`.
[[nodiscard]] double frameTime(const datasets::Scenario& scenario, int i);

/// The true voxels a flight observed: voxels of measured points whose interior overlaps a static
/// solid of the world, gathered frame by frame.
class ObservedTruth {
 public:
  /// Adds the true voxels of `frame`'s points within `config`'s maximum range.
  void observe(const DepthFrame& frame, const sim::World& world, const MapConfig& config);
  [[nodiscard]] const VoxelSet& voxels() const { return voxels_; }

 private:
  VoxelSet voxels_;
  std::vector<Eigen::Vector3f> points_S_;  ///< scratch
  VoxelBitset seen_;                       ///< scratch: the frame's voxels already looked at
};

/// Renders every frame of the scenario (datasets::SimulatedFlightSource, the camera mounted as
/// `config.sensor` says) and submits it to `engine` as a depth image. Also gathers the observed
/// ground truth.
FlightResult flyScenario(const datasets::Scenario& scenario, MapEngine& engine,
                         const FlightOptions& options = {});

/// Scores occupied voxels (see Accuracy).
[[nodiscard]] Accuracy scoreOccupancy(const std::vector<VoxelIndex>& mapped,
                                      const VoxelSet& observed_truth, const sim::World& world,
                                      double resolution_m);

}  // namespace mlmap::eval
