#include "render/framing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace hfrt::render {

namespace {

/// Cells find_extent's octree may evaluate.
constexpr size_t kFramingBudget = 200000;

Box empty_box() {
  float inf = std::numeric_limits<float>::infinity();
  return {{inf, inf, inf}, {-inf, -inf, -inf}};
}

void grow(Box& b, const Box& c) {
  b.lo = vmin(b.lo, c.lo);
  b.hi = vmax(b.hi, c.hi);
}

Box extent_by_intervals(const Field& field, const Box& bbox, int depth, size_t budget) {
  // Level by level, each level's cells in one batch of the interval evaluator (one box at a
  // time cost ~1.1 us per box on c1_gear, the batch a fraction of it).
  Box found = empty_box();
  std::vector<Box> cells{bbox}, next;
  std::vector<Interval> ivs;
  std::unique_ptr<bool[]> nan;
  size_t nan_size = 0;
  // The budget keeps pathological enclosures (every box straddles) from exploding: the cells of
  // the level where it runs out are kept whole, which only makes the extent larger.
  for (int level = 0; !cells.empty(); ++level) {
    const size_t n = cells.size();
    ivs.resize(n);
    if (nan_size < n) {
      nan_size = std::max(n, 2 * nan_size);
      nan.reset(new bool[nan_size]);
    }
    field.eval_intervals(n, cells.data(), ivs.data(), nan.get());
    next.clear();
    for (size_t i = 0; i < n; ++i) {
      const Box& cell = cells[i];
      const Interval iv = ivs[i];
      if (iv.hi < 0) continue;
      const bool inside = !std::isnan(iv.lo) && iv.lo >= 0 && !nan[i];
      if (inside || level >= depth) {
        grow(found, cell);
        continue;
      }
      const Vec3 c = cell.center();
      for (int k = 0; k < 8; ++k) {
        Box child;
        child.lo = {(k & 1) ? c.x : cell.lo.x, (k & 2) ? c.y : cell.lo.y,
                    (k & 4) ? c.z : cell.lo.z};
        child.hi = {(k & 1) ? cell.hi.x : c.x, (k & 2) ? cell.hi.y : c.y,
                    (k & 4) ? cell.hi.z : c.z};
        next.push_back(child);
      }
    }
    if (next.size() > budget) {
      for (const Box& child : next) grow(found, child);
      break;
    }
    budget -= next.size();
    cells.swap(next);
  }
  return found;
}

/// The bounding box of the inside points of an n^3 grid over `bbox` (one cell of margin added),
/// found by sweeping whole grid slices inwards from each side and stopping at the first slice
/// with an inside point: the same box as testing every grid point, at the cost of the slices
/// outside the solid only (a few slices for a tight box instead of n^3 points, which matters
/// for fields that are expensive per point, such as mesh and patch leaves).
Box extent_by_sampling(const Field& field, const Box& bbox, int depth) {
  const int n = (1 << std::min(depth, 7)) + 1;
  const Vec3 cell = bbox.size() / float(n - 1);
  auto coord = [&](int axis, int i) {
    return i == n - 1 ? bbox.hi[axis] : bbox.lo[axis] + cell[axis] * float(i);
  };
  std::vector<float> xs(size_t(n) * n), ys(xs.size()), zs(xs.size()), fs(xs.size());
  // Grid index ranges [lo[a], hi[a]] still to consider on each axis.
  int lo[3] = {0, 0, 0}, hi[3] = {n - 1, n - 1, n - 1};
  // Whether the slice `axis` = i (the other two axes over their current ranges) holds a point
  // where F >= 0 (NaN counts as outside).
  auto slice_has_inside = [&](int axis, int i) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    size_t m = 0;
    float* p[3] = {xs.data(), ys.data(), zs.data()};
    for (int b = lo[v]; b <= hi[v]; ++b) {
      for (int a = lo[u]; a <= hi[u]; ++a, ++m) {
        p[axis][m] = coord(axis, i);
        p[u][m] = coord(u, a);
        p[v][m] = coord(v, b);
      }
    }
    field.eval_sides(m, xs.data(), ys.data(), zs.data(), fs.data());
    for (size_t k = 0; k < m; ++k) {
      if (fs[k] >= 0) return true;
    }
    return false;
  };
  for (int axis = 0; axis < 3; ++axis) {
    int first = lo[axis];
    while (first <= hi[axis] && !slice_has_inside(axis, first)) ++first;
    if (first > hi[axis]) return empty_box();  // no grid point is inside
    int last = hi[axis];
    while (last > first && !slice_has_inside(axis, last)) --last;
    lo[axis] = first;
    hi[axis] = last;
  }
  Box found{{coord(0, lo[0]), coord(1, lo[1]), coord(2, lo[2])},
            {coord(0, hi[0]), coord(1, hi[1]), coord(2, hi[2])}};
  // The surface can be up to one cell beyond the outermost inside sample.
  found.lo = vmax(found.lo - cell, bbox.lo);
  found.hi = vmin(found.hi + cell, bbox.hi);
  return found;
}

}  // namespace

Box find_extent(const Field& field, const Box& bbox, int depth, bool* used_interval) {
  bool by_interval = field.has_interval();
  if (used_interval) *used_interval = by_interval;
  Box found = by_interval ? extent_by_intervals(field, bbox, depth, kFramingBudget)
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

Box proven_extent(const Field& field, const Box& bbox, int depth, size_t max_cells) {
  return intersect(extent_by_intervals(field, bbox, depth, max_cells), bbox);
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
