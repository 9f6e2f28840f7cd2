// MeshSurface's ray packets (geom/mesh_packet.cpp): every packet query answers exactly what the
// single-ray query answers for each of its rays, bit for bit, in both copies of the walk
// (AVX2 and the x86-64 baseline), for coherent and incoherent packets, partial packets, rays of
// different axis permutations in one packet, empty segments, and rays exactly through vertices
// and edges (the lanes that take the scalar tie-breaking test).

#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "geom/mesh_surface.h"
#include "tests/geom/test_meshes.h"

namespace hfrt::geom {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kN = MeshSurface::kPacketRays;

uint32_t bits(float x) {
  return std::bit_cast<uint32_t>(x);
}

/// One packet's rays and segments.
struct Packet {
  std::vector<Ray> rays;
  std::vector<float> tmin, tmax;
};

/// Nearest hits at a tie of two triangles (the same t) seen by expect_packet_matches_single.
int ties = 0;

/// Every packet query against the single-ray ones, for each ray of `p`.
void expect_packet_matches_single(const MeshSurface& s, const Packet& p, const std::string& what) {
  const int n = int(p.rays.size());
  ASSERT_LE(n, kN);
  SurfaceHit hits[kN];
  const uint32_t hit_mask =
      s.intersect_packet(p.rays.data(), n, p.tmin.data(), p.tmax.data(), hits);
  const uint32_t occ_mask = s.occluded_packet(p.rays.data(), n, p.tmin.data(), p.tmax.data());
  std::vector<Crossing> cr[kN];
  s.crossings_packet(p.rays.data(), n, p.tmin.data(), p.tmax.data(), cr);
  EXPECT_EQ(hit_mask >> n, 0u) << what;
  EXPECT_EQ(occ_mask >> n, 0u) << what;
  std::vector<Crossing> single;
  for (int i = 0; i < n; ++i) {
    const std::string lane = what + " lane " + std::to_string(i);
    SurfaceHit h;
    const bool hit = s.intersect(p.rays[i], p.tmin[i], p.tmax[i], &h);
    ASSERT_EQ(bool(hit_mask >> i & 1), hit) << lane;
    s.crossings(p.rays[i], p.tmin[i], p.tmax[i], &single);
    if (hit && hits[i].prim != h.prim) {
      // Two triangles hit at exactly the same t (a ray through an edge where two faces meet at
      // an angle): either is the nearest hit, and the walks meet them in different orders.
      // The packet's must be one of them.
      EXPECT_EQ(bits(hits[i].t), bits(h.t)) << lane;
      bool tie = false;
      for (const Crossing& c : single) tie |= c.prim == hits[i].prim && c.t == h.t;
      EXPECT_TRUE(tie) << lane << ": prim " << hits[i].prim << " instead of " << h.prim;
      ties++;
    } else if (hit) {
      EXPECT_EQ(bits(hits[i].t), bits(h.t)) << lane;
      EXPECT_EQ(hits[i].prim, h.prim) << lane;
      EXPECT_EQ(bits(hits[i].u), bits(h.u)) << lane;
      EXPECT_EQ(bits(hits[i].v), bits(h.v)) << lane;
      EXPECT_EQ(bits(hits[i].normal.x), bits(h.normal.x)) << lane;
      EXPECT_EQ(bits(hits[i].normal.y), bits(h.normal.y)) << lane;
      EXPECT_EQ(bits(hits[i].normal.z), bits(h.normal.z)) << lane;
    }
    EXPECT_EQ(bool(occ_mask >> i & 1), s.occluded(p.rays[i], p.tmin[i], p.tmax[i])) << lane;
    ASSERT_EQ(cr[i].size(), single.size()) << lane;
    for (size_t k = 0; k < single.size(); ++k) {
      EXPECT_EQ(bits(cr[i][k].t), bits(single[k].t)) << lane << " crossing " << k;
      EXPECT_EQ(cr[i][k].facing, single[k].facing) << lane << " crossing " << k;
      EXPECT_EQ(cr[i][k].prim, single[k].prim) << lane << " crossing " << k;
    }
    if (::testing::Test::HasFailure()) return;
  }
}

/// Runs `body` with the packets' AVX2 copy (where the CPU has it) and with the baseline one.
template <typename Body>
void for_each_copy(Body&& body) {
  const bool avx2 = MeshSurface::packets_use_avx2();
  for (const bool use : {true, false}) {
    MeshSurface::set_packets_use_avx2(use);
    SCOPED_TRACE(MeshSurface::packets_use_avx2() ? "AVX2 copy" : "baseline copy");
    body();
    if (::testing::Test::HasFailure()) break;
  }
  MeshSurface::set_packets_use_avx2(avx2);
}

/// The camera rays of an 8 x 1 pixel row (coherent), from `eye` through a pinhole image of
/// res x res pixels that frames `box`.
Packet camera_row(const Box& box, Vec3 eye, int res, int x0, int y, int n) {
  const Vec3 c = box.center();
  const Vec3 fwd = normalize(c - eye);
  const Vec3 right = normalize(cross(fwd, Vec3{0, 1, 0}));
  const Vec3 up = cross(right, fwd);
  const float half = 0.6f * length(box.diagonal()) / length(c - eye);
  Packet p;
  for (int i = 0; i < n; ++i) {
    const float u = ((float(x0 + i) + 0.5f) / float(res) * 2 - 1) * half;
    const float v = ((float(y) + 0.5f) / float(res) * 2 - 1) * half;
    p.rays.push_back({eye, fwd + right * u + up * v});
    p.tmin.push_back(0);
    p.tmax.push_back(kInf);
  }
  return p;
}

TEST(MeshPackets, CameraRowsOfTheArmadilloEqualSingleRays) {
  const MeshSurface& s = testing::armadillo_surface();
  const Box box = s.bounds();
  // From three sides (different axis permutations), 64 x 64 pixels: every row in packets of
  // eight, and a partial packet of 5 at each row's end.
  const Vec3 c = box.center();
  const float r = length(box.diagonal());
  int hits = 0;
  for_each_copy([&] {
    for (const Vec3 eye : {c + Vec3{0.3f, 0.2f, 1.0f} * r, c + Vec3{-1.0f, 0.4f, 0.1f} * r,
                           c + Vec3{0.2f, -1.2f, 0.3f} * r})
      for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; x += kN) {
          const Packet p = camera_row(box, eye, 69, x, y, x + kN <= 64 ? kN : 5);
          expect_packet_matches_single(s, p,
                                       "row " + std::to_string(y) + " x " + std::to_string(x));
          if (::testing::Test::HasFailure()) return;
          for (const Ray& ray : p.rays) {
            SurfaceHit h;
            hits += s.intersect(ray, 0, kInf, &h);
          }
        }
  });
  EXPECT_GT(hits, 2000);  // of 2 x 3 x 64 x 64 rays: not vacuous
}

TEST(MeshPackets, IncoherentPacketsAndSegmentsEqualSingleRays) {
  const MeshSurface& s = testing::armadillo_surface();
  const Box box = s.bounds();
  const float radius = length(box.diagonal());
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> unit(0, 1);
  for_each_copy([&] {
    for (int k = 0; k < 3000; ++k) {
      // Random rays through the box from every direction (mixed permutations in a packet),
      // segments cut at random (some empty, some reversed, some starting inside the mesh), and
      // packets of every size.
      Packet p;
      const int n = 1 + k % kN;
      for (int i = 0; i < n; ++i) {
        const Vec3 org = box.center() + testing::random_direction(rng) * radius;
        const Vec3 to = testing::random_point(rng, box);
        p.rays.push_back({org, to - org});
        const float a = unit(rng), b = unit(rng);
        switch ((k + i) % 4) {
          case 0:
            p.tmin.push_back(0), p.tmax.push_back(kInf);
            break;
          case 1:
            p.tmin.push_back(a), p.tmax.push_back(a + b);
            break;
          case 2:
            p.tmin.push_back(b), p.tmax.push_back(a);  // empty when a <= b
            break;
          default:
            p.tmin.push_back(0.5f + 0.5f * a), p.tmax.push_back(2);
            break;
        }
      }
      expect_packet_matches_single(s, p, "packet " + std::to_string(k));
      if (::testing::Test::HasFailure()) return;
    }
  });
}

TEST(MeshPackets, RaysExactlyThroughVerticesAndEdges) {
  // The height-field box's vertices and edge midpoints are exact: rays through them have zero
  // edge functions, which the lanes hand to the scalar test's tie-breaking.
  const int n = 12;
  const TriangleMesh m = testing::heightfield_box(n, 5);
  const auto s = MeshSurface::build(m);
  const Vec3 dirs[] = {{0, 0, -1}, {0, 0, 1}, {1, 2, -8}, {-2, 1, -4}, {0.5f, -1, 8}, {1, 1, -4}};
  for_each_copy([&] {
    for (int d0 = 0; d0 < 6; ++d0)
      for (int j = 0; j <= 2 * n; ++j) {
        Packet p;
        for (int i = 0; i <= 2 * n; ++i) {
          const int i0 = i / 2, j0 = j / 2, i1 = (i + 1) / 2, j1 = (j + 1) / 2;
          const Vec3 q = (m.vertices[j0 * (n + 1) + i0] + m.vertices[j1 * (n + 1) + i1]) * 0.5f;
          // Two directions alternate along the packet: lanes of different permutations.
          const Vec3 d = dirs[(d0 + i % 2) % 6];
          p.rays.push_back({q - d * 16.0f, d});
          p.tmin.push_back(0);
          p.tmax.push_back(kInf);
          if (int(p.rays.size()) == kN || i == 2 * n) {
            expect_packet_matches_single(*s, p,
                                         "row " + std::to_string(j) + " to " + std::to_string(i));
            if (::testing::Test::HasFailure()) return;
            p = {};
          }
        }
      }
  });
}

TEST(MeshPackets, SingleTriangleAndEmptyPackets) {
  // A mesh whose BVH root is a leaf (no 4-wide tree): the single-ray queries answer.
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  const auto s = MeshSurface::build(m);
  Packet p;
  for (int i = 0; i < 3; ++i) {
    p.rays.push_back({{0.2f + 0.3f * float(i), 0.2f, 1}, {0, 0, -1}});
    p.tmin.push_back(0);
    p.tmax.push_back(kInf);
  }
  expect_packet_matches_single(*s, p, "one triangle");
  SurfaceHit hits[kN];
  EXPECT_EQ(s->intersect_packet(p.rays.data(), 3, p.tmin.data(), p.tmax.data(), hits), 0b011u);
  EXPECT_EQ(testing::armadillo_surface().intersect_packet(nullptr, 0, nullptr, nullptr, nullptr),
            0u);
}

}  // namespace
}  // namespace hfrt::geom
