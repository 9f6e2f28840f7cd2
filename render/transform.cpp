// render::Transform (render/tracer.h): placing an object in the scene. A file of its own so that
// code which only places objects (scene/, and through it the `hfrt check` launcher) does not
// link the tracer and, with it, TBB.
#include <cmath>

#include "base/check.h"
#include "render/tracer.h"

namespace hfrt::render {

Transform Transform::from_srt(float scale, Vec3 rotate_deg, Vec3 translate) {
  HFRT_CHECK(scale > 0);
  Transform t;
  t.scale_ = scale;
  t.t_ = translate;
  const double k = M_PI / 180.0;
  double cx = std::cos(rotate_deg.x * k), sx = std::sin(rotate_deg.x * k);
  double cy = std::cos(rotate_deg.y * k), sy = std::sin(rotate_deg.y * k);
  double cz = std::cos(rotate_deg.z * k), sz = std::sin(rotate_deg.z * k);
  // R = Rz Ry Rx: x first.
  double rx[9] = {1, 0, 0, 0, cx, -sx, 0, sx, cx};
  double ry[9] = {cy, 0, sy, 0, 1, 0, -sy, 0, cy};
  double rz[9] = {cz, -sz, 0, sz, cz, 0, 0, 0, 1};
  double ryx[9], r[9];
  auto mul = [](const double* a, const double* b, double* c) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  };
  mul(ry, rx, ryx);
  mul(rz, ryx, r);
  for (int i = 0; i < 9; ++i) t.r_[i] = float(r[i]);
  return t;
}

Vec3 Transform::point_to_world(Vec3 p) const {
  p = p * scale_;
  return Vec3{r_[0] * p.x + r_[1] * p.y + r_[2] * p.z, r_[3] * p.x + r_[4] * p.y + r_[5] * p.z,
              r_[6] * p.x + r_[7] * p.y + r_[8] * p.z} +
         t_;
}

Vec3 Transform::direction_to_object(Vec3 d) const {
  Vec3 q{r_[0] * d.x + r_[3] * d.y + r_[6] * d.z, r_[1] * d.x + r_[4] * d.y + r_[7] * d.z,
         r_[2] * d.x + r_[5] * d.y + r_[8] * d.z};
  return q / scale_;
}

Vec3 Transform::point_to_object(Vec3 p) const {
  return direction_to_object(p - t_);
}

Vec3 Transform::normal_to_world(Vec3 n) const {
  return Vec3{r_[0] * n.x + r_[1] * n.y + r_[2] * n.z, r_[3] * n.x + r_[4] * n.y + r_[5] * n.z,
              r_[6] * n.x + r_[7] * n.y + r_[8] * n.z};
}

Box Transform::box_to_world(const Box& box) const {
  Box out;
  for (int c = 0; c < 8; ++c) {
    Vec3 p{(c & 1) ? box.hi.x : box.lo.x, (c & 2) ? box.hi.y : box.lo.y,
           (c & 4) ? box.hi.z : box.lo.z};
    out.extend(point_to_world(p));
  }
  return out;
}

}  // namespace hfrt::render
