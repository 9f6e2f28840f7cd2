#include "geom/bezier.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>

#include "base/file.h"

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

DVec3 BezierPatch::eval(double u, double v, DVec3* pu, DVec3* pv) const {
  double bu[4], dbu[4], bv[4], dbv[4];
  bernstein(du, u, bu, dbu);
  bernstein(dv, v, bv, dbv);
  DVec3 p, a, b;
  for (int j = 0; j <= dv; ++j) {
    // Row j contracted along u: its point and u-derivative.
    double rx = 0, ry = 0, rz = 0, sx = 0, sy = 0, sz = 0;
    for (int i = 0; i <= du; ++i) {
      const Vec3 c = cp[j * (du + 1) + i];
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
  float worst = 0;
  for (int j = 0; j <= dv; ++j)
    for (int i = 0; i <= du; ++i) {
      const float s = float(i) / du, t = float(j) / dv;
      const Vec3 bl =
          p00 * ((1 - s) * (1 - t)) + p10 * (s * (1 - t)) + p01 * ((1 - s) * t) + p11 * (s * t);
      worst = std::max(worst, length(control(i, j) - bl));
    }
  return worst;
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
  if (pos < toks.size())
    return at(toks[pos].line, "unexpected '" + toks[pos].text + "' after the " +
                                  std::to_string(count) + " patches");
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

TriangleMesh tessellate(const PatchSet& set, int n, float* max_error) {
  TriangleMesh mesh;
  mesh.source =
      set.source + " (tessellated " + std::to_string(n) + "x" + std::to_string(n) + " per patch)";
  float err = 0;
  for (const BezierPatch& patch : set.patches) {
    const uint32_t base = static_cast<uint32_t>(mesh.vertices.size());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        mesh.vertices.push_back(to_f(patch.eval(double(i) / n, double(j) / n)));
    auto idx = [&](int i, int j) { return base + static_cast<uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        mesh.triangles.push_back({idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)});
        mesh.triangles.push_back({idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)});
        if (max_error) {
          // Deviation at the quad centre (from the diagonal midpoint) and at the edge midpoints.
          const Vec3 c = to_f(patch.eval((i + 0.5) / n, (j + 0.5) / n));
          const Vec3 d = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i + 1, j + 1)]) * 0.5f;
          const Vec3 e = to_f(patch.eval((i + 0.5) / n, double(j) / n));
          const Vec3 f = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i + 1, j)]) * 0.5f;
          const Vec3 g = to_f(patch.eval(double(i) / n, (j + 0.5) / n));
          const Vec3 h = (mesh.vertices[idx(i, j)] + mesh.vertices[idx(i, j + 1)]) * 0.5f;
          err = std::max({err, length(c - d), length(e - f), length(g - h)});
        }
      }
  }
  if (max_error) *max_error = err;
  return mesh;
}

}  // namespace hfrt::geom
