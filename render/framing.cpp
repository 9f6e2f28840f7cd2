#include "render/framing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace hfrt::render {

namespace {

Box empty_box() {
  float inf = std::numeric_limits<float>::infinity();
  return {{inf, inf, inf}, {-inf, -inf, -inf}};
}

void grow(Box& b, const Box& c) {
  b.lo = vmin(b.lo, c.lo);
  b.hi = vmax(b.hi, c.hi);
}

Box extent_by_intervals(const Field& field, const Box& bbox, int depth) {
  Box found = empty_box();
  struct Node {
    Box box;
    int level;
  };
  std::vector<Node> stack{{bbox, 0}};
  // A budget keeps pathological enclosures (every box straddles) from exploding: the boxes
  // left when it runs out are kept whole, which only makes the extent larger.
  size_t budget = 200000;
  while (!stack.empty()) {
    Node node = stack.back();
    stack.pop_back();
    bool maybe_nan = false;
    Interval iv = field.eval_interval(node.box, &maybe_nan);
    if (iv.hi < 0) continue;
    bool inside = !std::isnan(iv.lo) && iv.lo >= 0 && !maybe_nan;
    if (inside || node.level >= depth || budget < 8) {
      grow(found, node.box);
      continue;
    }
    budget -= 8;
    Vec3 c = node.box.center();
    for (int k = 0; k < 8; ++k) {
      Box child;
      child.lo = {(k & 1) ? c.x : node.box.lo.x, (k & 2) ? c.y : node.box.lo.y,
                  (k & 4) ? c.z : node.box.lo.z};
      child.hi = {(k & 1) ? node.box.hi.x : c.x, (k & 2) ? node.box.hi.y : c.y,
                  (k & 4) ? node.box.hi.z : c.z};
      // Skip children already inside the extent found so far: they cannot grow it.
      if (!found.empty() && found.contains(child.lo) && found.contains(child.hi)) continue;
      stack.push_back({child, node.level + 1});
    }
  }
  return found;
}

Box extent_by_sampling(const Field& field, const Box& bbox, int depth) {
  const int n = (1 << std::min(depth, 7)) + 1;
  Vec3 cell = bbox.size() / float(n - 1);
  Box found = empty_box();
  std::vector<float> xs(size_t(n) * n), ys(xs.size()), zs(xs.size()), fs(xs.size());
  for (int k = 0; k < n; ++k) {
    float z = k == n - 1 ? bbox.hi.z : bbox.lo.z + cell.z * float(k);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        size_t idx = size_t(j) * n + i;
        xs[idx] = i == n - 1 ? bbox.hi.x : bbox.lo.x + cell.x * float(i);
        ys[idx] = j == n - 1 ? bbox.hi.y : bbox.lo.y + cell.y * float(j);
        zs[idx] = z;
      }
    }
    field.eval(xs.size(), xs.data(), ys.data(), zs.data(), fs.data());
    for (size_t idx = 0; idx < xs.size(); ++idx) {
      if (fs[idx] >= 0) grow(found, Box{{xs[idx], ys[idx], zs[idx]}, {xs[idx], ys[idx], zs[idx]}});
    }
  }
  if (found.empty()) return found;
  // The surface can be up to one cell beyond the outermost inside sample.
  found.lo = vmax(found.lo - cell, bbox.lo);
  found.hi = vmin(found.hi + cell, bbox.hi);
  return found;
}

}  // namespace

Box find_extent(const Field& field, const Box& bbox, int depth, bool* used_interval) {
  bool by_interval = field.has_interval();
  if (used_interval) *used_interval = by_interval;
  Box found = by_interval ? extent_by_intervals(field, bbox, depth)
                          : extent_by_sampling(field, bbox, depth);
  found = intersect(found, bbox);
  if (found.empty()) return bbox;
  if (by_interval) {
    // Interval enclosures of R-function blends can be very loose (the dependency problem:
    // f1 + f2 + sqrt(f1^2 + f2^2) over a box far from the solid still reaches above 0), so the
    // octree may keep most of the box. Sampling inside the sound extent tightens the frame;
    // when no sample is inside (a feature thinner than a cell) the sound extent stays.
    Box fine = intersect(extent_by_sampling(field, found, depth), found);
    if (!fine.empty()) found = fine;
  }
  return found;
}

Vec3 default_view_direction() {
  // 35 degrees to the right of the front view, 25 degrees above it.
  const float az = 35.0f * float(M_PI) / 180.0f, el = 25.0f * float(M_PI) / 180.0f;
  return {std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el)};
}

Camera resolve_camera(const CameraRequest& request, const Box& extent, float aspect) {
  Camera cam;
  cam.up = request.up.value_or(Vec3{0, 1, 0});
  cam.fov_deg = request.fov_deg.value_or(35.0f);
  cam.look_at = request.look_at.value_or(extent.center());
  float radius = std::max(0.5f * length(extent.size()), 1e-6f);
  if (request.ortho_width) {
    cam.kind = Camera::Kind::kOrthographic;
    cam.ortho_width = *request.ortho_width;
  }
  if (request.eye) {
    cam.eye = *request.eye;
  } else {
    Vec3 dir = default_view_direction();
    // Keep the default direction usable with a user-given up vector.
    if (length(cross(dir, normalize(cam.up))) < 1e-3f) dir = normalize(dir + Vec3{0.3f, 0, 0.4f});
    float dist = 2.0f * radius;  // orthographic: anywhere outside the bounding sphere
    if (cam.kind == Camera::Kind::kPerspective) {
      // The nearest eye position (along dir) from which all 8 corners of the extent project
      // inside the frame, plus a margin.
      Vec3 right = normalize(cross(-dir, cam.up)), up = cross(right, -dir);
      float tan_v = std::tan(0.5f * cam.fov_deg * float(M_PI) / 180.0f), tan_h = tan_v * aspect;
      dist = 0;
      for (int c = 0; c < 8; ++c) {
        Vec3 p{(c & 1) ? extent.hi.x : extent.lo.x, (c & 2) ? extent.hi.y : extent.lo.y,
               (c & 4) ? extent.hi.z : extent.lo.z};
        Vec3 q = p - cam.look_at;
        float toward = dot(q, dir);
        dist = std::max(dist, toward + std::abs(dot(q, right)) / tan_h);
        dist = std::max(dist, toward + std::abs(dot(q, up)) / tan_v);
      }
      dist = std::max(1.1f * dist, 1.05f * radius);
    }
    cam.eye = cam.look_at + dir * dist;
  }
  return cam;
}

}  // namespace hfrt::render
