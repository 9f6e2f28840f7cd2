#include "render/camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/check.h"

namespace hfrt::render {

CameraFrame::CameraFrame(const Camera& camera, int width, int height)
    : ortho_(camera.kind == Camera::Kind::kOrthographic),
      eye_(camera.eye),
      width_(width),
      height_(height) {
  HFRT_CHECK(width > 0 && height > 0);
  Vec3 view = camera.look_at - camera.eye;
  HFRT_CHECK_MSG(length(view) > 0, "camera eye equals look-at");
  forward_ = normalize(view);
  right_ = cross(forward_, camera.up);
  HFRT_CHECK_MSG(length(right_) > 1e-6f * length(camera.up), "camera up is parallel to the view");
  right_ = normalize(right_);
  up_ = cross(right_, forward_);
  float aspect = float(width) / float(height);
  if (ortho_) {
    HFRT_CHECK(camera.ortho_width > 0);
    half_w_ = camera.ortho_width * 0.5f;
    half_h_ = half_w_ / aspect;
  } else {
    HFRT_CHECK(camera.fov_deg > 0 && camera.fov_deg < 180);
    half_h_ = std::tan(camera.fov_deg * 0.5f * float(M_PI) / 180.0f);
    half_w_ = half_h_ * aspect;
  }
}

Ray CameraFrame::ray(float px, float py) const {
  float sx = (2.0f * px / float(width_) - 1.0f) * half_w_;
  float sy = (1.0f - 2.0f * py / float(height_)) * half_h_;
  Vec3 offset = right_ * sx + up_ * sy;
  if (ortho_) return {eye_ + offset, forward_};
  return {eye_, forward_ + offset};
}

Box CameraFrame::slab_box(float px0, float py0, float px1, float py1, float t0, float t1) const {
  // The region is the image of a box under a map that is affine in (sx, sy) for each t and
  // affine in t for each (sx, sy): its convex hull has these 8 corners.
  Box b{{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
         std::numeric_limits<float>::infinity()},
        {-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
         -std::numeric_limits<float>::infinity()}};
  const float pxs[2] = {px0, px1}, pys[2] = {py0, py1}, ts[2] = {t0, t1};
  for (float px : pxs)
    for (float py : pys) {
      Ray r = ray(px, py);
      for (float t : ts) {
        Vec3 p = r.o + r.d * t;
        b.lo = vmin(b.lo, p);
        b.hi = vmax(b.hi, p);
      }
    }
  // Rounding in o + t d (here and where the samples are computed) is a few ulps: widen the box
  // so that it stays a sound enclosure of the sample points.
  for (int i = 0; i < 3; ++i) {
    float pad = 4e-7f * std::max(std::abs(b.lo[i]), std::abs(b.hi[i])) + 1e-30f;
    b.lo[i] -= pad;
    b.hi[i] += pad;
  }
  return b;
}

void CameraFrame::depth_range(const Box& box, float* t_min, float* t_max) const {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (int c = 0; c < 8; ++c) {
    Vec3 p{(c & 1) ? box.hi.x : box.lo.x, (c & 2) ? box.hi.y : box.lo.y,
           (c & 4) ? box.hi.z : box.lo.z};
    float t = dot(p - eye_, forward_);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  if (!ortho_) lo = std::max(lo, 0.0f);
  *t_min = lo;
  *t_max = hi;
}

bool intersect_box(const Ray& ray, const Box& box, float* t_enter, float* t_exit, int* enter_axis) {
  float t0 = -std::numeric_limits<float>::infinity();
  float t1 = std::numeric_limits<float>::infinity();
  int axis = -1;
  for (int i = 0; i < 3; ++i) {
    float o = ray.o[i], d = ray.d[i];
    if (d == 0) {
      if (o < box.lo[i] || o > box.hi[i]) return false;
      continue;
    }
    float inv = 1.0f / d;
    float a = (box.lo[i] - o) * inv, b = (box.hi[i] - o) * inv;
    if (a > b) std::swap(a, b);
    if (a > t0) {
      t0 = a;
      axis = i;
    }
    t1 = std::min(t1, b);
  }
  if (!(t0 <= t1)) return false;
  *t_enter = t0;
  *t_exit = t1;
  if (enter_axis) *enter_axis = axis;
  return true;
}

}  // namespace hfrt::render
