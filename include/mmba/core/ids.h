#pragma once

#include <cstdint>
#include <functional>
#include <limits>

namespace mmba {

/// A typed id: an integer that cannot be confused with an id of another kind.
/// `Tag` is an empty struct naming the kind (CameraTag, ImageTag, ...).
template <typename Tag>
struct Id {
  using ValueType = uint64_t;
  static constexpr ValueType kInvalidValue = std::numeric_limits<ValueType>::max();

  ValueType value = kInvalidValue;

  constexpr Id() = default;
  constexpr explicit Id(ValueType v) : value(v) {}
  constexpr bool IsValid() const { return value != kInvalidValue; }
  constexpr bool operator==(const Id& o) const { return value == o.value; }
  constexpr bool operator!=(const Id& o) const { return value != o.value; }
  constexpr bool operator<(const Id& o) const { return value < o.value; }
};

struct CameraTag {};
struct ImageTag {};
struct Point3DTag {};
struct RigTag {};
struct ScanTag {};
struct StationTag {};
struct FrameTag {};
struct MountTag {};
struct TrajectoryNodeTag {};

using CameraId = Id<CameraTag>;    ///< intrinsics (COLMAP camera_id)
using ImageId = Id<ImageTag>;      ///< an image and its pose (COLMAP image_id)
using Point3DId = Id<Point3DTag>;  ///< a 3D point (COLMAP point3D_id)
using RigId = Id<RigTag>;
using ScanId = Id<ScanTag>;
using StationId = Id<StationTag>;
using FrameId = Id<FrameTag>;                    ///< one epoch of a camera rig (its rig_from_world)
using MountId = Id<MountTag>;                    ///< a sensor mounted on a platform (e.g. vehicle_from_lidar)
using TrajectoryNodeId = Id<TrajectoryNodeTag>;  ///< a node of a trajectory correction (its index in time order)

}  // namespace mmba

template <typename Tag>
struct std::hash<mmba::Id<Tag>> {
  size_t operator()(const mmba::Id<Tag>& id) const noexcept {
    return std::hash<uint64_t>()(id.value);
  }
};
