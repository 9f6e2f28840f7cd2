#pragma once
// Cameras: perspective (eye, look-at, up, vertical field of view) and orthographic (eye,
// look-at, up, view width). Rays are parametrised by *camera depth*: the point at parameter t
// lies at distance t in front of the eye plane, for both kinds. That makes the set of points
// seen through a rectangle of pixels at depths [t0, t1] the convex hull of 8 points, which is
// what per-tile interval culling needs.

#include "render/field.h"
#include "render/vec.h"

namespace hfrt::render {

/// A camera as the user describes it.
struct Camera {
  enum class Kind { kPerspective, kOrthographic };
  Kind kind = Kind::kPerspective;
  Vec3 eye{0, 0, 30};
  Vec3 look_at{0, 0, 0};
  Vec3 up{0, 1, 0};
  /// Vertical field of view in degrees (perspective).
  float fov_deg = 35;
  /// Horizontal width of the view in world units (orthographic).
  float ortho_width = 20;
};

/// A ray o + t d. For camera rays t is the camera depth (see the file comment), so `d` is not
/// unit length for perspective rays; shadow rays use a unit `d`.
struct Ray {
  Vec3 o, d;
};

/// A camera bound to an image size: maps pixel coordinates to rays.
class CameraFrame {
 public:
  /// `camera` must have eye != look_at and an `up` not parallel to the view direction
  /// (checked: a broken camera is a caller bug; the command line validates user input).
  CameraFrame(const Camera& camera, int width, int height);

  /// The ray through the image point (px, py) in pixel units: (0, 0) is the top-left corner
  /// of the image, (width, height) the bottom-right one.
  Ray ray(float px, float py) const;

  /// A box enclosing every point o + t d of every ray through the pixel rectangle
  /// [px0, px1] x [py0, py1] with t in [t0, t1] (the frustum slab of a tile).
  Box slab_box(float px0, float py0, float px1, float py1, float t0, float t1) const;

  /// The smallest t >= 0 (perspective) and the camera-depth range of the points of `box`.
  void depth_range(const Box& box, float* t_min, float* t_max) const;

  bool orthographic() const { return ortho_; }
  /// Half extents of the image plane at depth 1 (perspective) or in world units (ortho): ray()
  /// offsets by (2 px / width - 1) half_width() along right() and (1 - 2 py / height)
  /// half_height() along up().
  float half_width() const { return half_w_; }
  float half_height() const { return half_h_; }
  Vec3 forward() const { return forward_; }
  Vec3 right() const { return right_; }
  Vec3 up() const { return up_; }
  Vec3 eye() const { return eye_; }

 private:
  bool ortho_ = false;
  Vec3 eye_, forward_, right_, up_;
  float half_w_ = 1, half_h_ = 1;  // half extents of the image plane at depth 1 (or in world)
  int width_ = 1, height_ = 1;
};

/// Intersects the ray with `box`: on overlap returns true with the parameter range
/// [*t_enter, *t_exit] (not clamped) and the axis (0..2) of the face it enters through.
bool intersect_box(const Ray& ray, const Box& box, float* t_enter, float* t_exit, int* enter_axis);

}  // namespace hfrt::render
