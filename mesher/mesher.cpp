#include "mesher/mesher.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "base/check.h"
#include "base/memory.h"
#include "base/parallel.h"
#include "base/timer.h"

namespace hfrt::mesher {
namespace {

/// Seconds since construction (or the last restart).
struct Timer {
  Clock::time_point t0 = Clock::now();
  double seconds() const { return ms_since(t0) / 1000.0; }
};

constexpr int kBlock = 4;  // cells per block side
static_assert(kBlock == 4, "a block's surface cells are a 64-bit mask");
constexpr int kKeyBits = 21;  // bits per axis of a cell key
constexpr uint64_t kKeyMask = (uint64_t(1) << kKeyBits) - 1;
constexpr int kMaxCells = (1 << kKeyBits) - 4;
constexpr size_t kPad = 16;               // batches are padded to this many points
constexpr float kRankCutoff = 0.02f;      // eigenvalues of A^T A below this * max are dropped
constexpr int kRootSteps = 3;             // Illinois steps per crossing edge at most
constexpr float kRootTolerance = 1e-5f;   // an edge is done at |F| below this * its change
constexpr int kNewtonSteps = 10;          // gradient evaluations per vertex at most
constexpr float kUncheckedStep = 0.005f;  // a flat patch's first step this short (in cells)
                                          // is not checked by a value

/// The set bits of v (SWAR: a dozen instructions, no call; the x86-64 baseline has no popcnt
/// instruction, and there std::popcount is a call into libgcc).
inline int bit_count64(uint64_t v) {
  v = v - ((v >> 1) & 0x5555555555555555ull);
  v = (v & 0x3333333333333333ull) + ((v >> 2) & 0x3333333333333333ull);
  v = (v + (v >> 4)) & 0x0f0f0f0f0f0f0f0full;
  return int((v * 0x0101010101010101ull) >> 56);
}

uint64_t cell_key(int i, int j, int k) {
  return uint64_t(i) | (uint64_t(j) << kKeyBits) | (uint64_t(k) << (2 * kKeyBits));
}
void key_cell(uint64_t key, int c[3]) {
  c[0] = int(key & kKeyMask);
  c[1] = int((key >> kKeyBits) & kKeyMask);
  c[2] = int((key >> (2 * kKeyBits)) & kKeyMask);
}

// ---------------------------------------------------------------------------------------------
// Cube tables. Corner c = cx | cy << 1 | cz << 2. Edge e = axis * 4 + (u | v << 1), where (u, v)
// are the corner's coordinates on the two other axes in increasing order (x: y,z; y: x,z;
// z: x,y); the edge runs from the corner with coordinate 0 on `axis` to the one with 1.

constexpr void other_axes(int a, int* b, int* c) {
  *b = a == 0 ? 1 : 0;
  *c = a == 2 ? 1 : 2;
}

int edge_corner(int e, int end) {
  int a = e / 4, u = e & 1, v = (e >> 1) & 1, b, c;
  other_axes(a, &b, &c);
  return (end << a) | (u << b) | (v << c);
}

/// The low end of edge e relative to its cell's low corner (edge_corner(e, 0) as offsets).
constexpr int kEdgeLow[12][3] = {{0, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 1},   // along x
                                 {0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0, 1},   // along y
                                 {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};  // along z

/// The face of a cell at coordinate `side` on `axis`: its corners in cyclic order and, edge q
/// of the cycle from corner q to corner q + 1, its local edges.
void face_cycle(int axis, int side, int corners[4], int edges[4]) {
  int b, c;
  other_axes(axis, &b, &c);
  const int s = side << axis;
  corners[0] = s, corners[1] = s | (1 << b), corners[2] = s | (1 << b) | (1 << c),
  corners[3] = s | (1 << c);
  for (int i = 0; i < 4; ++i) {
    const int p = corners[i], q = corners[(i + 1) & 3];
    const int diff = p ^ q, a = diff == 1 ? 0 : (diff == 2 ? 1 : 2);
    const int lo = p & q;  // the end with 0 on `a`
    int o1, o2;
    other_axes(a, &o1, &o2);
    edges[i] = a * 4 + (((lo >> o1) & 1) | (((lo >> o2) & 1) << 1));
  }
}

/// For every corner mask: which patch (0..3) each crossing edge belongs to, -1 for edges that
/// do not cross, and the number of patches. Faces with four crossings separate their inside
/// corners (each inside corner's two edges form one segment).
struct CubeTable {
  int8_t comp[256][12];
  int8_t ncomp[256];
  uint16_t cross[256];  // bit e: edge e crosses
  uint8_t owned[256];   // crossing edges the cell owns (at its low corner: e & 3 == 0)
  // The blocks the cells around the crossing edges lie in (bit (dx + 1) + 3 (dy + 1) +
  // 9 (dz + 1), dx etc. the block offsets), by the cell's place in its block: per axis 0 at
  // the low face, 2 at the high face, 1 between (index c0 + 3 c1 + 9 c2). The closure needs
  // them all sampled.
  uint32_t reach[27][256];
  // The +a faces (bit a) with four crossings whose two segments belong to one patch of the
  // cell, and per such face its local edges: one of the first segment (around the inside
  // corner first in the face's cycle), both of the second (see FaceCandidate).
  uint8_t split_face[256];
  int8_t split_edges[256][3][3];

  CubeTable() {
    for (int e = 0; e < 12; ++e) {
      const int c = edge_corner(e, 0);
      HFRT_CHECK(kEdgeLow[e][0] == (c & 1) && kEdgeLow[e][1] == ((c >> 1) & 1) &&
                 kEdgeLow[e][2] == (c >> 2));
    }
    for (int m = 0; m < 256; ++m) {
      auto in = [m](int corner) { return (m >> corner) & 1; };
      int parent[12];
      std::iota(parent, parent + 12, 0);
      auto find = [&parent](int x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
      };
      auto unite = [&](int x, int y) { parent[find(x)] = find(y); };
      bool cross_e[12];
      for (int e = 0; e < 12; ++e) cross_e[e] = in(edge_corner(e, 0)) != in(edge_corner(e, 1));
      for (int a = 0; a < 3; ++a) {
        for (int s = 0; s < 2; ++s) {
          int corners[4], edges[4];
          face_cycle(a, s, corners, edges);
          int crossing[4], n = 0;
          for (int i = 0; i < 4; ++i)
            if (cross_e[edges[i]]) crossing[n++] = edges[i];
          if (n == 2) {
            unite(crossing[0], crossing[1]);
          } else if (n == 4) {
            for (int i = 0; i < 4; ++i)
              if (in(corners[i])) unite(edges[(i + 3) & 3], edges[i]);
          }
        }
      }
      int8_t ids[12];
      std::fill(ids, ids + 12, int8_t(-1));
      int next = 0;
      for (int e = 0; e < 12; ++e) {
        comp[m][e] = -1;
        if (!cross_e[e]) continue;
        int r = find(e);
        if (ids[r] < 0) ids[r] = int8_t(next++);
        comp[m][e] = ids[r];
      }
      ncomp[m] = int8_t(next);
      cross[m] = 0;
      for (int e = 0; e < 12; ++e) cross[m] |= uint16_t(cross_e[e]) << e;
      owned[m] = uint8_t(cross_e[0] + cross_e[4] + cross_e[8]);
      split_face[m] = 0;
      for (int a = 0; a < 3; ++a) {
        int corners[4], fe[4];  // the +a face
        face_cycle(a, 1, corners, fe);
        int ins[4];
        for (int q = 0; q < 4; ++q) ins[q] = in(corners[q]);
        if (!(ins[0] == ins[2] && ins[1] == ins[3] && ins[0] != ins[1])) continue;
        const int k1 = ins[0] ? 0 : 1, k2 = k1 + 2;  // the inside corners
        const int s1 = fe[(k1 + 3) & 3], s2a = fe[(k2 + 3) & 3], s2b = fe[k2];
        if (comp[m][s1] != comp[m][s2a]) continue;
        split_face[m] |= uint8_t(1 << a);
        split_edges[m][a][0] = int8_t(s1);
        split_edges[m][a][1] = int8_t(s2a);
        split_edges[m][a][2] = int8_t(s2b);
      }
      for (int place = 0; place < 27; ++place) {
        reach[place][m] = 0;
        for (int e = 0; e < 12; ++e)
          if (cross_e[e]) reach[place][m] |= edge_reach[place][e];
      }
    }
  }

  // Per place in the block (as reach) and local edge e: the blocks the four cells around e
  // lie in. (Once per edge, not per mask: ~7M instructions less on every process's first
  // mesh.)
  static constexpr auto edge_reach = [] {
    std::array<std::array<uint32_t, 12>, 27> t{};
    for (int place = 0; place < 27; ++place)
      for (int e = 0; e < 12; ++e) {
        // Edge e's owner is this cell + u e_b + v e_c; the cells around it are the owner
        // minus 0, e_b, e_c and both. A step of -1 from the low face (or +1 from the high
        // one) leaves the block.
        int b = 0, c = 0;
        other_axes(e / 4, &b, &c);
        for (int s = 0; s < 2; ++s)
          for (int u = 0; u < 2; ++u) {
            int d[3] = {0, 0, 0};
            d[b] = (e & 1) - s;
            d[c] = ((e >> 1) & 1) - u;
            int bit = 0;
            for (int a = 0, w = 1, pl = place; a < 3; ++a, w *= 3, pl /= 3) {
              const int o = (pl % 3 == 0 && d[a] < 0) ? -1 : (pl % 3 == 2 && d[a] > 0 ? 1 : 0);
              bit += w * (o + 1);
            }
            t[size_t(place)][size_t(e)] |= uint32_t(1) << bit;
          }
      }
    return t;
  }();
};

const CubeTable& cube_table() {
  static const CubeTable table;
  return table;
}

// ---------------------------------------------------------------------------------------------
// The grid and the capped field.

struct Grid {
  int n[3];      // cells per axis inside the box; the padded grid has n + 2 cells
  double lo[3];  // the box's low corner
  double h[3];   // cell size per axis
  Box box;
  std::vector<float> coord[3];  // node i's coordinate per axis (set by init_coords)

  void init_coords() {
    for (int a = 0; a < 3; ++a) {
      coord[a].resize(size_t(cells(a)) + 1);
      for (int i = 0; i <= cells(a); ++i) coord[a][i] = float(lo[a] + double(i - 1) * h[a]);
    }
  }
  float node(int axis, int i) const { return coord[axis][size_t(i)]; }
  Vec3 node_point(int i, int j, int k) const { return {node(0, i), node(1, j), node(2, k)}; }
  int cells(int axis) const { return n[axis] + 2; }
};

#if defined(__SSE2__)
/// Rows x, y, z of the four Vec3s at v (12 floats: x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3).
inline void load_rows(const Vec3* v, __m128* x, __m128* y, __m128* z) {
  static_assert(sizeof(Vec3) == 3 * sizeof(float));
  const float* f = &v->x;
  const __m128 a = _mm_loadu_ps(f), b = _mm_loadu_ps(f + 4), c = _mm_loadu_ps(f + 8);
  const __m128 x01 = _mm_shuffle_ps(a, a, _MM_SHUFFLE(3, 3, 3, 0));  // x0 x1 x1 x1
  const __m128 x23 = _mm_shuffle_ps(b, c, _MM_SHUFFLE(1, 1, 2, 2));  // x2 x2 x3 x3
  *x = _mm_shuffle_ps(x01, x23, _MM_SHUFFLE(2, 0, 1, 0));            // x0 x1 x2 x3
  const __m128 y01 = _mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 0, 1, 1));  // y0 y0 y1 y1
  const __m128 y23 = _mm_shuffle_ps(b, c, _MM_SHUFFLE(2, 2, 3, 3));  // y2 y2 y3 y3
  *y = _mm_shuffle_ps(y01, y23, _MM_SHUFFLE(2, 0, 2, 0));            // y0 y1 y2 y3
  const __m128 z01 = _mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2));  // z0 z0 z1 z1
  const __m128 z23 = _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 0, 0));  // z2 z2 z3 z3
  *z = _mm_shuffle_ps(z01, z23, _MM_SHUFFLE(2, 0, 2, 0));            // z0 z1 z2 z3
}

/// |x|, x finite (|x| < inf: false for NaN), and m ? a : b, lane by lane.
inline __m128 abs4(__m128 x) {
  return _mm_and_ps(x, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff)));
}
inline __m128 finite4(__m128 x) {
  return _mm_cmplt_ps(abs4(x), _mm_set1_ps(std::numeric_limits<float>::infinity()));
}
inline __m128 select4(__m128 m, __m128 a, __m128 b) {
  return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b));
}

/// Rows x, y, z into the four Vec3s at v by a 4x4 transpose. The fourth store spills into
/// v[4].x: v[4] must exist, and be written after (the callers' loops stop at i + 4 < n).
inline void store_rows(Vec3* v, __m128 x, __m128 y, __m128 z) {
  __m128 w = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(x, y, z, w);
  float* const out = &v->x;
  _mm_storeu_ps(out, x);
  _mm_storeu_ps(out + 3, y);
  _mm_storeu_ps(out + 6, z);
  _mm_storeu_ps(out + 9, w);
}
#endif

/// Fc = min(F, d) with d the distance inside the box's faces; NaN F is -inf (outside). Batches
/// are padded to a multiple of kPad with copies of the last point, so that a point's value
/// does not depend on where it sits in a batch (no scalar tail loop in the evaluator).
class Capped {
 public:
  Capped(const render::Field& field, const Box& box) : field_(field), box_(box) {}

  float box_distance(float x, float y, float z) const {
    return std::min(
        std::min(std::min(x - box_.lo.x, box_.hi.x - x), std::min(y - box_.lo.y, box_.hi.y - y)),
        std::min(z - box_.lo.z, box_.hi.z - z));
  }

  /// The entries an array of n points (or of their values) passed to eval or eval_gradient
  /// must have room for: n rounded up to a multiple of kPad.
  static size_t padded_size(size_t n) { return (n + kPad - 1) / kPad * kPad; }

  /// Fc at n points; counts NaN values of F in *nan_count when given. x, y, z and out have
  /// room for padded_size(n) entries: the points past n are set to copies of the last one
  /// (padding in place: no copy of the batch).
  void eval(size_t n, float* x, float* y, float* z, float* out, size_t* nan_count = nullptr) const {
    if (n == 0) return;
    const size_t m = pad(n, x, y, z);
    field_.eval(m, x, y, z, out);
    // (Restrict: the rows do not overlap, so that this loop runs as vectors without a check.)
    float* __restrict o = out;
    const float* __restrict px = x, * __restrict py = y, * __restrict pz = z;
    uint32_t nans = 0;
    for (size_t i = 0; i < n; ++i) {
      const float f = o[i];
      nans += f != f;
      o[i] = std::min(f != f ? -std::numeric_limits<float>::infinity() : f,
                      box_distance(px[i], py[i], pz[i]));
    }
    if (nan_count) *nan_count += nans;
  }

  /// Fc and its gradient (pointing into the solid) at n points: the box face's where the cap
  /// is the smaller; where F has no value, -inf and a NaN gradient (no direction). x, y, z
  /// have room for padded_size(n) entries (padded in place, as eval); f and g for n.
  void eval_gradient(size_t n, float* x, float* y, float* z, float* f, Vec3* g) const {
    if (n == 0) return;
    const size_t m = pad(n, x, y, z);
    // F and the gradient's components as consecutive rows of m (the model's layout: no
    // copy), per thread (a thread_local costs a call per use: one per batch here).
    thread_local std::vector<float, DefaultInitAllocator<float>> buf;
    buf.resize(4 * m);
    float *pf = buf.data(), *gx = pf + m, *gy = gx + m, *gz = gy + m;
    field_.eval_gradient(m, x, y, z, pf, gx, gy, gz);
    auto one = [&](size_t i) {
      const float fv = pf[i];
      f[i] = fv;
      if (fv == fv && fv <= box_distance(x[i], y[i], z[i])) {
        g[i] = {gx[i], gy[i], gz[i]};  // the usual case: F, not the cap
        return;
      }
      Vec3 p{x[i], y[i], z[i]};
      const float d[6] = {p.x - box_.lo.x, box_.hi.x - p.x, p.y - box_.lo.y,
                          box_.hi.y - p.y, p.z - box_.lo.z, box_.hi.z - p.z};
      const int k = int(std::min_element(d, d + 6) - d);
      if (fv != fv) {
        // No value: outside, and no direction.
        f[i] = -std::numeric_limits<float>::infinity();
        g[i] = {std::numeric_limits<float>::quiet_NaN(), 0, 0};
      } else if (d[k] < fv) {
        f[i] = d[k];
        Vec3 gb{0, 0, 0};
        gb[k / 2] = (k & 1) ? -1.0f : 1.0f;
        g[i] = gb;
      } else {
        g[i] = {gx[i], gy[i], gz[i]};
      }
    };
    size_t i = 0;
#if defined(__SSE2__)
    // Four points at a time where F is not NaN and not above the cap at all four (the usual
    // case; the test is box_distance's minimum in the same order, and cmple is false for a
    // NaN): their gradients from the rows to the Vec3s by store_rows (the loop stops at
    // i + 4 < n). (~1.5 % of the mesher's instructions, scalar.)
    const __m128 lox = _mm_set1_ps(box_.lo.x), loy = _mm_set1_ps(box_.lo.y),
                 loz = _mm_set1_ps(box_.lo.z), hix = _mm_set1_ps(box_.hi.x),
                 hiy = _mm_set1_ps(box_.hi.y), hiz = _mm_set1_ps(box_.hi.z);
    for (; i + 4 < n; i += 4) {
      const __m128 fv = _mm_loadu_ps(pf + i);
      const __m128 px = _mm_loadu_ps(x + i), py = _mm_loadu_ps(y + i), pz = _mm_loadu_ps(z + i);
      const __m128 d = _mm_min_ps(_mm_min_ps(_mm_min_ps(_mm_sub_ps(px, lox), _mm_sub_ps(hix, px)),
                                             _mm_min_ps(_mm_sub_ps(py, loy), _mm_sub_ps(hiy, py))),
                                  _mm_min_ps(_mm_sub_ps(pz, loz), _mm_sub_ps(hiz, pz)));
      if (_mm_movemask_ps(_mm_cmple_ps(fv, d)) != 15) {
        for (size_t j = i; j < i + 4; ++j) one(j);
        continue;
      }
      _mm_storeu_ps(f + i, fv);
      store_rows(g + i, _mm_loadu_ps(gx + i), _mm_loadu_ps(gy + i), _mm_loadu_ps(gz + i));
    }
#endif
    for (; i < n; ++i) one(i);
  }

  /// An interval enclosing Fc over each box (NaN ends: unknown), as Field::eval_intervals.
  void eval_intervals(size_t n, const Box* boxes, render::Interval* out) const {
    thread_local std::vector<uint8_t> nan_flags;
    nan_flags.assign(n, 0);
    if (field_.has_interval()) {
      static_assert(sizeof(bool) == 1);
      field_.eval_intervals(n, boxes, out, reinterpret_cast<bool*>(nan_flags.data()));
    } else {
      for (size_t i = 0; i < n; ++i) {
        out[i] = {-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
      }
    }
    for (size_t i = 0; i < n; ++i) {
      const Box& b = boxes[i];
      // d over the box: the minimum of six affine functions, each exact over the box.
      float dlo = std::min({b.lo.x - box_.lo.x, box_.hi.x - b.hi.x, b.lo.y - box_.lo.y,
                            box_.hi.y - b.hi.y, b.lo.z - box_.lo.z, box_.hi.z - b.hi.z});
      float dhi = std::min({b.hi.x - box_.lo.x, box_.hi.x - b.lo.x, b.hi.y - box_.lo.y,
                            box_.hi.y - b.lo.y, b.hi.z - box_.lo.z, box_.hi.z - b.lo.z});
      float lo = out[i].lo, hi = out[i].hi;
      // A box that may hold NaN points (outside) can only be proven empty, not full.
      if (nan_flags[i]) lo = -std::numeric_limits<float>::infinity();
      if (lo != lo || hi != hi) {
        lo = -std::numeric_limits<float>::infinity();
        hi = std::numeric_limits<float>::infinity();
      }
      out[i] = {std::min(lo, dlo), std::min(hi, dhi)};
    }
  }

 private:
  /// Sets points [n, padded_size(n)) to copies of the last point; returns padded_size(n).
  static size_t pad(size_t n, float* x, float* y, float* z) {
    const size_t m = padded_size(n);
    for (size_t i = n; i < m; ++i) x[i] = x[n - 1], y[i] = y[n - 1], z[i] = z[n - 1];
    return m;
  }

  const render::Field& field_;
  Box box_;
};

bool inside(float f) {
  return f >= 0;
}

// ---------------------------------------------------------------------------------------------
// Small linear algebra: eigen decomposition of a symmetric 3x3 matrix (Jacobi rotations).

void eigen_sym3(double a[3][3], double w[3], double v[3][3]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v[i][j] = i == j ? 1 : 0;
  const double scale = std::abs(a[0][0]) + std::abs(a[1][1]) + std::abs(a[2][2]);
  for (int sweep = 0; sweep < 16; ++sweep) {
    double off = std::abs(a[0][1]) + std::abs(a[0][2]) + std::abs(a[1][2]);
    if (!(off > 1e-12 * scale)) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        if (!(std::abs(a[p][q]) > 1e-14 * scale)) continue;
        double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        double t = (theta >= 0 ? 1 : -1) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {
          double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {
          double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {
          double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }
  for (int i = 0; i < 3; ++i) w[i] = a[i][i];
}

/// The point minimising sum (n_i . (p - p_i))^2 nearest the mass point `mass` of the k
/// points p_i, by the truncated pseudo-inverse; `rank` receives the number of eigenvalues
/// kept. (Out of line: solve_qef's fast path, inlined where the vertices are placed, is most
/// cells' whole QEF.)
[[gnu::noinline]] Vec3 solve_qef_general(const Vec3* p, const Vec3* nrm, int k,
                                         const double mass[3], int* rank) {
  double ata[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, atb[3] = {0, 0, 0};
  for (int i = 0; i < k; ++i) {
    double n[3] = {nrm[i].x, nrm[i].y, nrm[i].z};
    double len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (!(len2 > 0.5)) continue;  // no normal there
    double d = 0;
    for (int a = 0; a < 3; ++a) d += n[a] * (p[i][a] - mass[a]);
    for (int r = 0; r < 3; ++r) {
      atb[r] += n[r] * d;
      for (int c = 0; c < 3; ++c) ata[r][c] += n[r] * n[c];
    }
  }
  double w[3], v[3][3];
  eigen_sym3(ata, w, v);
  double wmax = std::max({w[0], w[1], w[2]});
  double x[3] = {0, 0, 0};
  *rank = 0;
  for (int e = 0; e < 3; ++e) {
    if (!(wmax > 0) || w[e] < kRankCutoff * wmax) continue;
    ++*rank;
    double dotb = v[0][e] * atb[0] + v[1][e] * atb[1] + v[2][e] * atb[2];
    for (int a = 0; a < 3; ++a) x[a] += v[a][e] * dotb / w[e];
  }
  return {float(mass[0] + x[0]), float(mass[1] + x[1]), float(mass[2] + x[2])};
}

template <typename F>
void parallel_chunks(size_t n, size_t grain, F&& body) {
  par::parallel_for(n, grain, body);
}

/// The position of a block of kBlock^3 cells (in blocks).
struct BlockPos {
  int b[3];
};

constexpr uint32_t kNone = ~uint32_t(0);

/// Offset d of a block's 27 neighbourhood (bit d of RunOut::reach), kOffset[d]: (d % 3,
/// d / 3 % 3, d / 9) - 1 on the three axes; kSelf is the block itself.
constexpr int kSelf = 13;
constexpr auto kOffset = [] {
  std::array<std::array<int8_t, 3>, 27> t{};
  for (int d = 0; d < 27; ++d)
    t[size_t(d)] = {int8_t(d % 3 - 1), int8_t(d / 3 % 3 - 1), int8_t(d / 9 - 1)};
  return t;
}();

/// The sampled blocks by position: find(x, y, z) is the index in the list of blocks of the
/// block at (x, y, z), kNone where none was sampled (or outside the grid of blocks). A
/// two-level grid: a dense grid of tiles of 8^3 blocks, each tile an array allocated where a
/// block lies in it, so that a lookup is two loads and the memory follows the surface (2 KiB a
/// tile; the top grid is 4 bytes per 512 blocks of the box). It replaced a table of all 27
/// neighbours of every block built by merge joins of sorted keys, which was ~4 % of the
/// mesher's instructions (callgrind, 256^3 blend) and 1.6 ms of the 512^3 blend's 2 threads;
/// the few lookups the closure and the faces make cost less than building it.
class BlockIndex {
 public:
  explicit BlockIndex(const int nb[3]) {
    for (int a = 0; a < 3; ++a) {
      nb_[a] = nb[a];
      nt_[a] = (nb[a] + kTile - 1) >> kTileBits;
    }
    top_.assign(size_t(nt_[0]) * size_t(nt_[1]) * size_t(nt_[2]), 0);
  }
  /// Files block `index` at p (inside the grid of blocks). Serial.
  void add(const BlockPos& p, uint32_t index) {
    uint32_t& t = top_[top_at(p.b[0], p.b[1], p.b[2])];
    if (t == 0) {
      tiles_.resize(tiles_.size() + kTileSize, kNone);
      t = uint32_t(tiles_.size() / kTileSize);  // tile number + 1
    }
    tiles_[size_t(t - 1) * kTileSize + in_tile(p.b[0], p.b[1], p.b[2])] = index;
  }
  uint32_t find(int x, int y, int z) const {
    if (unsigned(x) >= unsigned(nb_[0]) || unsigned(y) >= unsigned(nb_[1]) ||
        unsigned(z) >= unsigned(nb_[2]))
      return kNone;
    const uint32_t t = top_[top_at(x, y, z)];
    return t == 0 ? kNone : tiles_[size_t(t - 1) * kTileSize + in_tile(x, y, z)];
  }

 private:
  static constexpr int kTileBits = 3, kTile = 1 << kTileBits, kTileMask = kTile - 1;
  static constexpr size_t kTileSize = size_t(kTile) * kTile * kTile;
  size_t top_at(int x, int y, int z) const {
    return size_t(x >> kTileBits) +
           size_t(nt_[0]) * (size_t(y >> kTileBits) + size_t(nt_[1]) * size_t(z >> kTileBits));
  }
  static size_t in_tile(int x, int y, int z) {
    return size_t(x & kTileMask) | (size_t(y & kTileMask) << kTileBits) |
           (size_t(z & kTileMask) << (2 * kTileBits));
  }
  int nb_[3], nt_[3];
  std::vector<uint32_t> top_;    // per tile: its number in tiles_ + 1, 0 where none
  std::vector<uint32_t> tiles_;  // kTileSize entries per tile
};

/// A scratch array: resize() leaves new entries unset (each is written before it is read).
template <typename T>
using ScratchVector = std::vector<T, DefaultInitAllocator<T>>;

/// Crossing edges waiting for their zeros: the low and high end and Fc there.
/// Its arrays only grow (they are scratch reused run after run): set_size marks how many
/// entries are in use, without writing any.
struct EdgeBatch {
  std::vector<Vec3> pa, pb;
  ScratchVector<float> fa, fb;
  void clear() { n = 0; }
  size_t size() const { return n; }
  /// Room for entries [0, m).
  void grow(size_t m) {
    if (m <= pa.size()) return;
    m = std::max(m, 2 * pa.size());
    pa.resize(m), pb.resize(m), fa.resize(m), fb.resize(m);
  }
  void set_size(size_t m) { n = m; }
  void set(size_t i, Vec3 a, Vec3 b, float va, float vb) {
    pa[i] = a, pb[i] = b, fa[i] = va, fb[i] = vb;
  }

 private:
  size_t n = 0;
};

/// The zeros of a batch's edges and the unit gradient and slope (|grad Fc|) there.
struct EdgeZeros {
  std::vector<Vec3> point, normal;
  ScratchVector<float> slope;
};

/// The QEF point of the k edges `edge` of `zeros` (their zeros p_i and tangent planes): the
/// point minimising sum (n_i . (x - p_i))^2 nearest the mass point, by the truncated
/// pseudo-inverse; `rank` receives the number of eigenvalues kept. When the normals are all
/// valid and within ~6 degrees of their mean (the mass point is the answer: the fast path,
/// most cells), `*flat_normal` is set to their normalised mean and `*mean_slope` to the
/// edges' mean slope; otherwise both are left alone. (The fast path reads the edges where
/// they are; only the general one copies them out.)
inline Vec3 solve_qef(const Vec3* point, const Vec3* normal, const float* slopes,
                      const uint32_t* edge, int k, int* rank, Vec3* flat_normal,
                      float* mean_slope) {
  double mass[3] = {0, 0, 0};
  Vec3 mean{0, 0, 0};
  int valid = 0;
  float slope = 0;
  for (int i = 0; i < k; ++i) {
    const Vec3 p = point[edge[i]], n = normal[edge[i]];
    for (int a = 0; a < 3; ++a) mass[a] += p[a];
    if (length2(n) > 0.5f) mean += n, ++valid;
    slope += slopes[edge[i]];
  }
  const double inv_k = 1.0 / k;  // one division, not three
  for (int a = 0; a < 3; ++a) mass[a] *= inv_k;
  // Fast path: normals within ~6 degrees of their mean span one direction (rank 1), and the
  // least-squares point nearest the mass point is the mass point itself.
  const Vec3 u = normalize(mean);
  bool flat = valid == k && length2(mean) > 0;
  for (int i = 0; i < k; ++i) flat &= dot(normal[edge[i]], u) > 0.995f;  // no branch
  if (flat) {
    *rank = 1;
    *flat_normal = u;
    *mean_slope = slope / float(k);
    return {float(mass[0]), float(mass[1]), float(mass[2])};
  }
  Vec3 pts[12], nrm[12];
  for (int i = 0; i < k; ++i) pts[i] = point[edge[i]], nrm[i] = normal[edge[i]];
  return solve_qef_general(pts, nrm, k, mass, rank);
}

/// Scratch of solve_edges, one per thread. (Passed in: a function-local thread_local in this
/// shared library costs a __tls_get_addr call per use, ~7 % of the mesher's time.)
struct EdgeScratch {
  ScratchVector<float> tlo, thi, flo, fhi, vlo, vhi, tol, xyz, fs, tm;
  ScratchVector<uint8_t> side;
  std::vector<uint32_t> active, next_active;
  std::vector<Vec3> g;
};

/// The zero of every edge of `in` and the gradient there: a false-position step from the
/// sampled ends, evaluated with its gradient (exact where F is affine along the edge: planes
/// of CSG); an edge not then within kRootTolerance of its change of F (~1e-5 of the edge
/// from the zero) takes one Newton step along the edge with that gradient, or, at a kink of
/// min/max, Illinois false-position steps (bisection where a value is not finite) and a new
/// gradient.
void solve_edges(const Capped& capped, const EdgeBatch& in, EdgeZeros* out, EdgeScratch* scratch) {
  const size_t n = in.size();
  out->point.resize(n);
  out->normal.resize(n);
  out->slope.resize(n);
  if (n == 0) return;
  auto& [tlo_v, thi_v, flo_v, fhi_v, vlo_v, vhi_v, tol_v, xyz, fs_v, tm_v, side_v, active,
         next_active, g] = *scratch;
  for (auto* v : {&tlo_v, &thi_v, &flo_v, &fhi_v, &vlo_v, &vhi_v, &tol_v, &tm_v}) v->resize(n);
  xyz.resize(3 * Capped::padded_size(n));
  fs_v.resize(Capped::padded_size(n));
  side_v.resize(n);
  // The arrays as plain pointers: the loops below push onto vectors (an out-of-line call the
  // compiler must assume changes any vector) and store bytes (which may alias anything), so
  // reached through the vectors every access reloaded their pointers: 0.7 % of the mesher's
  // instructions (callgrind, 256^3 blend; 0.3 % in project_vertices, 1.5 % in run()).
  float *const tlo = tlo_v.data(), *const thi = thi_v.data(), *const flo = flo_v.data(),
               *const fhi = fhi_v.data(), *const vlo = vlo_v.data(), *const vhi = vhi_v.data(),
               *const tol = tol_v.data(), *const tm = tm_v.data(), *const fs = fs_v.data();
  uint8_t* const side = side_v.data();
  const Vec3 *const pa = in.pa.data(), *const pb = in.pb.data();
  const float *const fa_in = in.fa.data(), *const fb_in = in.fb.data();
  Vec3 *const zpoint = out->point.data(), *const znormal = out->normal.data();
  float* const zslope = out->slope.data();
  // A batch of k points goes to xs, ys, zs: consecutive rows of padded_size(k) in xyz (the
  // model's layout: evaluated without a copy).
  float *xs, *ys, *zs;
  auto rows_for = [&](size_t k) {
    const size_t m = Capped::padded_size(k);
    xs = xyz.data(), ys = xs + m, zs = ys + m;
  };
  // An edge's bracket [tlo, thi] and its state for the Illinois steps, kept only for the few
  // edges that take them (set from the first step's result below): flo, fhi the values
  // Illinois works with (halved when an end is kept twice); vlo, vhi the true values at the
  // bracket's ends; side the end last replaced (2: none).
  auto tolerance = [&](size_t i) {
    const float d = std::abs(fa_in[i] - fb_in[i]);
    return std::isfinite(d) ? kRootTolerance * d : 0.0f;
  };
  // The false-position point of edge i's bracket (its middle where a value is not finite).
  auto propose = [&](size_t i) {
    const float d = flo[i] - fhi[i];
    float t = 0.5f * (tlo[i] + thi[i]);
    if (std::isfinite(flo[i]) && std::isfinite(fhi[i]) && d != 0) {
      t = tlo[i] + (thi[i] - tlo[i]) * (flo[i] / d);
      const float lo = std::min(tlo[i], thi[i]), hi = std::max(tlo[i], thi[i]);
      if (!(t > lo && t < hi)) t = 0.5f * (tlo[i] + thi[i]);
    }
    return t;
  };
  // Edge i's bracket after the value f at tm[i] (Illinois: an end kept twice has its value
  // halved); true when f is within tolerance.
  auto update = [&](size_t i, float f) {
    if (inside(f) == inside(fa_in[i])) {
      tlo[i] = tm[i], flo[i] = vlo[i] = f;
      if (side[i] == 0) fhi[i] *= 0.5f;
      side[i] = 0;
    } else {
      thi[i] = tm[i], fhi[i] = vhi[i] = f;
      if (side[i] == 1) flo[i] *= 0.5f;
      side[i] = 1;
    }
    return std::abs(f) <= tol[i];
  };
  // One false-position step for the edges in `active`; those not within tolerance after it
  // are left in `active`.
  auto round = [&]() {
    const size_t na = active.size();
    rows_for(na);
    for (size_t j = 0; j < na; ++j) {
      const size_t i = active[j];
      tm[i] = propose(i);
      const Vec3 p = pa[i] + (pb[i] - pa[i]) * tm[i];
      xs[j] = p.x, ys[j] = p.y, zs[j] = p.z;
    }
    capped.eval(na, xs, ys, zs, fs);
    next_active.clear();
    for (size_t j = 0; j < na; ++j) {
      if (!update(active[j], fs[j])) next_active.push_back(active[j]);
    }
    active.swap(next_active);
  };
  // Edge i's unit normal and slope from the gradient gr at its point (none where gr has no
  // length).
  auto set_normal = [&](size_t i, Vec3 gr) {
    const float l = length(gr);
    const bool valid = l > 0 && std::isfinite(l);
    znormal[i] = valid ? gr / l : Vec3{0, 0, 0};
    zslope[i] = valid ? l : 0.0f;
  };
  // The bracket's end with the smaller |F|, and the gradient there, for the edges `which`.
  auto finish = [&](const std::vector<uint32_t>& which) {
    const size_t m = which.size();
    rows_for(m);
    for (size_t j = 0; j < m; ++j) {
      const size_t i = which[j];
      const float t = std::abs(vlo[i]) <= std::abs(vhi[i]) ? tlo[i] : thi[i];
      const Vec3 p = pa[i] + (pb[i] - pa[i]) * t;
      zpoint[i] = p;
      xs[j] = p.x, ys[j] = p.y, zs[j] = p.z;
    }
    g.resize(m);
    capped.eval_gradient(m, xs, ys, zs, fs, g.data());
    for (size_t j = 0; j < m; ++j) set_normal(which[j], g[j]);
  };
  // The first step: the false-position point from the sampled ends (propose() on the
  // bracket [0, 1]), its value and gradient from one evaluation (enough on a plane, where F
  // is affine along the edge).
  rows_for(n);
  size_t i0 = 0;
#if defined(__SSE2__)
  // Four edges at a time, the same operations lane by lane (the same bits): the ends' Vec3s
  // turned into rows (load_rows), the points back into Vec3s (store_rows; the loop stops at
  // i + 4 < n). (~2 % of the mesher's instructions, scalar.)
  {
    const __m128 half = _mm_set1_ps(0.5f), zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    for (; i0 + 4 < n; i0 += 4) {
      const size_t i = i0;
      const __m128 fa = _mm_loadu_ps(fa_in + i), fb = _mm_loadu_ps(fb_in + i);
      const __m128 d = _mm_sub_ps(fa, fb);
      const __m128 finite = _mm_and_ps(finite4(fa), finite4(fb));
      const __m128 q = _mm_div_ps(fa, d);
      const __m128 ok = _mm_and_ps(_mm_and_ps(finite, _mm_cmpneq_ps(d, zero)),
                                   _mm_and_ps(_mm_cmpgt_ps(q, zero), _mm_cmplt_ps(q, one)));
      const __m128 t = select4(ok, q, half);
      _mm_storeu_ps(tm + i, t);
      __m128 ax, ay, az, bx, by, bz;
      load_rows(pa + i, &ax, &ay, &az);
      load_rows(pb + i, &bx, &by, &bz);
      const __m128 px = _mm_add_ps(ax, _mm_mul_ps(_mm_sub_ps(bx, ax), t));
      const __m128 py = _mm_add_ps(ay, _mm_mul_ps(_mm_sub_ps(by, ay), t));
      const __m128 pz = _mm_add_ps(az, _mm_mul_ps(_mm_sub_ps(bz, az), t));
      _mm_storeu_ps(xs + i, px);
      _mm_storeu_ps(ys + i, py);
      _mm_storeu_ps(zs + i, pz);
      store_rows(zpoint + i, px, py, pz);
    }
  }
#endif
  for (size_t i = i0; i < n; ++i) {
    const float fa = fa_in[i], fb = fb_in[i], d = fa - fb;
    float t = 0.5f;
    if (std::isfinite(fa) && std::isfinite(fb) && d != 0) {
      t = fa / d;
      if (!(t > 0 && t < 1)) t = 0.5f;
    }
    tm[i] = t;
    const Vec3 p = pa[i] + (pb[i] - pa[i]) * t;
    zpoint[i] = p;
    xs[i] = p.x, ys[i] = p.y, zs[i] = p.z;
  }
  g.resize(n);
  capped.eval_gradient(n, xs, ys, zs, fs, g.data());
  const Vec3* const gn = g.data();
  // The edges not done: one Newton step along the edge with that gradient, where the
  // gradient's slope along the edge agrees with the bracket's secant (F smooth along it).
  // From within ~1 % of the edge of the zero (one false-position step) it lands within
  // ~1e-4 of it, as two more false-position steps would, for no evaluation; the normal stays
  // the one at the first point, a hundredth of a cell away. Where the slopes disagree (a
  // kink of min/max in the bracket) or the step leaves the bracket, the edge takes the
  // further false-position steps and a new gradient at the end.
  std::vector<uint32_t>& retry = next_active;
  retry.clear();
  // Edge i after its normal: within tolerance, a Newton step, or further steps (retry).
  auto after_first = [&](size_t i) {
    const float f = fs[i], fa = fa_in[i], fb = fb_in[i], t0 = tm[i], tl = tolerance(i);
    if (std::abs(f) <= tl) return;
    // The bracket after the first step (as update() leaves it).
    const bool low = inside(f) == inside(fa);
    const float lo_t = low ? t0 : 0.0f, hi_t = low ? 1.0f : t0;
    const float lo_v = low ? f : fa, hi_v = low ? fb : f;
    const Vec3 e = pb[i] - pa[i];
    const float slope_t = dot(gn[i], e);
    const float secant = (hi_v - lo_v) / (hi_t - lo_t);
    const float t = t0 - f / slope_t;
    const float lo = std::min(lo_t, hi_t), hi = std::max(lo_t, hi_t);
    if (std::isfinite(t) && t > lo && t < hi &&
        std::abs(slope_t - secant) <= 0.25f * std::abs(secant)) {
      zpoint[i] = pa[i] + e * t;
      return;
    }
    tlo[i] = lo_t, thi[i] = hi_t, flo[i] = vlo[i] = lo_v, fhi[i] = vhi[i] = hi_v;
    tol[i] = tl, side[i] = low ? 0 : 1;
    retry.push_back(uint32_t(i));
  };
  size_t i1 = 0;
#if defined(__SSE2__)
  // Four edges at a time where all four are within tolerance or take their Newton step (the
  // usual case), lane by lane the operations of set_normal and after_first (the same bits);
  // any other group edge by edge. (~3 % of the mesher's instructions, scalar.)
  {
    const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    const __m128 tolerance_k = _mm_set1_ps(kRootTolerance), quarter = _mm_set1_ps(0.25f);
    for (; i1 + 4 < n; i1 += 4) {
      const size_t i = i1;
      __m128 gx, gy, gz;
      load_rows(gn + i, &gx, &gy, &gz);
      // set_normal: l = |g|, valid = l > 0 and finite.
      const __m128 l = _mm_sqrt_ps(
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(gx, gx), _mm_mul_ps(gy, gy)), _mm_mul_ps(gz, gz)));
      const __m128 valid = _mm_and_ps(_mm_cmpgt_ps(l, zero), _mm_cmplt_ps(l, inf));
      store_rows(znormal + i, _mm_and_ps(valid, _mm_div_ps(gx, l)),
                 _mm_and_ps(valid, _mm_div_ps(gy, l)), _mm_and_ps(valid, _mm_div_ps(gz, l)));
      _mm_storeu_ps(zslope + i, _mm_and_ps(valid, l));
      // after_first.
      const __m128 f = _mm_loadu_ps(fs + i), fa = _mm_loadu_ps(fa_in + i),
                   fb = _mm_loadu_ps(fb_in + i), t0 = _mm_loadu_ps(tm + i);
      const __m128 ad = abs4(_mm_sub_ps(fa, fb));
      const __m128 tl = _mm_and_ps(_mm_cmplt_ps(ad, inf), _mm_mul_ps(tolerance_k, ad));
      const __m128 done = _mm_cmple_ps(abs4(f), tl);
      // low: inside(f) == inside(fa).
      const __m128 low = _mm_xor_ps(_mm_xor_ps(_mm_cmpge_ps(f, zero), _mm_cmpge_ps(fa, zero)),
                                    _mm_castsi128_ps(_mm_set1_epi32(-1)));
      const __m128 lo_t = select4(low, t0, zero), hi_t = select4(low, one, t0);
      const __m128 lo_v = select4(low, f, fa), hi_v = select4(low, fb, f);
      __m128 ax, ay, az, bx, by, bz;
      load_rows(pa + i, &ax, &ay, &az);
      load_rows(pb + i, &bx, &by, &bz);
      const __m128 ex = _mm_sub_ps(bx, ax), ey = _mm_sub_ps(by, ay), ez = _mm_sub_ps(bz, az);
      const __m128 slope_t =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(gx, ex), _mm_mul_ps(gy, ey)), _mm_mul_ps(gz, ez));
      const __m128 secant = _mm_div_ps(_mm_sub_ps(hi_v, lo_v), _mm_sub_ps(hi_t, lo_t));
      const __m128 t = _mm_sub_ps(t0, _mm_div_ps(f, slope_t));
      // (_mm_min_ps and std::min differ only where the operands are equal or NaN, which
      // lo_t and hi_t never are: one of them is t0 in (0, 1), the other 0 or 1.)
      const __m128 lo = _mm_min_ps(lo_t, hi_t), hi = _mm_max_ps(lo_t, hi_t);
      const __m128 step = _mm_and_ps(
          _mm_and_ps(finite4(t), _mm_cmpgt_ps(t, lo)),
          _mm_and_ps(_mm_cmplt_ps(t, hi), _mm_cmple_ps(abs4(_mm_sub_ps(slope_t, secant)),
                                                       _mm_mul_ps(quarter, abs4(secant)))));
      if (_mm_movemask_ps(_mm_or_ps(done, step)) != 15) {
        for (size_t j = i; j < i + 4; ++j) after_first(j);
        continue;
      }
      const int moved = _mm_movemask_ps(_mm_andnot_ps(done, step));
      if (moved == 0) continue;
      alignas(16) float px[4], py[4], pz[4];
      _mm_store_ps(px, _mm_add_ps(ax, _mm_mul_ps(ex, t)));
      _mm_store_ps(py, _mm_add_ps(ay, _mm_mul_ps(ey, t)));
      _mm_store_ps(pz, _mm_add_ps(az, _mm_mul_ps(ez, t)));
      for (int j = 0; j < 4; ++j)
        if ((moved >> j) & 1) zpoint[i + size_t(j)] = {px[j], py[j], pz[j]};
    }
  }
#endif
  for (size_t i = i1; i < n; ++i) {
    set_normal(i, gn[i]);
    after_first(i);
  }
  if (!retry.empty()) {
    active.swap(retry);
    std::vector<uint32_t> again = active;
    for (int it = 1; it < kRootSteps && !active.empty(); ++it) round();
    finish(again);
  }
}

/// How a vertex is moved onto F = 0: from where (the QEF point), within what (its cell, or a
/// face vertex's two edge points: a projection that leaves it by more than a cell is
/// dropped), and for a flat patch the mean edge normal and slope of its first step (slope 0:
/// the first step needs a gradient).
struct Placement {
  Box near;
  Vec3 dir{0, 0, 0};
  float slope = 0;
};

/// Scratch of project_vertices, one per thread (see EdgeScratch).
struct ProjectScratch {
  ScratchVector<float> xyz, fs;
  std::vector<float> last_f, slope, scale;
  std::vector<Vec3> g, start, prev, prev_step;
  std::vector<uint8_t> state;
  std::vector<uint32_t> idx, live;
};

/// Newton steps onto F = 0 for n vertices v (in place); returns how many moved. A gradient is
/// evaluated only where a step needs a direction; the point a step reaches is checked by a
/// value alone (|F| reduced? close enough?), with the gradient's length at the step's origin
/// as the slope. A flat patch's vertex (its edge normals within ~6 degrees) starts from a
/// value alone too: its first step goes along the mean edge normal with the mean edge slope,
/// both exact to first order at the mass point. Usually two values per smooth vertex, and no
/// gradient. A vertex with no value or no direction keeps its QEF point.
size_t project_vertices(const Capped& capped, float hmin, size_t n, Vec3* v,
                        const Placement* placement, ProjectScratch* scratch) {
  if (n == 0) return 0;
  const float on_surface = 1e-4f * hmin;  // a vertex this close to F = 0 stays where it is
  enum : uint8_t { kDone, kNeedGradient, kNeedValue, kFlatStart };
  auto& [xyz, fs_v, last_f_v, slope_v, scale_v, g_v, start_v, prev_v, prev_step_v, state_v, idx,
         live] = *scratch;
  xyz.resize(3 * Capped::padded_size(n));
  fs_v.resize(Capped::padded_size(n));
  // The points of the vertices idx as consecutive rows of the padded count in xyz (the
  // model's layout: evaluated without a copy).
  float *xs = nullptr, *ys = nullptr, *zs = nullptr;
  auto gather = [&]() {
    const size_t m = Capped::padded_size(idx.size());
    xs = xyz.data(), ys = xs + m, zs = ys + m;
    for (size_t j = 0; j < idx.size(); ++j) {
      const Vec3 p = v[idx[j]];
      xs[j] = p.x, ys[j] = p.y, zs[j] = p.z;
    }
  };
  last_f_v.assign(n, std::numeric_limits<float>::infinity());
  slope_v.assign(n, 0);
  scale_v.assign(n, 1);
  for (auto* a : {&g_v, &start_v, &prev_v, &prev_step_v}) a->resize(n);
  state_v.resize(n);
  // The arrays as plain pointers (see solve_edges: the pushes and byte stores below would
  // make every access through a vector reload its pointer).
  float *const fs = fs_v.data(), *const last_f = last_f_v.data(), *const slope = slope_v.data(),
               *const scale = scale_v.data();
  Vec3 *const g = g_v.data(), *const start = start_v.data(), *const prev = prev_v.data(),
              *const prev_step = prev_step_v.data();
  uint8_t* const state = state_v.data();
  live.clear();
  for (size_t i = 0; i < n; ++i) {
    start[i] = v[i];
    state[i] = placement[i].slope > 0 ? kFlatStart : kNeedGradient;
    live.push_back(uint32_t(i));
  }
  // A step from the current point of vertex i along `step`, from a value `f` and slope.
  auto take_step = [&](size_t i, float f, Vec3 step, float sl) {
    last_f[i] = std::abs(f);
    slope[i] = sl;
    prev[i] = v[i];
    const float len = length(step);
    if (len > hmin) step = step * (hmin / len);
    prev_step[i] = step;
    scale[i] = 1;
    v[i] = v[i] + step;
    state[i] = kNeedValue;
  };
  // `live`: the vertices not done yet (shrinks each iteration; most finish after two).
  for (int it = 0; it < kNewtonSteps && !live.empty(); ++it) {
    const bool last = it == kNewtonSteps - 1;
    // Gradients: the first evaluation of a vertex, or a direction from an accepted point.
    idx.clear();
    for (const uint32_t i : live) {
      if (state[i] == kNeedGradient) idx.push_back(i);
    }
    gather();
    capped.eval_gradient(idx.size(), xs, ys, zs, fs, g);
    for (size_t j = 0; j < idx.size(); ++j) {
      const size_t i = idx[j];
      const float g2 = length2(g[j]);
      if (!std::isfinite(fs[j]) || !(g2 > 0) || !std::isfinite(g2)) {
        v[i] = start[i];  // no value or no direction: keep the QEF point
        state[i] = kDone;
        continue;
      }
      const float gl = std::sqrt(g2);
      // A first evaluation may find the vertex on the surface already; a later point was
      // checked by its value (not close enough) before its gradient was asked for.
      if (last || (last_f[i] == std::numeric_limits<float>::infinity() &&
                   std::abs(fs[j]) / gl <= on_surface)) {
        state[i] = kDone;
        continue;
      }
      take_step(i, fs[j], g[j] * (-fs[j] / g2), gl);
    }
    // Values: flat starts, and the points steps reached.
    idx.clear();
    for (const uint32_t i : live) {
      if (state[i] == kNeedValue || state[i] == kFlatStart) idx.push_back(i);
    }
    gather();
    capped.eval(idx.size(), xs, ys, zs, fs);
    for (size_t j = 0; j < idx.size(); ++j) {
      const size_t i = idx[j];
      const float af = std::abs(fs[j]);
      if (!std::isfinite(fs[j])) {
        v[i] = start[i];  // no value: keep the QEF point
        state[i] = kDone;
        continue;
      }
      if (state[i] == kFlatStart) {
        const float sl = placement[i].slope;
        if (af <= on_surface * sl || last) {
          state[i] = kDone;
          continue;
        }
        const Vec3 step = placement[i].dir * (-fs[j] / sl);
        // A short first step is taken without a check: the mass point of a flat patch is
        // within ~h^2 / 8R of the surface (R its radius of curvature), and the step lands
        // within ~2 % of its length (the mean edge slope against the slope here), so a step
        // under kUncheckedStep of a cell ends within ~1e-4 of a cell of F = 0. (On the
        // 512^3 gyroid and blend the value it skips always passed: the files are the same.)
        // Such a vertex is done: it keeps nothing for a next step (and the step, far below
        // hmin, is never shortened).
        if (af <= kUncheckedStep * hmin * sl) {
          v[i] = v[i] + step;
          state[i] = kDone;
          continue;
        }
        take_step(i, fs[j], step, sl);
        continue;
      }
      if (!(af < last_f[i])) {
        // The step did not reduce |F| (a kink of min/max, or rounding): a shorter one from
        // the previous point, until it is too short to matter.
        scale[i] *= 0.25f;
        if (scale[i] < 1.0f / 64 || last) {
          v[i] = prev[i];
          state[i] = kDone;
        } else {
          v[i] = prev[i] + prev_step[i] * scale[i];
        }
        continue;
      }
      // Close enough by the slope at the step's origin (half the bound: the slope at the new
      // point may differ a little); otherwise a new direction there.
      if (af <= 0.5f * on_surface * slope[i] || last) {
        state[i] = kDone;
        continue;
      }
      last_f[i] = af;
      state[i] = kNeedGradient;
    }
    live.erase(
        std::remove_if(live.begin(), live.end(), [&](uint32_t i) { return state[i] == kDone; }),
        live.end());
  }
  // Keep a projection only when it stayed near its cell; otherwise the QEF point.
  size_t moved = 0;
  for (size_t i = 0; i < n; ++i) {
    Box near = placement[i].near;
    near.lo = near.lo - Vec3{hmin, hmin, hmin};
    near.hi = near.hi + Vec3{hmin, hmin, hmin};
    if (!near.contains(v[i]) || !is_finite(v[i])) v[i] = start[i];
    if (v[i].x != start[i].x || v[i].y != start[i].y || v[i].z != start[i].z) ++moved;
  }
  return moved;
}

/// A cell's +a face with four crossings whose two segments belong to one patch of the cell:
/// if they also belong to one patch of the cell across the face, the face gets a vertex of
/// its own (see mesh_field). Found while a run's cells are placed, settled after the join.
struct FaceCandidate {
  uint32_t cell;     // index in the run's cells (in all cells once joined)
  uint8_t axis;      // the face: +axis
  int8_t s1, s2[2];  // local edges: one of the first segment, both of the second
  Vec3 a, b;         // the zeros of s2's two edges
};

/// What one run of blocks made, in block order: the surface cells' corner signs (in each block
/// x fastest), their patch vertices (cell by cell, one per patch, projected onto F = 0 where
/// smooth), per block its surface cells (bit x + 4 y + 16 z) and the neighbouring blocks the
/// cells around its crossing edges lie in (bit d: offset kOffset[d]), and the faces that may need a
/// vertex. A cell's position is its block's and its bit's: nothing more is kept per cell.
/// Reused from batch to batch (clear() keeps the capacity): the runs' memory stays warm.
struct RunOut {
  std::vector<uint8_t> masks;
  std::vector<Vec3> vertices;
  std::vector<uint64_t> cmask;
  std::vector<uint32_t> reach;
  std::vector<FaceCandidate> faces;
  size_t nan_samples = 0, crossing_edges = 0, sharp = 0, projected = 0;
  void clear() {
    masks.clear(), vertices.clear(), cmask.clear(), reach.clear(), faces.clear();
    nan_samples = crossing_edges = sharp = projected = 0;
  }
};

/// Thread-seconds of the steps of a run, summed over runs.
struct RunClock {
  std::atomic<int64_t> sample_ns{0}, edges_ns{0}, vertices_ns{0};
};

/// The blocks' part of the mesher, run by run: each run of blocks is sampled, its crossing
/// edges solved and its cells' vertices placed together, from data of the run alone (edges
/// on the faces between blocks are solved by both), so that no global edge arrays are
/// needed and a run's output does not depend on the others or on the scheduling.
class BlockMesher {
 public:
  BlockMesher(const Capped& capped, const Grid& grid)
      : capped_(capped), grid_(grid), table_(cube_table()) {
    hmin_ = float(std::min({grid.h[0], grid.h[1], grid.h[2]}));
  }
  float hmin() const { return hmin_; }

  /// Meshes blocks [first, last) of `blocks` (one evaluation call for all their nodes).
  void run(const std::vector<BlockPos>& blocks, size_t first, size_t last, RunOut* out,
           RunClock* clock) const;

 private:
  static constexpr int kSide = kBlock + 1;
  static constexpr size_t kNodes = size_t(kSide) * kSide * kSide;
  /// A block of the run while its cells are placed: its low cell and, per axis a and node n
  /// (x + kSide (y + kSide z)), the batch index of the crossing edge from n towards +a (unset
  /// where that edge does not cross). Every edge between two of a block's nodes is an edge of
  /// one of its cells, so these are exactly the crossing edges its cells need: a cell finds
  /// its edges by one load each, instead of a list of 12 indices per cell counted from the
  /// rows' bits.
  struct RunBlock {
    int c0[3];
    uint16_t edge[3 * kNodes];  // [axis * kNodes + node]; < 65536: a run has ~5000 at most
  };
  /// A surface cell of the run: its block in the run, its place in the block, its corners.
  struct RunCell {
    uint16_t block;
    uint8_t l, j, k;
    uint8_t mask;
  };
  /// A block's surface cells as they are found, in order (x fastest): each cell's corners and
  /// place go to the run (out->masks, cells), its bit to the block's mask of surface cells,
  /// the blocks around its crossing edges' cells to the block's reach; end() files the
  /// block's mask and reach. Both ways of finding the cells (whole_block, the row path of
  /// run()) add them through it.
  class CellSink {
   public:
    CellSink(const CubeTable& table, size_t block_in_run, std::vector<RunCell>* cells, RunOut* out)
        : table_(table), block_(uint16_t(block_in_run)), cells_(cells), out_(out) {}
    void add(int l, int j, int k, int m) {
      static constexpr int kPlace[kBlock] = {0, 1, 1, 2};  // see CubeTable::reach
      cmask_ |= uint64_t(1) << (l + kBlock * (j + kBlock * k));
      out_->masks.push_back(uint8_t(m));
      reach_ |= table_.reach[kPlace[l] + 3 * kPlace[j] + 9 * kPlace[k]][m];
      out_->crossing_edges += size_t(table_.owned[m]);
      cells_->push_back({block_, uint8_t(l), uint8_t(j), uint8_t(k), uint8_t(m)});
    }
    void end() {
      out_->cmask.push_back(cmask_);
      out_->reach.push_back(reach_ & ~(uint32_t(1) << kSelf));
    }

   private:
    const CubeTable& table_;
    uint16_t block_;
    std::vector<RunCell>* cells_;
    RunOut* out_;
    uint64_t cmask_ = 0;
    uint32_t reach_ = 0;
  };
  /// Per local edge e: where RunBlock::edge holds it, from the cell's low corner's node.
  static constexpr std::array<uint16_t, 12> kEdgeSlot = [] {
    std::array<uint16_t, 12> t{};
    for (int e = 0; e < 12; ++e) {
      t[size_t(e)] = uint16_t(
          size_t(e / 4) * kNodes + size_t(kEdgeLow[e][0]) +
          size_t(kSide) * (size_t(kEdgeLow[e][1]) + size_t(kSide) * size_t(kEdgeLow[e][2])));
    }
    return t;
  }();
  /// The batch index of local edge e of cell rc (whose block is rb).
  static uint32_t edge_index(const RunBlock& rb, const RunCell& rc, int e) {
    return rb.edge[size_t(rc.l) + size_t(kSide) * (size_t(rc.j) + size_t(kSide) * size_t(rc.k)) +
                   kEdgeSlot[size_t(e)]];
  }
  /// Step 2 of run() for a whole block (kSide^3 nodes, values fb, node coordinates g*): its
  /// crossing edges into `edges` and rb->edge, its surface cells into `cells` and out.
  /// Branch-free where the surface decides: the nodes' sides are one 125-bit number S (bit
  /// n = x + kSide (y + kSide z)), the crossing edges along x, y and z are S ^ (S >> 1),
  /// S ^ (S >> kSide), S ^ (S >> kSide^2) and the surface cells the low corners whose eight
  /// corners' bits are neither all 0 nor all 1; each set of bits is then walked once.
  /// (Row by row, ~75 loops a block over a row's few bits, whose exits the surface decides,
  /// the 512^3 blend meshed ~4 % slower.) The edges go to the batch along x, then y, then z,
  /// each by node.
  void whole_block(const float* fb, const float* gx, const float* gy, const float* gz,
                   size_t block_in_run, RunBlock* rb, EdgeBatch* edges, std::vector<RunCell>* cells,
                   RunOut* out) const;

  /// Per thread: the run's buffers.
  struct Scratch {
    ScratchVector<float> buf;
    EdgeBatch edges;
    EdgeZeros zeros;
    std::vector<RunBlock> run_blocks;
    std::vector<RunCell> run_cells;
    std::vector<Placement> placements;
    EdgeScratch edge_scratch;
    ProjectScratch project_scratch;
  };
  const Capped& capped_;
  const Grid& grid_;
  const CubeTable& table_;
  float hmin_;
  mutable par::ThreadLocal<Scratch> scratch_;
};

void BlockMesher::whole_block(const float* fb, const float* gx, const float* gy, const float* gz,
                              size_t block_in_run, RunBlock* rb, EdgeBatch* edges,
                              std::vector<RunCell>* cells, RunOut* out) const {
  using Bits = unsigned __int128;  // bit n: node n (kNodes = 125 of them)
  static_assert(kNodes <= 128);
  constexpr int kS = kSide, kS2 = kSide * kSide;
  // Per node: its coordinates; and the nodes from which an edge along x, y, z stays in the
  // block, and the low corners of the block's cells.
  struct Tables {
    uint8_t at[kNodes][3];
    Bits valid[3], cell;
  };
  static constexpr Tables kT = [] {
    Tables t{};
    for (int n = 0; n < int(kNodes); ++n) {
      const int c[3] = {n % kS, (n / kS) % kS, n / kS2};
      for (int a = 0; a < 3; ++a) {
        t.at[n][a] = uint8_t(c[a]);
        if (c[a] < kBlock) t.valid[a] |= Bits(1) << n;
      }
      if (c[0] < kBlock && c[1] < kBlock && c[2] < kBlock) t.cell |= Bits(1) << n;
    }
    return t;
  }();
  // The sides: four values at a time (fb has room for 128).
  Bits sides = 0;
#if defined(__SSE2__)
  // (Into two 64-bit halves, the loops unrolled: constant shifts of one word instead of
  // variable 128-bit ones, ~1 % of the mesher's instructions.)
  const __m128 zero = _mm_setzero_ps();
  uint64_t half[2] = {0, 0};
  for (int w = 0; w < 2; ++w) {
#pragma GCC unroll 16
    for (int i = 0; i < 64; i += 4) {
      const int m = _mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(fb + 64 * w + i), zero));  // inside()
      half[w] |= uint64_t(unsigned(m)) << i;
    }
  }
  sides = Bits(half[0]) | (Bits(half[1]) << 64);
#else
  for (int i = 0; i < int(kNodes); ++i) sides |= Bits(inside(fb[i])) << i;
#endif
  sides &= (Bits(1) << kNodes) - 1;
  // The crossing edges, axis by axis, node by node.
  size_t ne = edges->size();
  edges->grow(ne + 3 * kNodes);
  const float* g[3] = {gx, gy, gz};
  constexpr int kStep[3] = {1, kS, kS2};
#pragma GCC unroll 3
  for (int a = 0; a < 3; ++a) {
    const Bits cross = (sides ^ (sides >> kStep[a])) & kT.valid[a];
    uint16_t* slot = rb->edge + size_t(a) * kNodes;
#pragma GCC unroll 2
    for (int w = 0; w < 2; ++w) {
      for (uint64_t bits = uint64_t(cross >> (64 * w)); bits != 0; bits &= bits - 1, ++ne) {
        const int n = 64 * w + std::countr_zero(bits);
        const uint8_t* c = kT.at[n];
        const Vec3 pa{gx[c[0]], gy[c[1]], gz[c[2]]};
        Vec3 pb = pa;
        pb[a] = g[a][c[a] + 1];
        edges->set(ne, pa, pb, fb[n], fb[n + kStep[a]]);
        slot[n] = uint16_t(ne);
      }
    }
  }
  edges->set_size(ne);
  // The surface cells: low corners whose corners (offsets 0, 1, kS, kS + 1 and the same
  // kS2 up) are not all alike.
  const Bits any = sides | (sides >> 1), all = sides & (sides >> 1);
  const Bits any4 = any | (any >> kS), all4 = all & (all >> kS);
  const Bits surface = (any4 | (any4 >> kS2)) & ~(all4 & (all4 >> kS2)) & kT.cell;
  CellSink sink(table_, block_in_run, cells, out);
#pragma GCC unroll 2
  for (int w = 0; w < 2; ++w) {
    for (uint64_t bits = uint64_t(surface >> (64 * w)); bits != 0; bits &= bits - 1) {
      const int n = 64 * w + std::countr_zero(bits);
      // Corner c = cx | cy << 1 | cz << 2, as run() numbers them.
      // (From one 64-bit window of S at n: a cell's corners lie within kS2 + kS + 2 bits.)
      static_assert(kS2 + kS + 2 <= 64);
      const uint64_t win = uint64_t(sides >> n);
      const int m = int(win & 3) | int(((win >> kS) & 3) << 2) | int(((win >> kS2) & 3) << 4) |
                    int(((win >> (kS2 + kS)) & 3) << 6);
      const uint8_t* c = kT.at[n];
      sink.add(c[0], c[1], c[2], m);
    }
  }
  sink.end();
}

void BlockMesher::run(const std::vector<BlockPos>& blocks, size_t first, size_t last, RunOut* out,
                      RunClock* clock) const {
  Clock::time_point t0 = Clock::now();
  Scratch& sc = scratch_.local();
  auto& [buf, edges, zeros, run_blocks, run_cells, placements, edge_scratch, project_scratch] = sc;
  run_blocks.resize(last - first);
  run_cells.clear(), edges.clear(), placements.clear();
  out->clear();
  std::vector<Vec3>& vertices = out->vertices;
  auto extent = [&](size_t bi, int c0[3], int cn[3]) {
    for (int a = 0; a < 3; ++a) {
      c0[a] = blocks[bi].b[a] * kBlock;
      cn[a] = std::min(kBlock, grid_.cells(a) - c0[a]);
    }
  };
  // The nodes' coordinates as consecutive rows of the padded count (the model's own layout:
  // evaluated without a copy), then their values.
  size_t nodes = 0;
  for (size_t bi = first; bi < last; ++bi) {
    int c0[3], cn[3];
    extent(bi, c0, cn);
    nodes += size_t(cn[0] + 1) * size_t(cn[1] + 1) * size_t(cn[2] + 1);
  }
  const size_t cap = Capped::padded_size(nodes);
  buf.resize(4 * cap + 4);  // + 4: whole_block reads a block's values 4 at a time (128 of 125)
  float *x = buf.data(), *y = x + cap, *z = y + cap, *f = z + cap;
  // 1. Sample every block's nodes.
  size_t np = 0;
  for (size_t bi = first; bi < last; ++bi) {
    int c0[3], cn[3];
    extent(bi, c0, cn);
    const float *gx = &grid_.coord[0][size_t(c0[0])], *gy = &grid_.coord[1][size_t(c0[1])],
                *gz = &grid_.coord[2][size_t(c0[2])];
    if (cn[0] == kBlock && cn[1] == kBlock && cn[2] == kBlock) {
      // A whole block (all but the grid's last ones): rows of kSide with the trip counts
      // known, the coordinates in locals (the stores could alias the grid's arrays). 2.0 %
      // fewer instructions in the whole mesher than the generic loop below (callgrind, 256^3
      // blend, one thread); no difference in time shows through the VM's noise.
      float lx[kSide], ly[kSide], lz[kSide];
      for (int l = 0; l < kSide; ++l) lx[l] = gx[l], ly[l] = gy[l], lz[l] = gz[l];
      for (int k = 0; k < kSide; ++k)
        for (int j = 0; j < kSide; ++j, np += kSide)
          for (int l = 0; l < kSide; ++l) x[np + l] = lx[l], y[np + l] = ly[j], z[np + l] = lz[k];
      continue;
    }
    for (int k = 0; k <= cn[2]; ++k)
      for (int j = 0; j <= cn[1]; ++j)
        for (int l = 0; l <= cn[0]; ++l, ++np) x[np] = gx[l], y[np] = gy[j], z[np] = gz[k];
  }
  capped_.eval(np, x, y, z, f, &out->nan_samples);
  // 2. The crossing edges and the surface cells, block by block.
  np = 0;
  for (size_t bi = first; bi < last; ++bi) {
    RunBlock& rb = run_blocks[bi - first];
    int cn[3];
    extent(bi, rb.c0, cn);
    const int* c0 = rb.c0;
    const int nx = cn[0] + 1, ny = cn[1] + 1, nz = cn[2] + 1;
    const size_t sy = size_t(nx), sz = size_t(nx) * ny;
    const float* fb = f + np;
    const float *gx = &grid_.coord[0][size_t(c0[0])], *gy = &grid_.coord[1][size_t(c0[1])],
                *gz = &grid_.coord[2][size_t(c0[2])];
    if (nx == kSide && ny == kSide && nz == kSide) {
      whole_block(fb, gx, gy, gz, bi - first, &rb, &edges, &run_cells, out);
      np += kNodes;
      continue;
    }
    // A block at the grid's high end (fewer cells): row by row.
    // The nodes' sides as one bit per node of each row along x (bit l: node l inside).
    uint32_t rows[kSide * kSide];
    for (int k = 0, n = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j) {
        uint32_t r = 0;
        for (int l = 0; l < nx; ++l, ++n) r |= uint32_t(inside(fb[n])) << l;
        rows[k * kSide + j] = r;
      }
    const uint32_t full = (uint32_t(1) << nx) - 1;
    // The crossing edges along x, y and z from each row's nodes and their ends: row by row
    // (y fastest), per row x, y, z and x fastest, so that a cell's edges lie close together
    // in the batch.
    size_t ne = edges.size();
    edges.grow(ne + size_t(3 * kSide * kSide * kSide));  // room for every edge of the block
    // The edges along axis A from the nodes `bits` of row (j, k) (A a template argument:
    // the far end's coordinate is picked at compile time).
    auto add_edges = [&]<int A>(int j, int k, uint32_t bits) {
      const size_t step = A == 0 ? 1 : (A == 1 ? sy : sz);
      uint16_t* slot =
          rb.edge + size_t(A) * kNodes + size_t(kSide) * (size_t(j) + size_t(kSide) * size_t(k));
      for (uint32_t b = bits; b != 0; b &= b - 1, ++ne) {
        const int l = std::countr_zero(b);
        const size_t n = size_t(k) * sz + size_t(j) * sy + size_t(l);
        const Vec3 pa{gx[l], gy[j], gz[k]};
        const Vec3 pb{A == 0 ? gx[l + 1] : gx[l], A == 1 ? gy[j + 1] : gy[j],
                      A == 2 ? gz[k + 1] : gz[k]};
        edges.set(ne, pa, pb, fb[n], fb[n + step]);
        slot[l] = uint16_t(ne);
      }
    };
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j) {
        const int row = j + kSide * k;
        const uint32_t r = rows[row];
        add_edges.operator()<0>(j, k, (r ^ (r >> 1)) & (full >> 1));
        if (j + 1 < ny) add_edges.operator()<1>(j, k, r ^ rows[row + 1]);
        if (k + 1 < nz) add_edges.operator()<2>(j, k, r ^ rows[row + kSide]);
      }
    edges.set_size(ne);
    CellSink sink(table_, bi - first, &run_cells, out);
    for (int k = 0; k < cn[2]; ++k)
      for (int j = 0; j < cn[1]; ++j) {
        // The four rows of nodes around this row of cells; all out or all in: no surface.
        const uint32_t r00 = rows[k * kSide + j], r10 = rows[k * kSide + j + 1],
                       r01 = rows[(k + 1) * kSide + j], r11 = rows[(k + 1) * kSide + j + 1];
        if ((r00 | r10 | r01 | r11) == 0 || (r00 & r10 & r01 & r11) == full) continue;
        for (int l = 0; l < cn[0]; ++l) {
          // Corner c = cx | cy << 1 | cz << 2: bits 0-1 from row (j, k), 2-3 from (j + 1, k),
          // 4-5 from (j, k + 1), 6-7 from (j + 1, k + 1).
          const int m = int(((r00 >> l) & 3) | (((r10 >> l) & 3) << 2) | (((r01 >> l) & 3) << 4) |
                            (((r11 >> l) & 3) << 6));
          if (m != 0 && m != 255) sink.add(l, j, k, m);
        }
      }
    sink.end();
    np += size_t(nz) * sz;
  }
  HFRT_CHECK_LE(edges.size(), size_t(UINT16_MAX));  // RunCell's edge indices
  const Clock::time_point t1 = Clock::now();
  // 3. The edges' zeros and normals.
  solve_edges(capped_, edges, &zeros, &edge_scratch);
  const Clock::time_point t2 = Clock::now();
  // 4. One vertex per patch: the QEF point of its edges' tangent planes, clamped to its cell;
  // then onto F = 0 where the patch is smooth (rank 1) or the point is off the surface.
  // (Arrays as plain pointers: the pushes below are calls after which every access through a
  // vector would reload its pointer.)
  const Vec3 *const zpoint = zeros.point.data(), *const znormal = zeros.normal.data();
  const float* const zslope = zeros.slope.data();
  const float *const cx = grid_.coord[0].data(), *const cy = grid_.coord[1].data(),
                     *const cz = grid_.coord[2].data();
  const RunCell* const cells = run_cells.data();
  const RunBlock* const rblocks = run_blocks.data();
  uint32_t cell_edges[12];
  for (size_t i = 0; i < run_cells.size(); ++i) {
    const RunCell& rc = cells[i];
    const RunBlock& rb = rblocks[rc.block];
    const int m = rc.mask;
    const int c[3] = {rb.c0[0] + rc.l, rb.c0[1] + rc.j, rb.c0[2] + rc.k};
    const Box cell_box(Vec3{cx[c[0]], cy[c[1]], cz[c[2]]},
                       Vec3{cx[c[0] + 1], cy[c[1] + 1], cz[c[2] + 1]});
    const int ncomp = table_.ncomp[m];
    for (int comp = 0; comp < ncomp; ++comp) {
      int k = 0;
      for (unsigned bits = table_.cross[m]; bits != 0; bits &= bits - 1) {
        const int e = std::countr_zero(bits);
        if (ncomp > 1 && table_.comp[m][e] != comp) continue;
        cell_edges[k++] = edge_index(rb, rc, e);
      }
      int rank = 0;
      Vec3 flat{0, 0, 0};
      float sl = 0;
      Vec3 v = solve_qef(zpoint, znormal, zslope, cell_edges, k, &rank, &flat, &sl);
      if (!is_finite(v)) v = cell_box.center();
      v = vmin(vmax(v, cell_box.lo), cell_box.hi);
      Placement pl;
      pl.near = cell_box;
      if (length2(flat) > 0 && sl > 0 && std::isfinite(sl)) pl.dir = flat, pl.slope = sl;
      vertices.push_back(v);
      placements.push_back(pl);
      if (rank >= 2) ++out->sharp;
    }
    // Faces with two segments of one patch (see FaceCandidate).
    for (unsigned faces = table_.split_face[m]; faces != 0; faces &= faces - 1) {
      const int a = std::countr_zero(faces);
      const int8_t* fe = table_.split_edges[m][a];
      out->faces.push_back({uint32_t(i),
                            uint8_t(a),
                            fe[0],
                            {fe[1], fe[2]},
                            zpoint[edge_index(rb, rc, fe[1])],
                            zpoint[edge_index(rb, rc, fe[2])]});
    }
  }
  out->projected += project_vertices(capped_, hmin_, vertices.size(), vertices.data(),
                                     placements.data(), &project_scratch);
  const Clock::time_point t3 = Clock::now();
  auto ns = [](Clock::time_point a, Clock::time_point b) {
    return int64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(b - a).count());
  };
  clock->sample_ns += ns(t0, t1);
  clock->edges_ns += ns(t1, t2);
  clock->vertices_ns += ns(t2, t3);
}

}  // namespace

void grid_for(const MeshOptions& options, int cells[3], double size[3]) {
  const Box& b = options.box;
  HFRT_CHECK(!b.empty() && b.max_extent() > 0);
  const double target = options.cell > 0 ? double(options.cell)
                                         : double(b.max_extent()) / std::max(1, options.resolution);
  for (int a = 0; a < 3; ++a) {
    double s = double(b.hi[a]) - double(b.lo[a]);
    // Relative slack: float inputs (1.2f / 0.05f = 48.0000012) must not add a cell.
    int n = int(std::ceil(s / target * (1 - 1e-6)));
    n = std::clamp(n, 1, kMaxCells);
    cells[a] = n;
    size[a] = s > 0 ? s / n : target;
  }
}

void warm_up(int threads) {
  (void)cube_table();
  par::warm_up(threads);
}

/// The two splits of a quad (corners 0, e1, e2, e3 relative to corner 0): per split the dot
/// product d of its two triangles' normals and the product l of their squared lengths
/// (split 0-2: e1 x e2 and e2 x e3; split 1-3: (e2 - e1) x (e3 - e1) and (e3 - e1) x -e1).
/// With SSE2 the four cross products, lengths and dots are lane by lane the same operations in
/// the same order as Vec3's cross, dot and length2 (so the same bits), a third of the
/// instructions (the faces' diagonals were ~8 % of the mesher's).
inline void split_products(Vec3 e1, Vec3 e2, Vec3 e3, float* d02, float* l02, float* d13,
                           float* l13) {
  const Vec3 u = e2 - e1, w = e3 - e1, ne1 = -e1;
#if defined(__SSE2__)
  // Lanes: a02, b02, a13, b13 as A x B (_mm_set_ps lists lanes 3..0).
  const __m128 ax = _mm_set_ps(w.x, u.x, e2.x, e1.x), ay = _mm_set_ps(w.y, u.y, e2.y, e1.y),
               az = _mm_set_ps(w.z, u.z, e2.z, e1.z);
  const __m128 bx = _mm_set_ps(ne1.x, w.x, e3.x, e2.x), by = _mm_set_ps(ne1.y, w.y, e3.y, e2.y),
               bz = _mm_set_ps(ne1.z, w.z, e3.z, e2.z);
  const __m128 cx = _mm_sub_ps(_mm_mul_ps(ay, bz), _mm_mul_ps(az, by));
  const __m128 cy = _mm_sub_ps(_mm_mul_ps(az, bx), _mm_mul_ps(ax, bz));
  const __m128 cz = _mm_sub_ps(_mm_mul_ps(ax, by), _mm_mul_ps(ay, bx));
  // Each lane with its partner (0 with 1, 2 with 3).
  constexpr int kSwap = _MM_SHUFFLE(2, 3, 0, 1);
  const __m128 sx = _mm_shuffle_ps(cx, cx, kSwap), sy = _mm_shuffle_ps(cy, cy, kSwap),
               sz = _mm_shuffle_ps(cz, cz, kSwap);
  const __m128 d =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, sx), _mm_mul_ps(cy, sy)), _mm_mul_ps(cz, sz));
  const __m128 len2 =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, cx), _mm_mul_ps(cy, cy)), _mm_mul_ps(cz, cz));
  const __m128 l = _mm_mul_ps(len2, _mm_shuffle_ps(len2, len2, kSwap));
  constexpr int kLane2 = _MM_SHUFFLE(2, 2, 2, 2);
  *d02 = _mm_cvtss_f32(d);
  *l02 = _mm_cvtss_f32(l);
  *d13 = _mm_cvtss_f32(_mm_shuffle_ps(d, d, kLane2));
  *l13 = _mm_cvtss_f32(_mm_shuffle_ps(l, l, kLane2));
#else
  const Vec3 a02 = cross(e1, e2), b02 = cross(e2, e3), a13 = cross(u, w), b13 = cross(w, ne1);
  *d02 = dot(a02, b02), *l02 = length2(a02) * length2(b02);
  *d13 = dot(a13, b13), *l13 = length2(a13) * length2(b13);
#endif
}

TriMesh mesh_field(const render::Field& field, const MeshOptions& options, MeshStats* stats_out) {
  HFRT_CHECK(options.cell > 0 || options.resolution >= 1);
  MeshStats stats;
  Timer total_timer;
  Grid grid;
  grid_for(options, grid.n, grid.h);
  for (int a = 0; a < 3; ++a) {
    grid.lo[a] = options.box.lo[a];
    stats.grid[a] = grid.n[a];
  }
  grid.box = options.box;
  grid.init_coords();
  const Capped capped(field, options.box);
  const CubeTable& table = cube_table();

  const int threads = options.threads > 0 ? options.threads : par::default_concurrency();
  stats.threads = threads;
  TriMesh mesh;
  par::with_threads(threads, [&] {
    // --- 1. The octree over blocks, level by level. ------------------------------------------
    Timer timer;
    int nb[3];
    for (int a = 0; a < 3; ++a) nb[a] = (grid.cells(a) + kBlock - 1) / kBlock;
    stats.blocks_total = size_t(nb[0]) * nb[1] * nb[2];
    stats.block_size = kBlock;
    int root = 1;
    while (root < std::max({nb[0], nb[1], nb[2]})) root <<= 1;
    using Node = BlockPos;
    auto node_box = [&](const Node& nd, int size) {
      Vec3 lo, hi;
      for (int a = 0; a < 3; ++a) {
        int c0 = nd.b[a] * kBlock, c1 = std::min((nd.b[a] + size) * kBlock, grid.cells(a));
        lo[a] = grid.node(a, c0);
        hi[a] = grid.node(a, c1);
      }
      return Box(lo, hi);
    };
    // Per level, in chunks on the threads: the nodes' boxes, their intervals and the children
    // of the undecided ones (joined in chunk order: the order does not depend on the
    // scheduling).
    std::vector<Node> level{{{0, 0, 0}}};
    int size = root;
    constexpr size_t kOctreeGrain = 512;
    std::vector<std::vector<Node>> children;
    while (true) {
      const size_t nchunks = (level.size() + kOctreeGrain - 1) / kOctreeGrain;
      children.resize(std::max(children.size(), nchunks));
      parallel_chunks(level.size(), kOctreeGrain, [&](size_t b, size_t e) {
        Box boxes[kOctreeGrain];
        render::Interval ivals[kOctreeGrain];
        for (size_t i = b; i < e; ++i) boxes[i - b] = node_box(level[i], size);
        capped.eval_intervals(e - b, boxes, ivals);
        std::vector<Node>& next = children[b / kOctreeGrain];
        next.clear();
        for (size_t i = b; i < e; ++i) {
          const render::Interval& iv = ivals[i - b];
          if (iv.hi < 0 || iv.lo >= 0) continue;  // proven outside, or inside everywhere
          if (size == 1) {
            next.push_back(level[i]);
            continue;
          }
          const int half = size / 2;
          for (int c = 0; c < 8; ++c) {
            Node ch{{level[i].b[0] + (c & 1) * half, level[i].b[1] + ((c >> 1) & 1) * half,
                     level[i].b[2] + (c >> 2) * half}};
            if (ch.b[0] < nb[0] && ch.b[1] < nb[1] && ch.b[2] < nb[2]) next.push_back(ch);
          }
        }
      });
      stats.octree_nodes += level.size();
      size_t total = 0;
      for (size_t c = 0; c < nchunks; ++c) total += children[c].size();
      std::vector<Node> next;
      next.reserve(total);
      for (size_t c = 0; c < nchunks; ++c)
        next.insert(next.end(), children[c].begin(), children[c].end());
      level.swap(next);
      if (size == 1) break;
      size /= 2;
    }
    stats.seconds_octree = timer.seconds();

    // --- 2. The blocks, run by run: samples, surface cells, edges, vertices. -----------------
    // Every run of kBatchBlocks blocks samples the (up to) 5^3 nodes of each block in one
    // evaluation call (the per-call cost paid once), then solves its crossing edges and
    // places its cells' vertices (BlockMesher). Each run writes its own RunOut and the runs
    // are joined in block order, so nothing depends on the scheduling. (Neighbouring sampled
    // blocks both evaluate their common faces: taking them from each other halves the
    // evaluations but costs more in memory traffic than it saves on models whose F is cheap.)
    timer = Timer();
    std::vector<BlockPos> blocks = std::move(level);
    const size_t octree_blocks = blocks.size();
    constexpr size_t kBatchBlocks = 16;
    const size_t kProgressBatch = 4096;  // a multiple of kBatchBlocks
    const BlockMesher block_mesher(capped, grid);
    // The runs of one batch (reused by the next: their memory stays warm), and what every
    // batch joined onto, in block order: per block its surface cells (bits), the blocks its
    // crossing edges reach, its first cell and its first vertex; per cell its corner signs;
    // the vertices (mesh.vertices) and the face candidates (with cells numbered over all).
    std::vector<RunOut> runs(kProgressBatch / kBatchBlocks);
    std::vector<uint64_t> block_cmask;
    std::vector<uint32_t> block_reach, block_cell_base{0}, block_vert_base{0};
    std::vector<uint8_t> masks;
    std::vector<FaceCandidate> faces;
    for (auto* v : {&block_reach, &block_cell_base, &block_vert_base})
      v->reserve(octree_blocks + 1);
    block_cmask.reserve(octree_blocks);
    // Joins runs [0, nruns) of a batch that ended at block `done` of `expected`: each run's
    // place in the joined arrays from the runs' sizes (serial, a few adds per run), then the
    // copies on the threads. (Joined on one thread, the copies and the first touch of the
    // arrays' pages took 43 of the blocks' 176 ms on the 512^3 gyroid, 2 threads, with the
    // other thread idle; in parallel the fresh process's mesh is 0.202-0.257 s against
    // 0.218-0.266 s with malloc on huge pages, and within the noise without.)
    struct RunPlace {
      size_t cell, vert, block, face;
    };
    std::vector<RunPlace> places(runs.size() + 1);
    auto join_batch = [&](size_t nruns, size_t done, size_t expected) {
      places[0] = {masks.size(), mesh.vertices.size(), block_cmask.size(), faces.size()};
      for (size_t r = 0; r < nruns; ++r) {
        const RunOut& o = runs[r];
        places[r + 1] = {places[r].cell + o.masks.size(), places[r].vert + o.vertices.size(),
                         places[r].block + o.cmask.size(), places[r].face + o.faces.size()};
        stats.nan_samples += o.nan_samples;
        stats.crossing_edges += o.crossing_edges;
        stats.sharp_vertices += o.sharp;
        stats.projected_vertices += o.projected;
      }
      const RunPlace& end = places[nruns];
      HFRT_CHECK_LE(end.vert, size_t(kNone) / 2);  // vertex and cell indices are 32-bit
      // Room for the rest by the density so far (the arrays are not moved again unless the
      // rest is much denser): one allocation, touched only as it is filled.
      auto grow = [&](auto& v, size_t n) {
        if (n <= v.capacity()) return;
        reserve_huge(v, std::max(n, size_t(double(n) * double(expected) / double(done) * 1.1)));
      };
      grow(masks, end.cell);
      grow(mesh.vertices, end.vert + end.vert / 64);  // and room for face vertices
      masks.resize(end.cell);
      mesh.vertices.resize(end.vert);
      faces.resize(end.face);
      block_cmask.resize(end.block);
      block_reach.resize(end.block);
      block_cell_base.resize(end.block + 1);
      block_vert_base.resize(end.block + 1);
      parallel_chunks(nruns, 4, [&](size_t rb, size_t re) {
        for (size_t r = rb; r < re; ++r) {
          const RunOut& o = runs[r];
          const RunPlace& at = places[r];
          std::copy(o.masks.begin(), o.masks.end(), masks.begin() + ptrdiff_t(at.cell));
          std::copy(o.vertices.begin(), o.vertices.end(),
                    mesh.vertices.begin() + ptrdiff_t(at.vert));
          std::copy(o.cmask.begin(), o.cmask.end(), block_cmask.begin() + ptrdiff_t(at.block));
          std::copy(o.reach.begin(), o.reach.end(), block_reach.begin() + ptrdiff_t(at.block));
          for (size_t i = 0; i < o.faces.size(); ++i) {
            FaceCandidate& fc = faces[at.face + i];
            fc = o.faces[i];
            fc.cell += uint32_t(at.cell);
          }
          // Per block its first cell and first vertex (entry b + 1: after block b).
          size_t c = 0;
          uint32_t cells = uint32_t(at.cell), verts = uint32_t(at.vert);
          for (size_t j = 0; j < o.cmask.size(); ++j) {
            const size_t n = size_t(bit_count64(o.cmask[j]));
            for (size_t i = c; i < c + n; ++i) verts += uint32_t(table.ncomp[o.masks[i]]);
            c += n;
            cells += uint32_t(n);
            block_cell_base[at.block + j + 1] = cells;
            block_vert_base[at.block + j + 1] = verts;
          }
          HFRT_CHECK(c == o.masks.size());
          HFRT_CHECK(verts == at.vert + o.vertices.size());
        }
      });
    };
    RunClock clock;
    BlockIndex index(nb);  // the blocks sampled so far
    // Closure: every crossing edge needs its four cells, and they may lie in a block the
    // octree pruned where the interval and the point evaluators disagree about a node. Such
    // blocks are meshed too, round after round, until no crossing edge reaches an unsampled
    // block (normally the first round finds none).
    for (size_t first = 0; first < blocks.size();) {
      const size_t last = blocks.size();
      for (size_t b0 = first; b0 < last; b0 += kProgressBatch) {
        const size_t b1 = std::min(last, b0 + kProgressBatch);
        parallel_chunks(b1 - b0, kBatchBlocks, [&](size_t s, size_t e) {
          block_mesher.run(blocks, b0 + s, b0 + e, &runs[s / kBatchBlocks], &clock);
        });
        join_batch((b1 - b0 + kBatchBlocks - 1) / kBatchBlocks, b1, last);
        if (options.progress && first == 0) options.progress(b1, octree_blocks + 1);
      }
      if (first == 0) stats.seconds_blocks = timer.seconds();
      for (size_t bi = first; bi < last; ++bi) index.add(blocks[bi], uint32_t(bi));
      // The blocks reached but not sampled, per chunk of blocks (almost always none).
      constexpr size_t kCheckGrain = 4096;  // blocks
      std::vector<std::vector<uint64_t>> missing_in((last - first + kCheckGrain - 1) / kCheckGrain);
      parallel_chunks(last - first, kCheckGrain, [&](size_t b, size_t e) {
        std::vector<uint64_t>& miss = missing_in[b / kCheckGrain];
        for (size_t bi = first + b; bi < first + e; ++bi) {
          for (uint32_t bits = block_reach[bi]; bits != 0; bits &= bits - 1) {
            const int d = std::countr_zero(bits);
            int q[3];
            for (int a = 0; a < 3; ++a) q[a] = blocks[bi].b[a] + kOffset[size_t(d)][size_t(a)];
            HFRT_CHECK(q[0] >= 0 && q[1] >= 0 && q[2] >= 0);
            if (index.find(q[0], q[1], q[2]) != kNone) continue;
            miss.push_back(cell_key(q[0], q[1], q[2]));
          }
        }
      });
      std::vector<uint64_t> missing;
      for (const auto& m : missing_in) missing.insert(missing.end(), m.begin(), m.end());
      std::sort(missing.begin(), missing.end());
      missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
      first = last;
      for (const uint64_t k : missing) {
        BlockPos q;
        key_cell(k, q.b);
        blocks.push_back(q);
      }
    }
    std::vector<RunOut>().swap(runs);
    stats.blocks_sampled = blocks.size();
    stats.thread_seconds_sample = double(clock.sample_ns.load()) * 1e-9;
    stats.thread_seconds_edges = double(clock.edges_ns.load()) * 1e-9;
    stats.thread_seconds_vertices = double(clock.vertices_ns.load()) * 1e-9;
    for (size_t bi = octree_blocks; bi < blocks.size(); ++bi)
      stats.closure_cells += size_t(bit_count64(block_cmask[bi]));
    const size_t ncells = masks.size(), ncellverts = mesh.vertices.size();
    HFRT_CHECK(block_cell_base.back() == ncells);
    stats.surface_cells = ncells;

    // --- 3. Face vertices. ---------------------------------------------------------------------
    Timer join_timer;
    // The block of cell ci, its position and its first vertex (for the few cells the face
    // candidates name; the faces walk the blocks' cells in order instead).
    auto cell_block = [&](size_t ci) {
      return uint32_t(
          std::upper_bound(block_cell_base.begin(), block_cell_base.end(), uint32_t(ci)) -
          block_cell_base.begin() - 1);
    };
    auto cell_pos = [&](size_t ci, uint32_t bi, int c[3]) {
      uint64_t bits = block_cmask[bi];
      for (uint32_t i = block_cell_base[bi]; i < ci; ++i) bits &= bits - 1;
      const int l = std::countr_zero(bits);
      c[0] = blocks[bi].b[0] * kBlock + l % kBlock;
      c[1] = blocks[bi].b[1] * kBlock + (l / kBlock) % kBlock;
      c[2] = blocks[bi].b[2] * kBlock + l / (kBlock * kBlock);
    };
    auto cell_vbase = [&](size_t ci, uint32_t bi) {
      uint32_t v = block_vert_base[bi];
      for (uint32_t i = block_cell_base[bi]; i < ci; ++i) v += uint32_t(table.ncomp[masks[i]]);
      return v;
    };
    // The surface cell at cell ci + (dx, dy, dz) (each -1, 0 or 1), kNone when there is none:
    // through its block's mask and the block's neighbours.
    auto neighbour_cell = [&](size_t ci, int dx, int dy, int dz) -> uint32_t {
      const uint32_t bi = cell_block(ci);
      int c[3];
      cell_pos(ci, bi, c);
      const int q[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
      if (q[0] < 0 || q[1] < 0 || q[2] < 0) return kNone;
      const uint32_t bq = index.find(q[0] / kBlock, q[1] / kBlock, q[2] / kBlock);
      if (bq == kNone) return kNone;
      const int l = (q[0] % kBlock) + kBlock * (q[1] % kBlock) + kBlock * kBlock * (q[2] % kBlock);
      const uint64_t cm = block_cmask[bq];
      if (!((cm >> l) & 1)) return kNone;
      return block_cell_base[bq] + uint32_t(bit_count64(cm & ((uint64_t(1) << l) - 1)));
    };
    // The key of local edge e of cell ci: its owner cell (at +u, +v) * 3 + its axis.
    auto edge_key = [&](size_t ci, int e) -> uint64_t {
      const int a = e / 4;
      int b, d, o[3] = {0, 0, 0};
      other_axes(a, &b, &d);
      o[b] = e & 1;
      o[d] = (e >> 1) & 1;
      const uint32_t owner = (e & 3) == 0 ? uint32_t(ci) : neighbour_cell(ci, o[0], o[1], o[2]);
      HFRT_CHECK(owner != kNone);
      return uint64_t(owner) * 3 + uint64_t(a);
    };

    // Faces where the same two patches would be joined by both segments: the segment around
    // the face's second inside corner gets a vertex of its own (between the two patches).
    struct Split {
      uint64_t edge;    // edge_key of the crossing edge whose quad gets the face vertex
      uint32_t pc, pd;  // the two patch vertices it goes between
      uint32_t m;       // the face vertex
      bool operator<(const Split& o) const {
        return edge < o.edge || (edge == o.edge && pc < o.pc);
      }
    };
    std::vector<Split> splits;
    std::vector<Placement> split_placements;
    ProjectScratch split_scratch;
    for (const FaceCandidate& fc : faces) {
      const size_t ci = fc.cell;
      const int m = masks[ci], a = fc.axis;
      int o[3] = {0, 0, 0};
      o[a] = 1;
      const uint32_t di = neighbour_cell(ci, o[0], o[1], o[2]);
      HFRT_CHECK(di != kNone);
      const int md = masks[di];
      // The same edges in the neighbour: the face is its -a face (bit a cleared).
      auto in_d = [a](int e) {
        // An edge on the +a face of C is along b or d; its position bit for axis a is set.
        int ax = e / 4, o1, o2;
        other_axes(ax, &o1, &o2);
        int u = e & 1, v = (e >> 1) & 1;
        if (o1 == a) u = 0;
        if (o2 == a) v = 0;
        return ax * 4 + (u | (v << 1));
      };
      if (table.comp[md][in_d(fc.s1)] != table.comp[md][in_d(fc.s2[0])]) continue;
      const uint32_t pc = cell_vbase(ci, cell_block(ci)) + uint32_t(table.comp[m][fc.s2[0]]);
      const uint32_t pd = cell_vbase(di, cell_block(di)) + uint32_t(table.comp[md][in_d(fc.s2[0])]);
      const uint32_t mv = uint32_t(mesh.vertices.size());
      splits.push_back({edge_key(ci, fc.s2[0]), pc, pd, mv});
      splits.push_back({edge_key(ci, fc.s2[1]), pc, pd, mv});
      mesh.vertices.push_back((fc.a + fc.b) * 0.5f);
      Placement pl;
      pl.near.extend(fc.a);
      pl.near.extend(fc.b);
      split_placements.push_back(pl);
    }
    std::vector<FaceCandidate>().swap(faces);
    std::sort(splits.begin(), splits.end());
    stats.split_faces = split_placements.size();
    stats.projected_vertices += project_vertices(
        capped, block_mesher.hmin(), split_placements.size(), mesh.vertices.data() + ncellverts,
        split_placements.data(), &split_scratch);
    const size_t nverts = mesh.vertices.size();
    stats.seconds_join = join_timer.seconds();
    if (ncells == 0) return;

    // --- 4. Faces: a quad per crossing edge (polygons where a face vertex was added). ---------
    timer = Timer();
    // Block by block: the four cells around an edge a block's cell owns are in the block or
    // in the layer at -1 of its neighbours, found once per block (kLocal places, x fastest,
    // shifted by one).
    constexpr int kLocalSide = kBlock + 1;
    constexpr int kLocal = kLocalSide * kLocalSide * kLocalSide;
    constexpr size_t kFaceGrain = 64;  // blocks
    // Each block's triangles go to a slot fixed in advance: two per crossing edge it owns,
    // and one more per face vertex in one of those edges' polygons.
    std::vector<size_t> tri_at(blocks.size() + 1, 0);
    parallel_chunks(blocks.size(), 1024, [&](size_t bb, size_t be) {
      for (size_t bi = bb; bi < be; ++bi) {
        size_t n = 0;
        for (uint32_t ci = block_cell_base[bi]; ci < block_cell_base[bi + 1]; ++ci) {
          n += 2 * size_t(table.owned[masks[ci]]);
        }
        tri_at[bi + 1] = n;
      }
    });
    for (const Split& sp : splits) ++tri_at[cell_block(size_t(sp.edge / 3)) + 1];
    for (size_t bi = 0; bi < blocks.size(); ++bi) tri_at[bi + 1] += tri_at[bi];
    reserve_huge(mesh.triangles, tri_at.back());
    mesh.triangles.resize(tri_at.back());
    // Per neighbour n (as below), the cells of a block that the faces of the block at +n
    // need: those at kBlock - 1 on each axis whose bit of n is set.
    static constexpr auto kLayer = [] {
      std::array<uint64_t, 8> layer{};
      for (int n = 0; n < 8; ++n)
        for (int l = 0; l < kBlock * kBlock * kBlock; ++l) {
          const int p[3] = {l % kBlock, (l / kBlock) % kBlock, l / (kBlock * kBlock)};
          bool keep = true;
          for (int a = 0; a < 3; ++a) keep = keep && (!((n >> a) & 1) || p[a] == kBlock - 1);
          if (keep) layer[n] |= uint64_t(1) << l;
        }
      return layer;
    }();
    // The place of the cell at bit l of the block at -n (bits of n: -1 on x, y, z) in the
    // local places (those of the block at 0 shifted by one; the block at -n's layer at 0 on
    // the axes of n's bits).
    static constexpr auto kPlaceOf = [] {
      std::array<std::array<uint8_t, kBlock * kBlock * kBlock>, 8> t{};
      for (int n = 0; n < 8; ++n)
        for (int l = 0; l < kBlock * kBlock * kBlock; ++l) {
          const int p[3] = {l % kBlock, (l / kBlock) % kBlock, l / (kBlock * kBlock)};
          int q[3];
          for (int a = 0; a < 3; ++a) q[a] = ((n >> a) & 1) ? 0 : p[a] + 1;
          t[size_t(n)][size_t(l)] = uint8_t(q[0] + kLocalSide * (q[1] + kLocalSide * q[2]));
        }
      return t;
    }();
    // The cycle's (u, v) corners behind an edge along a ((0,0), (1,0), (1,1), (0,1) on its
    // other axes b < d) as local edge bits (u | v << 1) and as local place offsets back.
    static constexpr int kCycle[4] = {0, 1, 3, 2};
    static constexpr auto kBehind = [] {
      std::array<std::array<int, 4>, 3> t{};
      constexpr int kStride[3] = {1, kLocalSide, kLocalSide * kLocalSide};
      for (int a = 0; a < 3; ++a) {
        int b = 0, d = 0;
        other_axes(a, &b, &d);
        for (int s = 0; s < 4; ++s)
          t[size_t(a)][size_t(s)] = (kCycle[s] & 1) * kStride[b] + (kCycle[s] >> 1) * kStride[d];
      }
      return t;
    }();
    const float inv_h = 1.0f / block_mesher.hmin();
    parallel_chunks(blocks.size(), kFaceGrain, [&](size_t bb, size_t be) {
      // Per place: the cell's first vertex | its mask << 32 (0: no surface cell there).
      uint64_t local[kLocal];
      for (size_t bi = bb; bi < be; ++bi) {
        if (block_cmask[bi] == 0) continue;
        std::array<uint32_t, 3>* tris = mesh.triangles.data() + tri_at[bi];
        std::fill(local, local + kLocal, uint64_t(0));
        const BlockPos& own = blocks[bi];
        for (int n = 0; n < 8; ++n) {
          // Neighbour n: -1 on each axis whose bit is set; only its cells at kBlock - 1 on
          // those axes.
          const uint32_t bq =
              index.find(own.b[0] - (n & 1), own.b[1] - ((n >> 1) & 1), own.b[2] - (n >> 2));
          if (bq == kNone) continue;
          const uint64_t cm = block_cmask[bq];
          const uint32_t c0 = block_cell_base[bq], v0 = block_vert_base[bq];
          // Where every cell of the block has one patch (almost all blocks), a cell's first
          // vertex is its rank: only the cells in the layer are visited.
          // (The block itself, n = 0, is walked in order: every cell is in its layer.)
          const bool single =
              n != 0 && block_vert_base[bq + 1] - v0 == block_cell_base[bq + 1] - c0;
          uint32_t ci = c0, v = v0;
          const uint64_t layer = single ? kLayer[n] : ~uint64_t(0);
          for (uint64_t bits = cm & layer; bits != 0; bits &= bits - 1) {
            const int l = std::countr_zero(bits);
            uint32_t vb;
            if (single) {
              ci = c0 + uint32_t(bit_count64(cm & ((uint64_t(1) << l) - 1)));
              vb = v0 + (ci - c0);
            } else {
              vb = v;
              v += uint32_t(table.ncomp[masks[ci]]);
            }
            const uint32_t mask = masks[ci];
            if (!single) ++ci;
            if ((kLayer[n] >> l) & 1) local[kPlaceOf[n][l]] = vb | (uint64_t(mask) << 32);
          }
        }
        uint32_t ci = block_cell_base[bi];
        for (uint64_t bits = block_cmask[bi]; bits != 0; bits &= bits - 1, ++ci) {
          const int l = std::countr_zero(bits);
          const int at = kPlaceOf[0][l];
          const int m = masks[ci];
          // The axes of the crossing edges the cell owns (from corner 0 to corner 1, 2, 4).
          const unsigned axes = unsigned((m ^ (m >> 1)) & 1) | unsigned(((m ^ (m >> 2)) & 1) << 1) |
                                unsigned(((m ^ (m >> 4)) & 1) << 2);
          for (unsigned bits = axes; bits != 0; bits &= bits - 1) {
            const int a = std::countr_zero(bits);
            // The cells at (u, v) behind the owner, in the cycle (0,0), (1,0), (1,1), (0,1).
            uint32_t poly[8];
            int np = 4;
            for (int s = 0; s < 4; ++s) {
              const uint64_t cj = local[at - kBehind[a][s]];
              HFRT_CHECK(cj != 0);
              const int e = a * 4 + kCycle[s];
              poly[s] = uint32_t(cj) + uint32_t(table.comp[cj >> 32][e]);
            }
            // Outward: +a when the edge's low end is inside; the cycle's normal is +a for the
            // x and z axes and -a for y.
            const bool low_inside = m & 1;
            const bool reverse = low_inside ? (a == 1) : (a != 1);
            if (reverse) std::reverse(poly, poly + 4);
            // Face vertices between consecutive patches.
            const uint64_t key = uint64_t(ci) * 3 + uint64_t(a);
            auto it = splits.empty()
                          ? splits.end()
                          : std::lower_bound(splits.begin(), splits.end(), Split{key, 0, 0, 0});
            for (; it != splits.end() && it->edge == key; ++it) {
              for (int i = 0; i < np; ++i) {
                const uint32_t pv = poly[i], qv = poly[(i + 1) % np];
                if ((pv == it->pc && qv == it->pd) || (pv == it->pd && qv == it->pc)) {
                  std::copy_backward(poly + i + 1, poly + np, poly + np + 1);
                  poly[i + 1] = it->m;
                  ++np;
                  break;
                }
              }
            }
            if (np == 4) {
              // The corners from v0, in cells (so that the products below neither underflow
              // nor overflow in single precision at any cell size).
              const Vec3 v0 = mesh.vertices[poly[0]];
              const Vec3 e1 = (mesh.vertices[poly[1]] - v0) * inv_h,
                         e2 = (mesh.vertices[poly[2]] - v0) * inv_h,
                         e3 = (mesh.vertices[poly[3]] - v0) * inv_h;
              // The diagonal whose two triangles agree best (a flat quad either way; see
              // docs/meshing.md "Not yet" for sharp edges across the cells): the larger
              // cosine between the two triangles' normals, c = d / sqrt(L) (d their dot
              // product, L the product of their squared lengths), compared as c |c|
              // cross-multiplied by the other split's L: no root and no division. (The
              // diagonals are about a third of the faces' time on the 512^3 blend; this form
              // took ~5 % off the faces.) Ties keep 0-2; a split with a degenerate triangle
              // (L = 0) counts as cosine 0.
              float d02, l02, d13, l13;
              split_products(e1, e2, e3, &d02, &l02, &d13, &l13);
              bool use13;
              if (l02 > 0 && l13 > 0) {
                // c13 > c02 + 1e-6, as c |c| with its margin 2e-6 (c near 1 where it matters).
                use13 = d13 * std::abs(d13) * l02 > d02 * std::abs(d02) * l13 + 2e-6f * l02 * l13;
              } else {
                const float c02 = l02 > 0 ? d02 / std::sqrt(l02) : 0.0f;
                const float c13 = l13 > 0 ? d13 / std::sqrt(l13) : 0.0f;
                use13 = c13 > c02 + 1e-6f;
              }
              // 1-3: the cycle from poly[1] (the triangles 1 2 3 and 1 3 0).
              const int r = use13 ? 1 : 0;
              const uint32_t q0 = poly[r], q1 = poly[r + 1], q2 = poly[r + 2],
                             q3 = poly[(r + 3) & 3];
              *tris++ = {q0, q1, q2};
              *tris++ = {q0, q2, q3};
            } else {
              // A fan from a face vertex: its diagonals end at a vertex that only this polygon
              // and the one across the split segment have. (A fan from poly[0] could join two
              // patch vertices that an edge of another quad already joins: an edge of four
              // triangles, as in the corpus's fsin model at 40 cells.)
              int apex = 0;
              while (apex < np && poly[apex] < ncellverts) ++apex;
              HFRT_CHECK(apex < np);
              std::rotate(poly, poly + apex, poly + np);
              for (int i = 1; i + 1 < np; ++i) *tris++ = {poly[0], poly[i], poly[i + 1]};
            }
          }
        }
        HFRT_CHECK(tris == mesh.triangles.data() + tri_at[bi + 1]);
      }
    });

    // Colours from s[1..3].
    if (options.colors && field.num_attributes() >= 3) {
      const int k = field.num_attributes();
      mesh.colors.assign(nverts, Vec3{1, 1, 1});
      parallel_chunks(nverts, 1024, [&](size_t vb, size_t ve) {
        const size_t n = ve - vb;
        std::vector<float> xs(n), ys(n), zs(n), s(n * k);
        for (size_t i = 0; i < n; ++i) {
          xs[i] = mesh.vertices[vb + i].x, ys[i] = mesh.vertices[vb + i].y,
          zs[i] = mesh.vertices[vb + i].z;
        }
        field.eval_attributes(n, xs.data(), ys.data(), zs.data(), s.data());
        for (size_t i = 0; i < n; ++i) {
          Vec3 col;
          for (int ch = 0; ch < 3; ++ch) {
            float v = s[ch * n + i];
            col[ch] = v == v ? std::clamp(v, 0.0f, 1.0f) : 1.0f;
          }
          mesh.colors[vb + i] = col;
        }
      });
    }
    stats.seconds_faces = timer.seconds();
    if (options.progress) options.progress(octree_blocks + 1, octree_blocks + 1);
  });
  stats.seconds_total = total_timer.seconds();
  if (stats_out) *stats_out = stats;
  return mesh;
}

}  // namespace hfrt::mesher
