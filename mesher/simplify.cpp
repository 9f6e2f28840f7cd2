#include "mesher/simplify.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "base/check.h"

namespace hfrt::mesher {
namespace {

struct P3 {
  double x = 0, y = 0, z = 0;
};
P3 to_p3(Vec3 v) {
  return {v.x, v.y, v.z};
}
P3 sub(P3 a, P3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
P3 cross3(P3 a, P3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot3(P3 a, P3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

/// A symmetric 4x4 quadric: the sum of (n . p + d)^2 over a set of planes.
struct Quadric {
  double q[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0};  // xx xy xz xw yy yz yw zz zw ww
  void add_plane(P3 n, double d) {
    const double v[4] = {n.x, n.y, n.z, d};
    int k = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) q[k++] += v[i] * v[j];
  }
  Quadric& operator+=(const Quadric& o) {
    for (int i = 0; i < 10; ++i) q[i] += o.q[i];
    return *this;
  }
  double eval(P3 p) const {
    const double v[4] = {p.x, p.y, p.z, 1};
    double s = 0;
    int k = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j, ++k) s += (i == j ? 1 : 2) * q[k] * v[i] * v[j];
    return std::max(0.0, s);
  }
};

/// An edge and its place in the order of collapses when it was evaluated: `key` is its error
/// in steps of 1/1024 of the bound plus len2 / (len2 + mean len2) (in [0, 1): the shorter edge
/// first within a step; simplify.h says why). An entry is current when evaluating the edge
/// again gives the same key (a collapse into either end changes its quadric and position, and
/// pushes the edge anew): no version numbers, so an entry is 16 bytes.
struct Candidate {
  double key;
  uint32_t a, b;  // a < b; b is merged into a
  bool operator<(const Candidate& o) const {
    if (key != o.key) return key < o.key;
    if (a != o.a) return a < o.a;
    return b < o.b;
  }
};

/// A min-heap of four children per node: a node's children share a cache line (4 x 16 bytes)
/// and the tree is half as deep as a binary one. The edges come out in the order of (key,
/// a, b), as from any heap. (With std::priority_queue's binary heap of 32-byte entries, its
/// sifts' cache misses were ~70 % of a simplification: the 512^3 gyroid's 2.7M triangles
/// took 14.6 s, now 11.9 s.)
class CandidateHeap {
 public:
  bool empty() const { return h_.empty(); }
  size_t size() const { return h_.size(); }
  const Candidate& top() const { return h_.front(); }
  void push(const Candidate& c) {
    size_t i = h_.size();
    h_.push_back(c);
    while (i > 0) {
      const size_t parent = (i - 1) / 4;
      if (!(c < h_[parent])) break;
      h_[i] = h_[parent];
      i = parent;
    }
    h_[i] = c;
  }
  void pop() {
    const Candidate last = h_.back();
    h_.pop_back();
    const size_t n = h_.size();
    if (n == 0) return;
    size_t i = 0;
    while (true) {
      const size_t first = 4 * i + 1;
      if (first >= n) break;
      size_t best = first;
      const size_t end = std::min(first + 4, n);
      for (size_t k = first + 1; k < end; ++k) {
        if (h_[k] < h_[best]) best = k;
      }
      if (!(h_[best] < last)) break;
      h_[i] = h_[best];
      i = best;
    }
    h_[i] = last;
  }
  void reserve(size_t n) { h_.reserve(n); }

 private:
  std::vector<Candidate> h_;
};

}  // namespace

void simplify_mesh(TriMesh* mesh, double max_error, SimplifyStats* stats,
                   const std::function<void(size_t done, size_t total)>& progress) {
  HFRT_CHECK(max_error > 0);
  const auto t0 = std::chrono::steady_clock::now();
  const size_t nv = mesh->vertices.size(), nt = mesh->triangles.size();
  auto& tris = mesh->triangles;
  std::vector<P3> pos(nv);
  for (size_t i = 0; i < nv; ++i) pos[i] = to_p3(mesh->vertices[i]);
  std::vector<uint8_t> tri_alive(nt, 1), v_alive(nv, 1);
  std::vector<std::vector<uint32_t>> vtris(nv);
  std::vector<Quadric> quad(nv);
  for (uint32_t t = 0; t < nt; ++t) {
    const P3 a = pos[tris[t][0]], b = pos[tris[t][1]], c = pos[tris[t][2]];
    P3 n = cross3(sub(b, a), sub(c, a));
    const double len = std::sqrt(dot3(n, n));
    for (int k = 0; k < 3; ++k) vtris[tris[t][k]].push_back(t);
    if (!(len > 0)) continue;
    n = {n.x / len, n.y / len, n.z / len};
    for (int k = 0; k < 3; ++k) quad[tris[t][k]].add_plane(n, -dot3(n, a));
  }
  const double limit = max_error * max_error;
  // The order's steps of error, and its reference length: the mean squared length of each
  // triangle's first edge.
  const double quantum = limit / 1024;
  double len2_ref = 0;
  for (uint32_t t = 0; t < nt; ++t) {
    const P3 d = sub(pos[tris[t][0]], pos[tris[t][1]]);
    len2_ref += dot3(d, d);
  }
  len2_ref = nt > 0 ? len2_ref / double(nt) : 1;
  if (!(len2_ref > 0)) len2_ref = 1;
  size_t alive_tris = nt, collapses = 0;

  // The vertices sharing a live triangle with v, each once (in no particular order), marked
  // with a fresh epoch: by marks, in time linear in v's triangles, not by a sort. The order of
  // the pushes below does not change the order of the pops.
  std::vector<uint32_t> mark(nv, 0);
  uint32_t epoch = 0;
  auto new_epoch = [&]() {
    if (++epoch == 0) {  // wrapped: every old mark could match again
      std::fill(mark.begin(), mark.end(), 0u);
      epoch = 1;
    }
    return epoch;
  };
  size_t visits = 0;
  auto neighbours = [&](uint32_t v, std::vector<uint32_t>* out) {
    out->clear();
    visits += vtris[v].size();
    const uint32_t e = new_epoch();
    for (uint32_t t : vtris[v]) {
      if (!tri_alive[t]) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t u = tris[t][k];
        if (u != v && mark[u] != e) mark[u] = e, out->push_back(u);
      }
    }
  };
  // How many neighbours of b are neighbours of a, given neighbours(a, ...) just marked them
  // with epoch ea.
  auto common_neighbours = [&](uint32_t b, uint32_t ea) {
    visits += vtris[b].size();
    const uint32_t eb = new_epoch();
    int n = 0;
    for (uint32_t t : vtris[b]) {
      if (!tri_alive[t]) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t u = tris[t][k];
        if (u == b || mark[u] == eb) continue;
        n += mark[u] == ea;
        mark[u] = eb;
      }
    }
    return n;
  };
  // The key of collapsing edge (a, b) (Candidate) and where the merged vertex goes (a's
  // position, b's or the midpoint, the cheapest); true when its error is within the bound.
  auto evaluate = [&](uint32_t a, uint32_t b, Candidate* c, P3* merged = nullptr,
                      bool* at_b = nullptr) {
    if (a > b) std::swap(a, b);
    Quadric q = quad[a];
    q += quad[b];
    const P3 mid{(pos[a].x + pos[b].x) / 2, (pos[a].y + pos[b].y) / 2, (pos[a].z + pos[b].z) / 2};
    const double costs[3] = {q.eval(pos[a]), q.eval(pos[b]), q.eval(mid)};
    const int best = int(std::min_element(costs, costs + 3) - costs);
    const P3 d = sub(pos[a], pos[b]);
    const double len2 = dot3(d, d);
    *c = {std::floor(costs[best] / quantum) + len2 / (len2 + len2_ref), a, b};
    if (merged) *merged = best == 0 ? pos[a] : best == 1 ? pos[b] : mid;
    if (at_b) *at_b = best == 1;
    return costs[best] <= limit;
  };

  CandidateHeap heap;
  heap.reserve(3 * nt / 2);
  for (uint32_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = tris[t][k], b = tris[t][(k + 1) % 3];
      if (a > b) continue;  // each edge once (a closed mesh has both directions)
      Candidate c;
      if (evaluate(a, b, &c)) heap.push(c);
    }
  }

  std::vector<uint32_t> na, shared;
  size_t looked = 0;
  constexpr size_t kProgressEvery = size_t(1) << 16;  // candidates
  while (!heap.empty() && alive_tris > 4) {
    const Candidate top = heap.top();
    heap.pop();
    if (progress && ++looked % kProgressEvery == 0) progress(looked, looked + heap.size());
    const uint32_t a = top.a, b = top.b;
    if (!v_alive[a] || !v_alive[b]) continue;
    Candidate c;
    P3 np;
    bool at_b = false;
    evaluate(a, b, &c, &np, &at_b);
    if (c.key != top.key) continue;  // an end has changed since: the edge was pushed anew
    // The two triangles of the edge, and the link condition.
    shared.clear();
    for (uint32_t t : vtris[a]) {
      if (!tri_alive[t]) continue;
      if (tris[t][0] == b || tris[t][1] == b || tris[t][2] == b) shared.push_back(t);
    }
    if (shared.size() != 2) continue;
    neighbours(a, &na);
    if (common_neighbours(b, epoch) != 2) continue;
    // No triangle around a or b may turn over or collapse.
    bool ok = true;
    for (uint32_t v : {a, b}) {
      visits += vtris[v].size();
      for (uint32_t t : vtris[v]) {
        if (!ok) break;
        if (!tri_alive[t] || t == shared[0] || t == shared[1]) continue;
        P3 p[3], q[3];
        for (int k = 0; k < 3; ++k) {
          p[k] = pos[tris[t][k]];
          q[k] = (tris[t][k] == a || tris[t][k] == b) ? np : p[k];
        }
        const P3 n0 = cross3(sub(p[1], p[0]), sub(p[2], p[0]));
        const P3 n1 = cross3(sub(q[1], q[0]), sub(q[2], q[0]));
        const double l0 = std::sqrt(dot3(n0, n0)), l1 = std::sqrt(dot3(n1, n1));
        if (!(l1 > 1e-12 * l0) || dot3(n0, n1) < 0.2 * l0 * l1) ok = false;
      }
    }
    if (!ok) continue;
    // Collapse b into a.
    for (uint32_t t : shared) tri_alive[t] = 0;
    alive_tris -= 2;
    for (uint32_t t : vtris[b]) {
      if (!tri_alive[t]) continue;
      for (int k = 0; k < 3; ++k)
        if (tris[t][k] == b) tris[t][k] = a;
      vtris[a].push_back(t);
    }
    vtris[b].clear();
    std::erase_if(vtris[a], [&](uint32_t t) { return !tri_alive[t]; });
    v_alive[b] = 0;
    if (at_b && !mesh->colors.empty()) mesh->colors[a] = mesh->colors[b];
    pos[a] = np;
    quad[a] += quad[b];
    ++collapses;
    neighbours(a, &na);
    for (uint32_t n : na) {
      Candidate nc;
      if (evaluate(a, n, &nc)) heap.push(nc);
    }
  }

  if (progress) progress(looked, looked);
  // Compact: the surviving vertices in their old order, then the surviving triangles.
  std::vector<uint32_t> remap(nv, ~uint32_t(0));
  TriMesh out;
  for (uint32_t t = 0; t < nt; ++t) {
    if (!tri_alive[t]) continue;
    std::array<uint32_t, 3> tri;
    for (int k = 0; k < 3; ++k) tri[k] = tris[t][k];
    out.triangles.push_back(tri);
  }
  for (auto& tri : out.triangles) {
    for (uint32_t& v : tri) {
      if (remap[v] == ~uint32_t(0)) remap[v] = 0;  // mark used
    }
  }
  for (uint32_t v = 0; v < nv; ++v) {
    if (remap[v] == ~uint32_t(0)) continue;
    remap[v] = uint32_t(out.vertices.size());
    out.vertices.push_back({float(pos[v].x), float(pos[v].y), float(pos[v].z)});
    if (!mesh->colors.empty()) out.colors.push_back(mesh->colors[v]);
  }
  for (auto& tri : out.triangles)
    for (uint32_t& v : tri) v = remap[v];
  if (stats) {
    stats->triangles_before = nt;
    stats->triangles_after = out.triangles.size();
    stats->collapses = collapses;
    stats->triangle_visits = visits;
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  *mesh = std::move(out);
}

}  // namespace hfrt::mesher
