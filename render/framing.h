#pragma once
// Default framing: where is the solid inside the bounding box, and from where to look at it
// when the user gives no camera.

#include <optional>

#include "render/camera.h"
#include "render/field.h"

namespace hfrt::render {

/// A box enclosing the part of `bbox` where F may be >= 0. With an interval evaluator: octree
/// subdivision of `bbox` (boxes whose interval excludes 0 are dropped) to `depth` levels, then
/// tightened by a grid of samples inside it (loose enclosures otherwise frame too wide); without
/// one: a grid of 2^depth + 1 samples per axis, widened by one cell. Returns `bbox` itself when
/// nothing was found (an empty model still gets a sensible camera). `used_interval` (optional)
/// tells which method ran.
Box find_extent(const Field& field, const Box& bbox, int depth = 6, bool* used_interval = nullptr);

/// A box outside of which (within `bbox`) intervals prove F < 0: the octree subdivision of
/// find_extent to `depth` levels without its tightening by samples, so it is sound wherever
/// the interval evaluator is (render/field.h). It stops a level early where that level would
/// take the cells evaluated past `max_cells` (a looser box, at a bounded cost). Empty when no
/// cell of the octree may hold F >= 0. Needs field.has_interval().
Box proven_extent(const Field& field, const Box& bbox, int depth, size_t max_cells);

/// What the user said about the camera; missing parts are filled in by resolve_camera.
struct CameraRequest {
  std::optional<Vec3> eye, look_at, up;
  std::optional<float> fov_deg;
  /// Set: orthographic with this view width.
  std::optional<float> ortho_width;
};

/// The direction from the target towards the default eye: a three-quarter view from the front
/// right and above (y is up, as in the original HyperFun viewer).
Vec3 default_view_direction();

/// Completes a camera: look-at defaults to the centre of `extent`, up to +y, fov to 35
/// degrees; a missing eye is placed along the default view direction (or, with only the eye
/// given, the look-at stays the extent's centre) at the distance where the bounding sphere of
/// `extent` fits the frame of an image of `aspect` = width / height.
Camera resolve_camera(const CameraRequest& request, const Box& extent, float aspect);

}  // namespace hfrt::render
