#include "geom/bezier.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>

#include "base/check.h"
#include "base/file.h"
#include "geom/bvh.h"

namespace hfrt::geom {
namespace {

// Bernstein basis of degree d (1..3) at t, and its derivative.
void bernstein(int d, double t, double b[4], double db[4]) {
  const double s = 1 - t;
  switch (d) {
    case 1:
      b[0] = s, b[1] = t;
      db[0] = -1, db[1] = 1;
      break;
    case 2:
      b[0] = s * s, b[1] = 2 * t * s, b[2] = t * t;
      db[0] = -2 * s, db[1] = 2 * (s - t), db[2] = 2 * t;
      break;
    default:
      b[0] = s * s * s, b[1] = 3 * t * s * s, b[2] = 3 * t * t * s, b[3] = t * t * t;
      db[0] = -3 * s * s, db[1] = 3 * s * s - 6 * t * s, db[2] = 6 * t * s - 3 * t * t,
      db[3] = 3 * t * t;
      break;
  }
}

// The control points of the Bézier curve segment [t0, t1] of a curve of degree d (d+1 points).
void curve_segment(int d, const Vec3* in, double t0, double t1, Vec3* out) {
  DVec3 p[4];
  for (int i = 0; i <= d; ++i) p[i] = to_d(in[i]);
  // Split at t1, keep the left part [0, t1].
  auto split_left = [d](DVec3* q, double t) {
    DVec3 left[4];
    DVec3 w[4];
    for (int i = 0; i <= d; ++i) w[i] = q[i];
    left[0] = w[0];
    for (int r = 1; r <= d; ++r) {
      for (int i = 0; i <= d - r; ++i)
        w[i] = {w[i].x + t * (w[i + 1].x - w[i].x), w[i].y + t * (w[i + 1].y - w[i].y),
                w[i].z + t * (w[i + 1].z - w[i].z)};
      left[r] = w[0];
    }
    for (int i = 0; i <= d; ++i) q[i] = left[i];
  };
  auto split_right = [d](DVec3* q, double t) {
    DVec3 right[4];
    DVec3 w[4];
    for (int i = 0; i <= d; ++i) w[i] = q[i];
    right[d] = w[d];
    for (int r = 1; r <= d; ++r) {
      for (int i = 0; i <= d - r; ++i)
        w[i] = {w[i].x + t * (w[i + 1].x - w[i].x), w[i].y + t * (w[i + 1].y - w[i].y),
                w[i].z + t * (w[i + 1].z - w[i].z)};
      right[d - r] = w[d - r];
    }
    for (int i = 0; i <= d; ++i) q[i] = right[i];
  };
  if (t1 < 1) split_left(p, t1);
  if (t0 > 0) split_right(p, t1 > 0 ? t0 / t1 : 0);
  for (int i = 0; i <= d; ++i) out[i] = to_f(p[i]);
}

// How far outside [0, 1] a trim point may lie (then clamped): rounding in exporters.
constexpr double kTrimTolerance = 1e-6;

struct Token {
  std::string text;
  size_t line;
};

std::vector<Token> tokenize(const std::string& text) {
  std::vector<Token> out;
  std::istringstream in(text);
  std::string line;
  size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(line.substr(0, line.find('#')));
    std::string tok;
    while (ls >> tok) out.push_back({tok, lineno});
  }
  return out;
}

}  // namespace

namespace {

// The patch point and its partial derivatives, for degrees (du, dv) given at compile time
// (DU, DV > 0: the loops unrolled, for the bicubic patches Newton evaluates on every ray) or
// at run time (DU = DV = 0). The same operations in the same order either way.
template <int DU, int DV>
DVec3 eval_patch(const BezierPatch& patch, double u, double v, DVec3* pu, DVec3* pv) {
  const int du = DU > 0 ? DU : patch.du, dv = DV > 0 ? DV : patch.dv;
  double bu[4], dbu[4], bv[4], dbv[4];
  bernstein(du, u, bu, dbu);
  bernstein(dv, v, bv, dbv);
  DVec3 p, a, b;
  for (int j = 0; j <= dv; ++j) {
    // Row j contracted along u: its point and u-derivative.
    double rx = 0, ry = 0, rz = 0, sx = 0, sy = 0, sz = 0;
    for (int i = 0; i <= du; ++i) {
      const Vec3 c = patch.cp[j * (du + 1) + i];
      rx += bu[i] * c.x, ry += bu[i] * c.y, rz += bu[i] * c.z;
      sx += dbu[i] * c.x, sy += dbu[i] * c.y, sz += dbu[i] * c.z;
    }
    p.x += bv[j] * rx, p.y += bv[j] * ry, p.z += bv[j] * rz;
    a.x += bv[j] * sx, a.y += bv[j] * sy, a.z += bv[j] * sz;
    b.x += dbv[j] * rx, b.y += dbv[j] * ry, b.z += dbv[j] * rz;
  }
  if (pu) *pu = a;
  if (pv) *pv = b;
  return p;
}

}  // namespace

static_assert(alignof(BicubicD) == 32, "eval_bicubic's AVX2 clone loads the lanes aligned");

BicubicD::BicubicD(const BezierPatch& p) {
  HFRT_CHECK(p.du == 3 && p.dv == 3);
  for (int k = 0; k < 16; ++k) cp[k] = V4d{p.cp[k].x, p.cp[k].y, p.cp[k].z, 0};
}

namespace {

// eval_bicubic's body, inlined into a generic copy and an AVX2 one (eval_bicubic picks one
// for the CPU; both run the same operations, so they give the same bits).
[[gnu::always_inline]] inline DVec3 eval_bicubic_body(const BicubicD& patch, double u, double v,
                                                      DVec3* pu, DVec3* pv) {
  using V4d = BicubicD::V4d;
  double bu[4], dbu[4], bv[4], dbv[4];
  bernstein(3, u, bu, dbu);
  bernstein(3, v, bv, dbv);
  // eval_patch<3, 3> with x, y, z as lanes: each lane's sums are that function's, term by term.
  V4d p = {0, 0, 0, 0}, a = p, b = p;
  for (int j = 0; j <= 3; ++j) {
    V4d r = {0, 0, 0, 0}, sd = r;
    for (int i = 0; i <= 3; ++i) {
      const V4d c = patch.cp[j * 4 + i];
      r += bu[i] * c;
      sd += dbu[i] * c;
    }
    p += bv[j] * r;
    a += bv[j] * sd;
    b += dbv[j] * r;
  }
  if (pu) *pu = {a[0], a[1], a[2]};
  if (pv) *pv = {b[0], b[1], b[2]};
  return {p[0], p[1], p[2]};
}

__attribute__((target("avx2"))) DVec3 eval_bicubic_avx2(const BicubicD& patch, double u, double v,
                                                        DVec3* pu, DVec3* pv) {
  return eval_bicubic_body(patch, u, v, pu, pv);
}

bool cpu_has_avx2() {
  __builtin_cpu_init();  // needed before __builtin_cpu_supports in a static initialiser
  return __builtin_cpu_supports("avx2");
}

// Chosen once at start-up, not by a target_clones ifunc: its resolver runs while the dynamic
// loader relocates, before a sanitizer's runtime is up (the TSan build crashed there). Code
// that runs before this initialiser gets the generic copy, which gives the same bits.
const bool kHasAvx2 = cpu_has_avx2();

}  // namespace

DVec3 eval_bicubic_generic(const BicubicD& patch, double u, double v, DVec3* pu, DVec3* pv) {
  return eval_bicubic_body(patch, u, v, pu, pv);
}

DVec3 eval_bicubic(const BicubicD& patch, double u, double v, DVec3* pu, DVec3* pv) {
  return kHasAvx2 ? eval_bicubic_avx2(patch, u, v, pu, pv)
                  : eval_bicubic_generic(patch, u, v, pu, pv);
}

DVec3 BezierPatch::eval(double u, double v, DVec3* pu, DVec3* pv) const {
  if (du == 3 && dv == 3) return eval_patch<3, 3>(*this, u, v, pu, pv);
  return eval_patch<0, 0>(*this, u, v, pu, pv);
}

Box BezierPatch::control_bounds() const {
  Box b;
  for (int k = 0; k < num_control_points(); ++k) b.extend(cp[k]);
  return b;
}

BezierPatch BezierPatch::sub_patch(double u0, double u1, double v0, double v1) const {
  BezierPatch out = *this;
  Vec3 row[4], seg[4];
  for (int j = 0; j <= dv; ++j) {
    for (int i = 0; i <= du; ++i) row[i] = control(i, j);
    curve_segment(du, row, u0, u1, seg);
    for (int i = 0; i <= du; ++i) out.control(i, j) = seg[i];
  }
  for (int i = 0; i <= du; ++i) {
    for (int j = 0; j <= dv; ++j) row[j] = out.control(i, j);
    curve_segment(dv, row, v0, v1, seg);
    for (int j = 0; j <= dv; ++j) out.control(i, j) = seg[j];
  }
  return out;
}

float BezierPatch::flatness() const {
  const Vec3 p00 = control(0, 0), p10 = control(du, 0), p01 = control(0, dv), p11 = control(du, dv);
  // The largest squared distance, then one square root: sqrt is correctly rounded and
  // monotonic, so this is the largest distance bit for bit (one sqrt instead of 16, and the
  // parameters' divisions once per row and column).
  float su[4], tv[4];
  for (int i = 0; i <= du; ++i) su[i] = float(i) / du;
  for (int j = 0; j <= dv; ++j) tv[j] = float(j) / dv;
  float worst2 = 0;
  for (int j = 0; j <= dv; ++j)
    for (int i = 0; i <= du; ++i) {
      const float s = su[i], t = tv[j];
      const Vec3 bl =
          p00 * ((1 - s) * (1 - t)) + p10 * (s * (1 - t)) + p01 * ((1 - s) * t) + p11 * (s * t);
      worst2 = std::max(worst2, length2(control(i, j) - bl));
    }
  return std::sqrt(worst2);
}

Box PatchSet::bounds() const {
  Box b;
  for (const BezierPatch& p : patches) b.extend(p.control_bounds());
  return b;
}

Result<PatchSet> parse_bpt(const std::string& text, const std::string& name) {
  const std::vector<Token> toks = tokenize(text);
  size_t pos = 0;
  auto at = [&](size_t line, const std::string& what) {
    return Error{name + ":" + std::to_string(line) + ": " + what};
  };
  auto last_line = [&] { return toks.empty() ? size_t{1} : toks.back().line; };
  auto next_int = [&](const char* what, long* out) -> std::optional<Error> {
    if (pos >= toks.size()) return at(last_line(), std::string("file ends before ") + what);
    const Token& t = toks[pos++];
    char* end = nullptr;
    *out = std::strtol(t.text.c_str(), &end, 10);
    if (end == t.text.c_str() || *end != '\0')
      return at(t.line, std::string("expected ") + what + ", found '" + t.text + "'");
    return std::nullopt;
  };
  if (toks.empty()) return Error{name + ": empty file (expected the number of patches)"};
  long count = 0;
  if (auto e = next_int("the number of patches", &count)) return *e;
  if (count <= 0) return at(toks[0].line, "the number of patches must be positive");
  PatchSet set;
  set.source = name;
  for (long p = 0; p < count; ++p) {
    BezierPatch patch;
    long du = 0, dv = 0;
    const std::string which = "patch " + std::to_string(p + 1);
    if (auto e = next_int(("the u degree of " + which).c_str(), &du)) return *e;
    if (auto e = next_int(("the v degree of " + which).c_str(), &dv)) return *e;
    if (du < 1 || du > 3 || dv < 1 || dv > 3)
      return at(toks[pos - 1].line, which + ": degrees " + std::to_string(du) + " " +
                                        std::to_string(dv) + " not in 1..3");
    patch.du = static_cast<int>(du);
    patch.dv = static_cast<int>(dv);
    for (int k = 0; k < patch.num_control_points(); ++k) {
      float c[3];
      for (int a = 0; a < 3; ++a) {
        if (pos >= toks.size())
          return at(last_line(), "file ends inside " + which + " (control point " +
                                     std::to_string(k + 1) + " of " +
                                     std::to_string(patch.num_control_points()) + ")");
        const Token& t = toks[pos++];
        char* end = nullptr;
        const double v = std::strtod(t.text.c_str(), &end);
        if (end == t.text.c_str() || *end != '\0')
          return at(t.line, "malformed coordinate '" + t.text + "' in " + which);
        if (!std::isfinite(v) || !std::isfinite(static_cast<float>(v)))
          return at(t.line, "non-finite coordinate '" + t.text + "' in " + which);
        c[a] = static_cast<float>(v);
      }
      patch.cp[k] = {c[0], c[1], c[2]};
    }
    set.patches.push_back(patch);
  }
  // Trim records: `trim P L`, then L loops of `n` and n (u, v) points.
  std::vector<std::vector<std::vector<UV>>> loops;
  while (pos < toks.size()) {
    if (toks[pos].text != "trim")
      return at(toks[pos].line, "unexpected '" + toks[pos].text + "' after the " +
                                    std::to_string(count) + " patches");
    ++pos;
    long patch = 0, nloops = 0;
    if (auto e = next_int("the patch index of a trim record", &patch)) return *e;
    if (patch < 1 || patch > count)
      return at(toks[pos - 1].line, "trim patch index " + std::to_string(patch) +
                                        " out of range 1.." + std::to_string(count));
    const std::string which = "the trim record of patch " + std::to_string(patch);
    if (auto e = next_int(("the number of loops of " + which).c_str(), &nloops)) return *e;
    if (nloops < 1)
      return at(toks[pos - 1].line,
                which + ": the number of loops must be positive, found " + std::to_string(nloops));
    if (loops.empty()) loops.resize(count);
    for (long l = 0; l < nloops; ++l) {
      const std::string loop = "loop " + std::to_string(l + 1) + " of " + which;
      long n = 0;
      if (auto e = next_int(("the number of points of " + loop).c_str(), &n)) return *e;
      if (n < 3)
        return at(toks[pos - 1].line,
                  loop + " has " + std::to_string(n) + " points, at least 3 are needed");
      std::vector<UV> pts;
      for (long k = 0; k < n; ++k) {
        double c[2];
        for (int a = 0; a < 2; ++a) {
          if (pos >= toks.size())
            return at(last_line(), "file ends inside " + loop + " (point " + std::to_string(k + 1) +
                                       " of " + std::to_string(n) + ")");
          const Token& t = toks[pos++];
          char* end = nullptr;
          const double v = std::strtod(t.text.c_str(), &end);
          if (end == t.text.c_str() || *end != '\0')
            return at(t.line, "malformed trim coordinate '" + t.text + "' in " + loop);
          if (!std::isfinite(v))
            return at(t.line, "non-finite trim coordinate '" + t.text + "' in " + loop);
          if (v < -kTrimTolerance || v > 1 + kTrimTolerance)
            return at(t.line, "trim coordinate " + t.text + " in " + loop +
                                  " is outside the parameter range [0, 1]");
          c[a] = std::clamp(v, 0.0, 1.0);
        }
        pts.push_back({c[0], c[1]});
      }
      // A polyline closed explicitly (last point = first) is the same loop.
      if (pts.back().u == pts.front().u && pts.back().v == pts.front().v) pts.pop_back();
      loops[patch - 1].push_back(std::move(pts));
    }
  }
  if (!loops.empty())
    for (std::vector<std::vector<UV>>& l : loops) set.trims.emplace_back(std::move(l));
  return set;
}

Result<PatchSet> load_bpt(const std::string& path, const Limits& limits) {
  Result<std::string> text =
      read_file_limited(path, limits.max_mesh_bytes, /*regular_only=*/true, "max_mesh_bytes");
  if (!text) return file_error(path, text.error());
  return parse_bpt(*text, path);
}

Result<PatchSet> patches_from_array(std::span<const double> p, const std::string& what) {
  if (p.empty()) return Error{what + ": no patches"};
  if (p.size() % 48 != 0)
    return Error{what + ": " + std::to_string(p.size()) +
                 " numbers, not a multiple of 48 (16 control points per bicubic patch)"};
  PatchSet set;
  set.source = what;
  for (size_t k = 0; k < p.size() / 48; ++k) {
    BezierPatch patch;
    for (int i = 0; i < 16; ++i) {
      const double* c = &p[48 * k + 3 * i];
      Vec3 v{static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2])};
      if (!is_finite(v))
        return Error{what + ": patch " + std::to_string(k + 1) + " control point " +
                     std::to_string(i + 1) + " is not finite"};
      patch.cp[i] = v;
    }
    set.patches.push_back(patch);
  }
  return set;
}

namespace {

/// A patch at the half-steps k / (2n) of an n x n grid, k = 0..2n: the tessellation's
/// vertices (even k) and the midpoints its error is measured at (odd k). Each point is
/// eval_patch's sum with the same operations in the same order (the parameters are the same
/// doubles: i / n and (i + 0.5) / n are (2i) / (2n) and (2i + 1) / (2n) correctly rounded),
/// so the points are BezierPatch::eval's bit for bit, at a fraction of the cost: each row's
/// contraction along u is made once per u instead of once per point.
class HalfGrid {
 public:
  HalfGrid(const BezierPatch& patch, int n) : n_(n), dv_(patch.dv), rows_(size_t(2 * n + 1) * 4) {
    bv_.resize(size_t(2 * n + 1));
    for (int k = 0; k <= 2 * n; ++k) {
      double bu[4], dbu[4];
      bernstein(patch.du, param(k), bu, dbu);
      bernstein(patch.dv, param(k), bv_[size_t(k)].data(), dbu);
      for (int j = 0; j <= patch.dv; ++j) {
        double rx = 0, ry = 0, rz = 0;
        for (int i = 0; i <= patch.du; ++i) {
          const Vec3 c = patch.cp[j * (patch.du + 1) + i];
          rx += bu[i] * c.x, ry += bu[i] * c.y, rz += bu[i] * c.z;
        }
        rows_[size_t(k) * 4 + size_t(j)] = DVec3{rx, ry, rz};
      }
    }
  }
  /// The point at (ku / (2n), kv / (2n)).
  Vec3 at(int ku, int kv) const {
    const std::array<double, 4>& bv = bv_[size_t(kv)];
    const DVec3* r = &rows_[size_t(ku) * 4];
    DVec3 p;
    for (int j = 0; j <= dv_; ++j)
      p.x += bv[j] * r[j].x, p.y += bv[j] * r[j].y, p.z += bv[j] * r[j].z;
    return to_f(p);
  }

 private:
  double param(int k) const { return k % 2 == 0 ? double(k / 2) / n_ : (k / 2 + 0.5) / n_; }
  int n_, dv_;
  std::vector<DVec3> rows_;  // [k][j]: row j contracted along u at u = k / (2n)
  std::vector<std::array<double, 4>> bv_;
};

}  // namespace

TriangleMesh tessellate(const PatchSet& set, int n, float* max_error, std::vector<uint64_t>* keys,
                        std::vector<TriangleUV>* uvs) {
  HFRT_CHECK(n >= 1 && n < (1 << 16));
  TriangleMesh mesh;
  if (keys) keys->clear();
  if (uvs) uvs->clear();
  // The quads in Morton order, so that each quadtree node of a patch's grid is a contiguous
  // run of triangles (build_bvh_grouped).
  std::vector<std::array<uint32_t, 3>> quad_order;  // (Morton code, i, j)
  quad_order.reserve(size_t(n) * n);
  for (uint32_t j = 0; j < uint32_t(n); ++j)
    for (uint32_t i = 0; i < uint32_t(n); ++i) quad_order.push_back({morton2(i, j), i, j});
  std::sort(quad_order.begin(), quad_order.end());
  mesh.source =
      set.source + " (tessellated " + std::to_string(n) + "x" + std::to_string(n) + " per patch)";
  float err = 0;
  std::vector<std::array<UV, 3>> clipped;
  for (size_t p = 0; p < set.patches.size(); ++p) {
    const BezierPatch& patch = set.patches[p];
    const Trim* trim = set.trim(p);
    const uint32_t base = static_cast<uint32_t>(mesh.vertices.size());
    const HalfGrid grid(patch, n);
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) mesh.vertices.push_back(grid.at(2 * i, 2 * j));
    auto idx = [&](int i, int j) { return base + static_cast<uint32_t>(j * (n + 1) + i); };
    for (const auto& [code, qi, qj] : quad_order) {
      const int i = int(qi), j = int(qj);
      const uint64_t key = (uint64_t(p) << 32) | code;
      const Trim::Cover cover =
          trim ? trim->classify(double(i) / n, double(i + 1) / n, double(j) / n, double(j + 1) / n)
               : Trim::Cover::kKept;
      if (cover == Trim::Cover::kRemoved) continue;
      if (cover == Trim::Cover::kPartial) {
        // The kept part of the quad, exactly in (u, v); its own vertices (a T-junction
        // with the neighbouring quads is harmless to distances and winding numbers).
        clipped.clear();
        trim->clip(double(i) / n, double(i + 1) / n, double(j) / n, double(j + 1) / n, &clipped);
        for (const std::array<UV, 3>& tri : clipped) {
          const uint32_t first = static_cast<uint32_t>(mesh.vertices.size());
          Vec3 q[3];
          for (int k = 0; k < 3; ++k) {
            q[k] = to_f(patch.eval(tri[k].u, tri[k].v));
            mesh.vertices.push_back(q[k]);
          }
          mesh.triangles.push_back({first, first + 1, first + 2});
          if (keys) keys->push_back(key);
          if (uvs) {
            TriangleUV t{uint32_t(p)};
            for (int k = 0; k < 3; ++k) t.u[k] = float(tri[k].u), t.v[k] = float(tri[k].v);
            uvs->push_back(t);
          }
          if (max_error) {
            // Edge midpoints and the centroid against the flat triangle.
            for (int k = 0; k < 3; ++k) {
              const UV a = tri[k], b = tri[(k + 1) % 3];
              const Vec3 m = to_f(patch.eval(0.5 * (a.u + b.u), 0.5 * (a.v + b.v)));
              err = std::max(err, length(m - (q[k] + q[(k + 1) % 3]) * 0.5f));
            }
            const Vec3 c = to_f(patch.eval((tri[0].u + tri[1].u + tri[2].u) / 3,
                                           (tri[0].v + tri[1].v + tri[2].v) / 3));
            err = std::max(err, length(c - (q[0] + q[1] + q[2]) * (1.0f / 3)));
          }
        }
        continue;
      }
      mesh.triangles.push_back({idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)});
      mesh.triangles.push_back({idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)});
      if (keys) keys->insert(keys->end(), 2, key);
      if (uvs) {
        const float ua = float(double(i) / n), ub = float(double(i + 1) / n);
        const float va = float(double(j) / n), vb = float(double(j + 1) / n);
        uvs->push_back({uint32_t(p), {ua, ub, ub}, {va, va, vb}});
        uvs->push_back({uint32_t(p), {ua, ub, ua}, {va, vb, vb}});
      }
      if (max_error) {
        // Deviation at the quad centre (from the diagonal midpoint) and at the edge midpoints.
        const Vec3 c = grid.at(2 * i + 1, 2 * j + 1);
        const Vec3 d = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i + 1, j + 1)]) * 0.5f;
        const Vec3 e = grid.at(2 * i + 1, 2 * j);
        const Vec3 f = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i + 1, j)]) * 0.5f;
        const Vec3 g = grid.at(2 * i, 2 * j + 1);
        const Vec3 h = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i, j + 1)]) * 0.5f;
        err = std::max({err, length(c - d), length(e - f), length(g - h)});
        if (trim) {
          // The top and right edges too: the neighbour that samples them may be trimmed.
          const Vec3 k = grid.at(2 * i + 1, 2 * j + 2);
          const Vec3 l = (mesh.vertices[idx(i, j + 1)] + mesh.vertices[idx(i + 1, j + 1)]) * 0.5f;
          const Vec3 m = grid.at(2 * i + 2, 2 * j + 1);
          const Vec3 q = (mesh.vertices[idx(i + 1, j)] + mesh.vertices[idx(i + 1, j + 1)]) * 0.5f;
          err = std::max({err, length(k - l), length(m - q)});
        }
      }
    }
  }
  if (max_error) *max_error = err;
  return mesh;
}

}  // namespace hfrt::geom
