#include "mesher/mesher.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>

#include "base/check.h"
#include "base/parallel.h"
#include "base/timer.h"

namespace hfrt::mesher {
namespace {

/// Seconds since construction (or the last restart).
struct Timer {
  Clock::time_point t0 = Clock::now();
  double seconds() const { return ms_since(t0) / 1000.0; }
};

constexpr int kBlock = 4;     // cells per block side
constexpr int kKeyBits = 21;  // bits per axis of a cell key
constexpr uint64_t kKeyMask = (uint64_t(1) << kKeyBits) - 1;
constexpr int kMaxCells = (1 << kKeyBits) - 4;
constexpr size_t kPad = 16;              // batches are padded to this many points
constexpr float kRankCutoff = 0.02f;     // eigenvalues of A^T A below this * max are dropped
constexpr int kRootSteps = 3;            // Illinois steps per crossing edge at most
constexpr float kRootTolerance = 1e-5f;  // an edge is done at |F| below this * its change
constexpr int kNewtonSteps = 10;         // gradient evaluations per vertex at most

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

void other_axes(int a, int* b, int* c) {
  *b = a == 0 ? 1 : 0;
  *c = a == 2 ? 1 : 2;
}

int edge_corner(int e, int end) {
  int a = e / 4, u = e & 1, v = (e >> 1) & 1, b, c;
  other_axes(a, &b, &c);
  return (end << a) | (u << b) | (v << c);
}

/// For every corner mask: which patch (0..3) each crossing edge belongs to, -1 for edges that
/// do not cross, and the number of patches. Faces with four crossings separate their inside
/// corners (each inside corner's two edges form one segment).
struct CubeTable {
  int8_t comp[256][12];
  int8_t ncomp[256];
  uint16_t cross[256];  // bit e: edge e crosses

  CubeTable() {
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
          int b, c;
          other_axes(a, &b, &c);
          // The face's corners in cyclic order and the edge from corner i to corner i+1.
          int corners[4] = {s << a, (s << a) | (1 << b), (s << a) | (1 << b) | (1 << c),
                            (s << a) | (1 << c)};
          int edges[4];
          for (int i = 0; i < 4; ++i) {
            int p = corners[i], q = corners[(i + 1) & 3];
            int diff = p ^ q, axis = diff == 1 ? 0 : (diff == 2 ? 1 : 2);
            int lo = p & q;  // the end with 0 on `axis`
            int o1, o2;
            other_axes(axis, &o1, &o2);
            edges[i] = axis * 4 + (((lo >> o1) & 1) | (((lo >> o2) & 1) << 1));
          }
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
    }
  }
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

  float node(int axis, int i) const { return float(lo[axis] + double(i - 1) * h[axis]); }
  Vec3 node_point(int i, int j, int k) const { return {node(0, i), node(1, j), node(2, k)}; }
  int cells(int axis) const { return n[axis] + 2; }
};

/// Fc = min(F, d) with d the distance inside the box's faces; NaN F is -inf (outside). Batches
/// are padded to a multiple of kPad with copies of the last point, so that a point's value
/// does not depend on where it sits in a batch (no scalar tail loop in the evaluator).
class Capped {
 public:
  Capped(const render::Field& field, const Box& box) : field_(field), box_(box) {}

  float box_distance(Vec3 p) const {
    return std::min({p.x - box_.lo.x, box_.hi.x - p.x, p.y - box_.lo.y, box_.hi.y - p.y,
                     p.z - box_.lo.z, box_.hi.z - p.z});
  }

  /// Fc at n points; counts NaN values of F in *nan_count when given.
  void eval(size_t n, const float* x, const float* y, const float* z, float* out,
            size_t* nan_count = nullptr) const {
    if (n == 0) return;
    thread_local std::vector<float> buf;
    const size_t m = (n + kPad - 1) / kPad * kPad;
    buf.resize(4 * m);
    float *px = buf.data(), *py = px + m, *pz = py + m, *pf = pz + m;
    std::copy(x, x + n, px);
    std::copy(y, y + n, py);
    std::copy(z, z + n, pz);
    for (size_t i = n; i < m; ++i) px[i] = x[n - 1], py[i] = y[n - 1], pz[i] = z[n - 1];
    field_.eval(m, px, py, pz, pf);
    for (size_t i = 0; i < n; ++i) {
      float f = pf[i];
      if (f != f) {
        if (nan_count) ++*nan_count;
        f = -std::numeric_limits<float>::infinity();
      }
      out[i] = std::min(f, box_distance({x[i], y[i], z[i]}));
    }
  }

  /// Fc and its gradient (pointing into the solid) at n points: the box face's where the cap
  /// is the smaller; where F has no value, -inf and a NaN gradient (no direction).
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                     Vec3* g) const {
    if (n == 0) return;
    thread_local std::vector<float> buf;
    const size_t m = (n + kPad - 1) / kPad * kPad;
    buf.resize(7 * m);
    float *px = buf.data(), *py = px + m, *pz = py + m, *pf = pz + m, *gx = pf + m, *gy = gx + m,
          *gz = gy + m;
    std::copy(x, x + n, px);
    std::copy(y, y + n, py);
    std::copy(z, z + n, pz);
    for (size_t i = n; i < m; ++i) px[i] = x[n - 1], py[i] = y[n - 1], pz[i] = z[n - 1];
    field_.eval_gradient(m, px, py, pz, pf, gx, gy, gz);
    for (size_t i = 0; i < n; ++i) {
      Vec3 p{x[i], y[i], z[i]};
      const float d[6] = {p.x - box_.lo.x, box_.hi.x - p.x, p.y - box_.lo.y,
                          box_.hi.y - p.y, p.z - box_.lo.z, box_.hi.z - p.z};
      const int k = int(std::min_element(d, d + 6) - d);
      const float fv = pf[i];
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
        f[i] = fv;
        g[i] = {gx[i], gy[i], gz[i]};
      }
    }
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

/// The point minimising sum (n_i . (x - p_i))^2 nearest the mass point, by the truncated
/// pseudo-inverse; `rank` receives the number of eigenvalues kept. When the normals are all
/// valid and within ~6 degrees of their mean (the mass point is the answer), `*flat` is set
/// to their normalised mean; otherwise it is left alone.
Vec3 solve_qef(const Vec3* p, const Vec3* nrm, int k, int* rank, Vec3* flat_normal) {
  double mass[3] = {0, 0, 0};
  for (int i = 0; i < k; ++i)
    for (int a = 0; a < 3; ++a) mass[a] += p[i][a];
  for (int a = 0; a < 3; ++a) mass[a] /= k;
  // Fast path: normals within ~6 degrees of their mean span one direction (rank 1), and the
  // least-squares point nearest the mass point is the mass point itself.
  {
    Vec3 mean{0, 0, 0};
    int valid = 0;
    for (int i = 0; i < k; ++i) {
      if (length2(nrm[i]) > 0.5f) mean += nrm[i], ++valid;
    }
    const Vec3 u = normalize(mean);
    bool flat = valid == k && length2(mean) > 0;
    for (int i = 0; i < k && flat; ++i) flat = dot(nrm[i], u) > 0.995f;
    if (flat) {
      *rank = 1;
      *flat_normal = u;
      return {float(mass[0]), float(mass[1]), float(mass[2])};
    }
  }
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

struct CellRec {
  uint64_t key;
  float f[4];  // Fc at corners 0, 1, 2 and 4: the ends of the three edges the cell owns
  uint8_t mask;
  bool operator<(const CellRec& o) const { return key < o.key; }
};

void append_cells(const float* f, const int c0[3], int nx, int ny, int nz,
                  std::vector<CellRec>* out);

/// Samples the grid nodes of the cells [c0, c1) (per axis) and appends the cells with a sign
/// change to `out`.
void sample_cells(const Capped& capped, const Grid& grid, const int c0[3], const int c1[3],
                  std::vector<CellRec>* out, size_t* nan_count) {
  const int nx = c1[0] - c0[0] + 1, ny = c1[1] - c0[1] + 1, nz = c1[2] - c0[2] + 1;
  const size_t np = size_t(nx) * ny * nz;
  thread_local std::vector<float> buf;
  buf.resize(4 * np);
  float *x = buf.data(), *y = x + np, *z = y + np, *f = z + np;
  size_t i = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int l = 0; l < nx; ++l, ++i) {
        x[i] = grid.node(0, c0[0] + l);
        y[i] = grid.node(1, c0[1] + j);
        z[i] = grid.node(2, c0[2] + k);
      }
  capped.eval(np, x, y, z, f, nan_count);
  append_cells(f, c0, nx, ny, nz, out);
}

/// Appends the cells with a sign change among nodes [c0, c0 + (nx, ny, nz)) whose values are
/// `f` (x fastest).
void append_cells(const float* f, const int c0[3], int nx, int ny, int nz,
                  std::vector<CellRec>* out) {
  // The side of every node first, then each cell's corners from it.
  const size_t np = size_t(nx) * ny * nz, sy = size_t(nx), sz = size_t(nx) * ny;
  thread_local std::vector<uint8_t> side;
  side.resize(np);
  for (size_t n = 0; n < np; ++n) side[n] = uint8_t(inside(f[n]));
  const size_t corner[8] = {0, 1, sy, sy + 1, sz, sz + 1, sz + sy, sz + sy + 1};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int l = 0; l + 1 < nx; ++l) {
        const uint8_t* s0 = side.data() + size_t(k) * sz + size_t(j) * sy + size_t(l);
        int mask = 0;
        for (int c = 0; c < 8; ++c) mask |= s0[corner[c]] << c;
        if (mask != 0 && mask != 255) {
          auto val = [&](int dl, int dj, int dk) {
            return f[size_t(k + dk) * sz + size_t(j + dj) * sy + size_t(l + dl)];
          };
          out->push_back({cell_key(c0[0] + l, c0[1] + j, c0[2] + k),
                          {val(0, 0, 0), val(1, 0, 0), val(0, 1, 0), val(0, 0, 1)},
                          uint8_t(mask)});
        }
      }
}

// The neighbours of each surface cell at 12 offsets (+x, +y, +z, +x+y, +x+z, +y+z, then the
// same negated), by merge joins of the sorted keys with themselves shifted: linear, cache
// friendly, no hashing. ~0u where the neighbour is not a surface cell.
constexpr int kOffsets[12][3] = {{1, 0, 0},  {0, 1, 0},   {0, 0, 1},   {1, 1, 0},
                                 {1, 0, 1},  {0, 1, 1},   {-1, 0, 0},  {0, -1, 0},
                                 {0, 0, -1}, {-1, -1, 0}, {-1, 0, -1}, {0, -1, -1}};
constexpr uint32_t kNone = ~uint32_t(0);

/// The offset index of u * e_b + v * e_c (b < c, u or v set), negated when `negative`.
int offset_index(int b, int c, int u, int v, bool negative) {
  int i = (u && v) ? (b == 0 ? (c == 1 ? 3 : 4) : 5) : (u ? b : c);
  return negative ? i + 6 : i;
}

struct Neighbours {
  std::vector<uint32_t> at[12];
};

Neighbours find_neighbours(const std::vector<CellRec>& cells) {
  Neighbours nb;
  par::parallel_for(12, 1, [&](size_t lo, size_t) {
    const int o = int(lo);
    std::vector<uint32_t>& out = nb.at[o];
    out.assign(cells.size(), kNone);
    size_t j = 0;
    for (size_t i = 0; i < cells.size(); ++i) {
      int c[3];
      key_cell(cells[i].key, c);
      int q[3];
      bool valid = true;
      for (int a = 0; a < 3; ++a) {
        q[a] = c[a] + kOffsets[o][a];
        valid = valid && q[a] >= 0;
      }
      if (!valid) continue;
      const uint64_t t = cell_key(q[0], q[1], q[2]);
      while (j < cells.size() && cells[j].key < t) ++j;
      if (j < cells.size() && cells[j].key == t) out[i] = uint32_t(j);
    }
  });
  return nb;
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
    struct Node {
      int b[3];
    };
    auto node_box = [&](const Node& nd, int size) {
      Vec3 lo, hi;
      for (int a = 0; a < 3; ++a) {
        int c0 = nd.b[a] * kBlock, c1 = std::min((nd.b[a] + size) * kBlock, grid.cells(a));
        lo[a] = grid.node(a, c0);
        hi[a] = grid.node(a, c1);
      }
      return Box(lo, hi);
    };
    // Per block: 0 proven outside, 1 proven inside (by the octree), 2 sampled.
    std::vector<Node> level{{{0, 0, 0}}};
    int size = root;
    std::vector<Box> boxes;
    std::vector<render::Interval> ivals;
    while (true) {
      boxes.resize(level.size());
      ivals.resize(level.size());
      for (size_t i = 0; i < level.size(); ++i) boxes[i] = node_box(level[i], size);
      parallel_chunks(level.size(), 64, [&](size_t b, size_t e) {
        capped.eval_intervals(e - b, boxes.data() + b, ivals.data() + b);
      });
      stats.octree_nodes += level.size();
      std::vector<Node> next;
      for (size_t i = 0; i < level.size(); ++i) {
        const render::Interval& iv = ivals[i];
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
      level.swap(next);
      if (size == 1) break;
      size /= 2;
    }
    stats.seconds_octree = timer.seconds();

    // --- 2. Sample the blocks' nodes: the surface cells. -------------------------------------
    timer = Timer();
    const std::vector<Node>& blocks = level;
    stats.blocks_sampled = blocks.size();
    // Every block samples the (up to) 5^3 nodes of its cells, kBatchBlocks blocks per
    // evaluation call (the per-call cost paid once), and appends its surface cells to its
    // thread's list; the lists are sorted by key afterwards, so their order does not depend
    // on the scheduling. (Neighbouring sampled blocks both evaluate their common faces: taking
    // them from each other halves the evaluations but costs more in memory traffic than it
    // saves on models whose F is cheap.)
    constexpr int kSide = kBlock + 1;
    constexpr size_t kNodes = size_t(kSide) * kSide * kSide;
    constexpr size_t kBatchBlocks = 16;
    auto block_extent = [&](size_t bi, int c0[3], int cn[3]) {
      for (int a = 0; a < 3; ++a) {
        c0[a] = blocks[bi].b[a] * kBlock;
        cn[a] = std::min(kBlock, grid.cells(a) - c0[a]);
      }
    };
    std::vector<size_t> block_nans(blocks.size(), 0);
    par::ThreadLocal<std::vector<CellRec>> thread_cells;
    const size_t kProgressBatch = 4096;
    for (size_t b0 = 0; b0 < blocks.size(); b0 += kProgressBatch) {
      const size_t b1 = std::min(blocks.size(), b0 + kProgressBatch);
      parallel_chunks(b1 - b0, kBatchBlocks, [&](size_t s, size_t e) {
        std::vector<CellRec>& out = thread_cells.local();
        thread_local std::vector<float> buf;
        const size_t cap = kNodes * kBatchBlocks;
        buf.resize(4 * cap);
        float *x = buf.data(), *y = x + cap, *z = y + cap, *f = z + cap;
        for (size_t bs = b0 + s; bs < b0 + e; bs += kBatchBlocks) {
          const size_t be = std::min(b0 + e, bs + kBatchBlocks);
          size_t np = 0;
          for (size_t bi = bs; bi < be; ++bi) {
            int c0[3], cn[3];
            block_extent(bi, c0, cn);
            for (int k = 0; k <= cn[2]; ++k)
              for (int j = 0; j <= cn[1]; ++j)
                for (int l = 0; l <= cn[0]; ++l, ++np) {
                  x[np] = grid.node(0, c0[0] + l);
                  y[np] = grid.node(1, c0[1] + j);
                  z[np] = grid.node(2, c0[2] + k);
                }
          }
          capped.eval(np, x, y, z, f, &block_nans[bs]);
          np = 0;
          for (size_t bi = bs; bi < be; ++bi) {
            int c0[3], cn[3];
            block_extent(bi, c0, cn);
            const int nx = cn[0] + 1, ny = cn[1] + 1, nz = cn[2] + 1;
            append_cells(f + np, c0, nx, ny, nz, &out);
            np += size_t(nx) * ny * nz;
          }
        }
      });
      if (options.progress) options.progress(b1, blocks.size() * 2);
    }
    std::vector<CellRec> cells;
    {
      size_t total = 0;
      thread_cells.for_each([&](std::vector<CellRec>& v) { total += v.size(); });
      cells.reserve(total);
      thread_cells.for_each([&](std::vector<CellRec>& v) {
        cells.insert(cells.end(), v.begin(), v.end());
        std::vector<CellRec>().swap(v);
      });
      for (size_t n : block_nans) stats.nan_samples += n;
    }
    par::parallel_sort(cells.begin(), cells.end());

    // Closure: every crossing edge needs its four cells (looked for from the edge's owner and
    // from the three others). A cell can be missing only where the interval and point
    // evaluators disagree about a node of a pruned block.
    Neighbours nbr;
    while (true) {
      nbr = find_neighbours(cells);
      std::vector<uint64_t> missing;
      for (size_t ci = 0; ci < cells.size(); ++ci) {
        const CellRec& cr = cells[ci];
        int c[3];
        key_cell(cr.key, c);
        for (int a = 0; a < 3; ++a) {
          if (((cr.mask >> 0) & 1) == ((cr.mask >> (1 << a)) & 1)) continue;
          int b, d;
          other_axes(a, &b, &d);
          for (int uv = 1; uv < 4; ++uv) {
            if (nbr.at[offset_index(b, d, uv & 1, uv >> 1, true)][ci] != kNone) continue;
            int q[3] = {c[0], c[1], c[2]};
            q[b] -= uv & 1;
            q[d] -= uv >> 1;
            missing.push_back(cell_key(q[0], q[1], q[2]));
          }
        }
        // And every crossing edge a cell shares needs the cell that owns it (at +u, +v).
        constexpr uint16_t kShared = 0xEEE;  // the edges with (e & 3) != 0
        for (unsigned bits = table.cross[cr.mask] & kShared; bits != 0; bits &= bits - 1) {
          const int e = std::countr_zero(bits);
          int b, d;
          other_axes(e / 4, &b, &d);
          const int u = e & 1, v = (e >> 1) & 1;
          if (nbr.at[offset_index(b, d, u, v, false)][ci] != kNone) continue;
          int q[3] = {c[0], c[1], c[2]};
          q[b] += u;
          q[d] += v;
          missing.push_back(cell_key(q[0], q[1], q[2]));
        }
      }
      if (missing.empty()) break;
      std::sort(missing.begin(), missing.end());
      missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
      stats.closure_cells += missing.size();
      std::vector<CellRec> added;
      for (uint64_t k : missing) {
        int c0[3], c1[3];
        key_cell(k, c0);
        for (int a = 0; a < 3; ++a) c1[a] = c0[a] + 1;
        size_t nan_dummy = 0;
        sample_cells(capped, grid, c0, c1, &added, &nan_dummy);
      }
      HFRT_CHECK(!added.empty());  // a missing cell has a crossing edge: it is a surface cell
      cells.insert(cells.end(), added.begin(), added.end());
      std::sort(cells.begin(), cells.end());
      cells.erase(std::unique(cells.begin(), cells.end(),
                              [](const CellRec& x, const CellRec& y) { return x.key == y.key; }),
                  cells.end());
    }
    stats.surface_cells = cells.size();
    stats.seconds_sample = timer.seconds();
    if (cells.empty()) return;

    // --- 3. Crossing edges: zero and normal. --------------------------------------------------
    timer = Timer();
    std::vector<uint32_t> edge_base(cells.size() + 1, 0);
    for (size_t i = 0; i < cells.size(); ++i) {
      const int m = cells[i].mask;
      int owned = 0;
      for (int a = 0; a < 3; ++a) owned += (m & 1) != ((m >> (1 << a)) & 1);
      edge_base[i + 1] = edge_base[i] + owned;
    }
    const size_t nedges = edge_base.back();
    stats.crossing_edges = nedges;
    std::vector<Vec3> edge_point(nedges), edge_normal(nedges);
    std::vector<float> edge_slope(nedges);  // |grad F| at the edge point
    auto owned_edge_index = [&](size_t ci, int axis) {
      const int m = cells[ci].mask;
      uint32_t idx = edge_base[ci];
      for (int a = 0; a < axis; ++a) idx += (m & 1) != ((m >> (1 << a)) & 1);
      return idx;
    };
    parallel_chunks(cells.size(), 512, [&](size_t cb, size_t ce) {
      const size_t e0 = edge_base[cb], e1 = edge_base[ce], n = e1 - e0;
      if (n == 0) return;
      std::vector<Vec3> pa(n), pb(n);
      std::vector<uint8_t> sa(n), side(n, 2);
      // Parameter t along the edge and the values at the bracket's ends.
      std::vector<float> tlo(n, 0), thi(n, 1), flo(n), fhi(n), xs(n), ys(n), zs(n), fs(n), tm(n);
      std::vector<float> vlo(n), vhi(n);  // the true values at the ends (flo, fhi get halved)
      for (size_t ci = cb; ci < ce; ++ci) {
        int c[3];
        key_cell(cells[ci].key, c);
        const int m = cells[ci].mask;
        size_t idx = edge_base[ci] - e0;
        for (int a = 0; a < 3; ++a) {
          if ((m & 1) == ((m >> (1 << a)) & 1)) continue;
          int q[3] = {c[0], c[1], c[2]};
          q[a] += 1;
          pa[idx] = grid.node_point(c[0], c[1], c[2]);
          pb[idx] = grid.node_point(q[0], q[1], q[2]);
          sa[idx] = uint8_t(m & 1);
          flo[idx] = cells[ci].f[0];
          fhi[idx] = cells[ci].f[a + 1];
          vlo[idx] = flo[idx], vhi[idx] = fhi[idx];
          ++idx;
        }
      }
      // Illinois false position (bisection where a value is not finite): superlinear on
      // smooth edges, exact in one step where F is affine along the edge (planes of CSG).
      // An edge is done once |F| at its newest point is below kRootTolerance of the change of
      // F along the edge (then ~1e-5 of the edge from the zero): after one step on a plane,
      // two on a smooth surface; only the edges not done are evaluated again.
      std::vector<float> tol(n);
      std::vector<uint32_t> active(n), next_active;
      for (size_t i = 0; i < n; ++i) {
        const float d = std::abs(vlo[i] - vhi[i]);
        tol[i] = std::isfinite(d) ? kRootTolerance * d : 0.0f;
        active[i] = uint32_t(i);
      }
      for (int it = 0; it < kRootSteps && !active.empty(); ++it) {
        const size_t na = active.size();
        for (size_t j = 0; j < na; ++j) {
          const size_t i = active[j];
          const float d = flo[i] - fhi[i];
          float t = 0.5f * (tlo[i] + thi[i]);
          if (std::isfinite(flo[i]) && std::isfinite(fhi[i]) && d != 0) {
            t = tlo[i] + (thi[i] - tlo[i]) * (flo[i] / d);
            const float lo = std::min(tlo[i], thi[i]), hi = std::max(tlo[i], thi[i]);
            if (!(t > lo && t < hi)) t = 0.5f * (tlo[i] + thi[i]);
          }
          tm[i] = t;
          const Vec3 p = pa[i] + (pb[i] - pa[i]) * t;
          xs[j] = p.x, ys[j] = p.y, zs[j] = p.z;
        }
        capped.eval(na, xs.data(), ys.data(), zs.data(), fs.data());
        next_active.clear();
        for (size_t j = 0; j < na; ++j) {
          const size_t i = active[j];
          if (!(std::abs(fs[j]) <= tol[i])) next_active.push_back(uint32_t(i));
          if (inside(fs[j]) == bool(sa[i])) {
            tlo[i] = tm[i], flo[i] = vlo[i] = fs[j];
            if (side[i] == 0) fhi[i] *= 0.5f;
            side[i] = 0;
          } else {
            thi[i] = tm[i], fhi[i] = vhi[i] = fs[j];
            if (side[i] == 1) flo[i] *= 0.5f;
            side[i] = 1;
          }
        }
        active.swap(next_active);
      }
      for (size_t i = 0; i < n; ++i) {
        // The end of the bracket with the smaller |F| (both are within the bracket).
        const float t = std::abs(vlo[i]) <= std::abs(vhi[i]) ? tlo[i] : thi[i];
        const Vec3 p = pa[i] + (pb[i] - pa[i]) * t;
        edge_point[e0 + i] = p;
        xs[i] = p.x, ys[i] = p.y, zs[i] = p.z;
      }
      std::vector<Vec3> g(n);
      capped.eval_gradient(n, xs.data(), ys.data(), zs.data(), fs.data(), g.data());
      for (size_t i = 0; i < n; ++i) {
        float l = length(g[i]);
        const bool valid = l > 0 && std::isfinite(l);
        edge_normal[e0 + i] = valid ? g[i] / l : Vec3{0, 0, 0};
        edge_slope[e0 + i] = valid ? l : 0.0f;
      }
    });
    stats.seconds_edges = timer.seconds();

    // The crossing edge (global index) of local edge `e` of cell `ci`.
    auto local_edge_index = [&](size_t ci, int e) {
      const int a = e / 4;
      if ((e & 3) == 0) return owned_edge_index(ci, a);
      int b, d;
      other_axes(a, &b, &d);
      const uint32_t owner = nbr.at[offset_index(b, d, e & 1, (e >> 1) & 1, false)][ci];
      HFRT_CHECK(owner != kNone);
      return owned_edge_index(owner, a);
    };

    // --- 4. Vertices: one per patch; then split faces; then placement. ------------------------
    timer = Timer();
    std::vector<uint32_t> vbase(cells.size() + 1, 0);
    for (size_t i = 0; i < cells.size(); ++i) vbase[i + 1] = vbase[i] + table.ncomp[cells[i].mask];
    const size_t ncellverts = vbase.back();

    // Faces where the same two patches would be joined by both segments: the segment around
    // the face's second inside corner gets a vertex of its own (between the two patches).
    struct Split {
      uint32_t edge;    // crossing edge whose quad gets the face vertex
      uint32_t pc, pd;  // the two patch vertices it goes between
      uint32_t m;       // the face vertex
      bool operator<(const Split& o) const {
        return edge < o.edge || (edge == o.edge && pc < o.pc);
      }
    };
    std::vector<Split> splits;
    std::vector<std::array<uint32_t, 2>> split_edges;  // per face vertex: its two crossing edges
    for (size_t ci = 0; ci < cells.size(); ++ci) {
      const int m = cells[ci].mask;
      for (int a = 0; a < 3; ++a) {
        int b, d;
        other_axes(a, &b, &d);
        // The +a face: corners with bit a set, in cyclic order.
        int corners[4] = {1 << a, (1 << a) | (1 << b), (1 << a) | (1 << b) | (1 << d),
                          (1 << a) | (1 << d)};
        int ins[4];
        for (int i = 0; i < 4; ++i) ins[i] = (m >> corners[i]) & 1;
        if (!(ins[0] == ins[2] && ins[1] == ins[3] && ins[0] != ins[1])) continue;
        // Local edges of this face (in this cell), edge i from corner i to corner i+1.
        int edges[4];
        for (int i = 0; i < 4; ++i) {
          int p = corners[i], q = corners[(i + 1) & 3];
          int diff = p ^ q, axis = diff == 1 ? 0 : (diff == 2 ? 1 : 2);
          int lo = p & q, o1, o2;
          other_axes(axis, &o1, &o2);
          edges[i] = axis * 4 + (((lo >> o1) & 1) | (((lo >> o2) & 1) << 1));
        }
        const int k1 = ins[0] ? 0 : 1, k2 = k1 + 2;  // the inside corners
        const int s1[2] = {edges[(k1 + 3) & 3], edges[k1]},
                  s2[2] = {edges[(k2 + 3) & 3], edges[k2]};
        if (table.comp[m][s1[0]] != table.comp[m][s2[0]]) continue;
        const uint32_t di = nbr.at[a][ci];
        HFRT_CHECK(di != kNone);
        const int md = cells[di].mask;
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
        if (table.comp[md][in_d(s1[0])] != table.comp[md][in_d(s2[0])]) continue;
        const uint32_t pc = vbase[ci] + table.comp[m][s2[0]];
        const uint32_t pd = vbase[di] + table.comp[md][in_d(s2[0])];
        const uint32_t mv = uint32_t(ncellverts + split_edges.size());
        const uint32_t ea = local_edge_index(ci, s2[0]), eb = local_edge_index(ci, s2[1]);
        split_edges.push_back({ea, eb});
        splits.push_back({ea, pc, pd, mv});
        splits.push_back({eb, pc, pd, mv});
      }
    }
    std::sort(splits.begin(), splits.end());
    stats.split_faces = split_edges.size();
    const size_t nverts = ncellverts + split_edges.size();

    // Placement, in chunks of cells: QEF, clamp, then Newton steps onto F = 0 where needed.
    mesh.vertices.assign(nverts, Vec3{0, 0, 0});
    std::vector<uint8_t> project(nverts, 0);
    std::vector<Box> vcell(nverts);
    // Flat patches (project 3): the mean edge normal and slope, for the first Newton step.
    std::vector<Vec3> vdir(nverts);
    std::vector<float> vslope(nverts);
    std::atomic<size_t> sharp{0};
    // The four patch vertices around each crossing edge, in the cycle order of kUV, written
    // by the cell at that position (each slot by exactly one cell).
    std::vector<uint32_t> quad(4 * nedges, ~uint32_t(0));
    parallel_chunks(cells.size(), 1024, [&](size_t cb, size_t ce) {
      size_t local_sharp = 0;
      Vec3 pts[12], nrm[12];
      float slp[12];
      for (size_t ci = cb; ci < ce; ++ci) {
        const int m = cells[ci].mask;
        int c[3];
        key_cell(cells[ci].key, c);
        const Box cb_box(grid.node_point(c[0], c[1], c[2]),
                         grid.node_point(c[0] + 1, c[1] + 1, c[2] + 1));
        for (int comp = 0; comp < table.ncomp[m]; ++comp) {
          int k = 0;
          for (int e = 0; e < 12; ++e) {
            if (table.comp[m][e] != comp) continue;
            const uint32_t gi = local_edge_index(ci, e);
            pts[k] = edge_point[gi];
            nrm[k] = edge_normal[gi];
            slp[k] = edge_slope[gi];
            // This cell is at (u, v) = (e & 1, e >> 1 & 1) behind the edge's owner.
            static constexpr int kSlot[4] = {0, 1, 3, 2};  // (u | v << 1) -> position in kUV
            quad[4 * size_t(gi) + kSlot[e & 3]] = vbase[ci] + uint32_t(comp);
            ++k;
          }
          int rank = 0;
          Vec3 flat{0, 0, 0};
          Vec3 v = solve_qef(pts, nrm, k, &rank, &flat);
          if (!is_finite(v)) v = cb_box.center();
          v = vmin(vmax(v, cb_box.lo), cb_box.hi);
          const uint32_t vi = vbase[ci] + comp;
          mesh.vertices[vi] = v;
          vcell[vi] = cb_box;
          project[vi] = rank <= 1 ? 2 : 1;  // 2: always; 1: only when off the surface
          if (length2(flat) > 0) {
            float sl = 0;
            for (int i = 0; i < k; ++i) sl += slp[i];
            sl /= float(k);
            if (sl > 0 && std::isfinite(sl)) {
              project[vi] = 3;  // always, first along the mean normal
              vdir[vi] = flat;
              vslope[vi] = sl;
            }
          }
          if (rank >= 2) ++local_sharp;
        }
      }
      sharp += local_sharp;
    });
    stats.sharp_vertices = sharp.load();
    for (size_t s = 0; s < split_edges.size(); ++s) {
      const Vec3 a = edge_point[split_edges[s][0]], b = edge_point[split_edges[s][1]];
      const size_t vi = ncellverts + s;
      mesh.vertices[vi] = (a + b) * 0.5f;
      Box bx;
      bx.extend(a);
      bx.extend(b);
      vcell[vi] = bx;
      project[vi] = 2;
    }
    if (options.progress) options.progress(blocks.size() + blocks.size() / 2, blocks.size() * 2);

    const float hmin = float(std::min({grid.h[0], grid.h[1], grid.h[2]}));
    const float on_surface = 1e-4f * hmin;  // a vertex this close to F = 0 stays where it is
    std::atomic<size_t> projected{0};
    // Newton steps onto F = 0. A gradient is evaluated only where a step needs a direction;
    // the point a step reaches is checked by a value alone (|F| reduced? close enough?), with
    // the gradient's length at the step's origin as the slope. A flat patch's vertex (its
    // edge normals within ~6 degrees) starts from a value alone too: its first step goes along
    // the mean edge normal with the mean edge slope, both exact to first order at the mass
    // point. Usually two values per smooth vertex, and no gradient.
    enum : uint8_t { kDone, kNeedGradient, kNeedValue, kFlatStart };
    parallel_chunks(nverts, 1024, [&](size_t vb, size_t ve) {
      const size_t n = ve - vb;
      std::vector<float> xs(n), ys(n), zs(n), fs(n);
      std::vector<Vec3> g(n), start(n), prev(n), prev_step(n);
      std::vector<uint8_t> state(n);
      std::vector<float> last_f(n, std::numeric_limits<float>::infinity()), slope(n, 0),
          scale(n, 1);
      std::vector<uint32_t> idx;
      for (size_t i = 0; i < n; ++i) {
        start[i] = mesh.vertices[vb + i];
        const uint8_t pr = project[vb + i];
        state[i] = pr == 0 ? kDone : (pr == 3 ? kFlatStart : kNeedGradient);
      }
      // A step from the current point of vertex i along `step`, from a value `f` and slope.
      auto take_step = [&](size_t i, float f, Vec3 step, float sl) {
        const size_t vi = vb + i;
        last_f[i] = std::abs(f);
        slope[i] = sl;
        prev[i] = mesh.vertices[vi];
        const float len = length(step);
        if (len > hmin) step = step * (hmin / len);
        prev_step[i] = step;
        scale[i] = 1;
        mesh.vertices[vi] = mesh.vertices[vi] + step;
        state[i] = kNeedValue;
      };
      // The vertices not done yet (shrinks each iteration; most finish after two).
      std::vector<uint32_t> live;
      for (size_t i = 0; i < n; ++i) {
        if (state[i] != kDone) live.push_back(uint32_t(i));
      }
      for (int it = 0; it < kNewtonSteps && !live.empty(); ++it) {
        const bool last = it == kNewtonSteps - 1;
        // Gradients: the first evaluation of a vertex, or a direction from an accepted point.
        idx.clear();
        for (const uint32_t i : live) {
          if (state[i] != kNeedGradient) continue;
          const Vec3 p = mesh.vertices[vb + i];
          xs[idx.size()] = p.x, ys[idx.size()] = p.y, zs[idx.size()] = p.z;
          idx.push_back(uint32_t(i));
        }
        capped.eval_gradient(idx.size(), xs.data(), ys.data(), zs.data(), fs.data(), g.data());
        for (size_t j = 0; j < idx.size(); ++j) {
          const size_t i = idx[j], vi = vb + i;
          const float g2 = length2(g[j]);
          if (!std::isfinite(fs[j]) || !(g2 > 0) || !std::isfinite(g2)) {
            mesh.vertices[vi] = start[i];  // no value or no direction: keep the QEF point
            state[i] = kDone;
            continue;
          }
          const float gl = std::sqrt(g2);
          // A first evaluation may find the vertex on the surface already; a later point
          // was checked by its value (not close enough) before its gradient was asked for.
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
          if (state[i] != kNeedValue && state[i] != kFlatStart) continue;
          const Vec3 p = mesh.vertices[vb + i];
          xs[idx.size()] = p.x, ys[idx.size()] = p.y, zs[idx.size()] = p.z;
          idx.push_back(uint32_t(i));
        }
        capped.eval(idx.size(), xs.data(), ys.data(), zs.data(), fs.data());
        for (size_t j = 0; j < idx.size(); ++j) {
          const size_t i = idx[j], vi = vb + i;
          const float af = std::abs(fs[j]);
          if (!std::isfinite(fs[j])) {
            mesh.vertices[vi] = start[i];  // no value: keep the QEF point
            state[i] = kDone;
            continue;
          }
          if (state[i] == kFlatStart) {
            const float sl = vslope[vi];
            if (af <= on_surface * sl || last) {
              state[i] = kDone;
              continue;
            }
            take_step(i, fs[j], vdir[vi] * (-fs[j] / sl), sl);
            continue;
          }
          if (!(af < last_f[i])) {
            // The step did not reduce |F| (a kink of min/max, or rounding): a shorter one
            // from the previous point, until it is too short to matter.
            scale[i] *= 0.25f;
            if (scale[i] < 1.0f / 64 || last) {
              mesh.vertices[vi] = prev[i];
              state[i] = kDone;
            } else {
              mesh.vertices[vi] = prev[i] + prev_step[i] * scale[i];
            }
            continue;
          }
          // Close enough by the slope at the step's origin (half the bound: the slope at
          // the new point may differ a little); otherwise a new direction there.
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
        const size_t vi = vb + i;
        Box near = vcell[vi];
        near.lo = near.lo - Vec3{hmin, hmin, hmin};
        near.hi = near.hi + Vec3{hmin, hmin, hmin};
        if (!near.contains(mesh.vertices[vi]) || !is_finite(mesh.vertices[vi])) {
          mesh.vertices[vi] = start[i];
        }
        const Vec3 v = mesh.vertices[vi];
        if (v.x != start[i].x || v.y != start[i].y || v.z != start[i].z) ++moved;
      }
      projected += moved;
    });
    stats.projected_vertices = projected.load();

    stats.seconds_vertices = timer.seconds();

    // --- 5. Faces: a quad per crossing edge (polygons where a face vertex was added). ---------
    timer = Timer();
    std::vector<std::vector<std::array<uint32_t, 3>>> chunk_tris;
    const size_t kFaceGrain = 2048;
    chunk_tris.resize((cells.size() + kFaceGrain - 1) / kFaceGrain);
    parallel_chunks(cells.size(), kFaceGrain, [&](size_t cb, size_t ce) {
      auto& tris = chunk_tris[cb / kFaceGrain];
      for (size_t ci = cb; ci < ce; ++ci) {
        const int m = cells[ci].mask;
        int c[3];
        key_cell(cells[ci].key, c);
        for (int a = 0; a < 3; ++a) {
          if ((m & 1) == ((m >> (1 << a)) & 1)) continue;
          const uint32_t gi = owned_edge_index(ci, a);
          int b, d;
          other_axes(a, &b, &d);
          uint32_t poly[8];
          int np = 4;
          for (int p = 0; p < 4; ++p) {
            poly[p] = quad[4 * size_t(gi) + p];
            HFRT_CHECK(poly[p] != ~uint32_t(0));
          }
          // Outward: +a when the edge's low end is inside; the cycle's normal is +a for the x
          // and z axes and -a for y.
          const bool low_inside = m & 1;
          const bool reverse = low_inside ? (a == 1) : (a != 1);
          if (reverse) std::reverse(poly, poly + 4);
          // Face vertices between consecutive patches.
          auto it = std::lower_bound(splits.begin(), splits.end(), Split{gi, 0, 0, 0});
          for (; it != splits.end() && it->edge == gi; ++it) {
            for (int i = 0; i < np; ++i) {
              const uint32_t p = poly[i], q = poly[(i + 1) % np];
              if ((p == it->pc && q == it->pd) || (p == it->pd && q == it->pc)) {
                std::copy_backward(poly + i + 1, poly + np, poly + np + 1);
                poly[i + 1] = it->m;
                ++np;
                break;
              }
            }
          }
          if (np == 4) {
            const Vec3 v0 = mesh.vertices[poly[0]], v1 = mesh.vertices[poly[1]],
                       v2 = mesh.vertices[poly[2]], v3 = mesh.vertices[poly[3]];
            // The diagonal whose two triangles agree best (a flat quad either way; on a
            // sharp edge the one along the edge).
            const Vec3 na = normalize(cross(v1 - v0, v2 - v0)),
                       nb = normalize(cross(v2 - v0, v3 - v0));
            const Vec3 nc = normalize(cross(v2 - v1, v3 - v1)),
                       nd = normalize(cross(v3 - v1, v0 - v1));
            if (dot(nc, nd) > dot(na, nb) + 1e-6f) {
              tris.push_back({poly[1], poly[2], poly[3]});
              tris.push_back({poly[1], poly[3], poly[0]});
            } else {
              tris.push_back({poly[0], poly[1], poly[2]});
              tris.push_back({poly[0], poly[2], poly[3]});
            }
          } else {
            for (int i = 1; i + 1 < np; ++i) tris.push_back({poly[0], poly[i], poly[i + 1]});
          }
        }
      }
    });
    size_t ntris = 0;
    for (auto& t : chunk_tris) ntris += t.size();
    mesh.triangles.reserve(ntris);
    for (auto& t : chunk_tris) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());

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
    if (options.progress) options.progress(blocks.size() * 2, blocks.size() * 2);
  });
  stats.seconds_total = total_timer.seconds();
  if (stats_out) *stats_out = stats;
  return mesh;
}

}  // namespace hfrt::mesher
