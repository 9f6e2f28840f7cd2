// Mesh and patch ray tracing throughput (issue 10), a timed CLI:
//   * armadillo primary rays per second, 1024^2 perspective rays on all cores, hfrt's BVH one
//     ray at a time and in packets of 4 x 2 pixels (MeshSurface::intersect_packet) and, when
//     Embree was found at configure time, Embree's rtcIntersect1 and rtcIntersect8 on the same
//     rays and packets in the same run (with the hit/miss agreement of each with hfrt's);
//   * shadow rays from every primary hit towards one light: any hit one at a time and in
//     packets of eight consecutive rays, hfrt and Embree (rtcOccluded1, rtcOccluded8);
//   * teapot frames per second, 512x512 primary rays on all cores (direct Newton ray–patch),
//     and every crossing of the same camera rays one at a time and in packets of 4 x 2
//     (PatchSurface::crossings_many), with the pixels whose crossings differ;
//   * BVH build time per million triangles (the armadillo replicated to ~1M triangles), and the
//     memory per triangle of the built MeshSurface.
// Run: build/bench/hfrt_bench_mesh [--threads T] [--frames K] [--copies C] [--out DIR]

#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "geom/bezier.h"
#include "geom/mesh.h"
#include "geom/mesh_surface.h"
#include "geom/patch_surface.h"

#ifdef HFRT_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

using namespace hfrt::geom;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
// Process CPU time (all threads): on a machine shared with other jobs, rays per CPU-second is
// the steadier figure; wall-clock rates are printed too.
double cpu_seconds() {
  return double(std::clock()) / CLOCKS_PER_SEC;
}

// A pinhole camera looking at the box from the front (-y side, z up), framing it.
struct Camera {
  Vec3 eye, forward, right, up;
  int width, height;
  Ray ray(int x, int y) const {
    const float sx = (2.0f * (x + 0.5f) / width - 1.0f);
    const float sy = (1.0f - 2.0f * (y + 0.5f) / height);
    return {eye, forward + right * sx + up * sy};
  }
};

Camera frame(const Box& b, int w, int h, Vec3 view_dir, Vec3 world_up) {
  const Vec3 c = b.center();
  const float r = 0.5f * length(b.diagonal());
  const float fov_tan = 0.45f;  // half-angle tangent
  const Vec3 f = normalize(view_dir);
  const Vec3 right = normalize(cross(f, world_up));
  const Vec3 up = cross(right, f);
  const float dist = r / fov_tan * 1.05f;
  return {c - f * dist, f, right * fov_tan, up * fov_tan, w, h};
}

// Renders one frame with `trace(ray, &t, &normal_dot)` over tiles; returns hits.
template <typename Trace>
size_t render(const Camera& cam, std::vector<float>* image, Trace&& trace) {
  image->assign(size_t(cam.width) * cam.height, 0.0f);
  return tbb::parallel_reduce(
      tbb::blocked_range2d<int>(0, cam.height, 16, 0, cam.width, 16), size_t{0},
      [&](const tbb::blocked_range2d<int>& r, size_t hits) {
        for (int y = r.rows().begin(); y != r.rows().end(); ++y)
          for (int x = r.cols().begin(); x != r.cols().end(); ++x) {
            float shade;
            if (trace(cam.ray(x, y), &shade)) {
              (*image)[size_t(y) * cam.width + x] = shade;
              ++hits;
            }
          }
        return hits;
      },
      std::plus<>());
}

// The side of a packet's pixel block: 4 x 2 = 8 rays, as Embree's rtcIntersect8 takes them.
constexpr int kPacketW = 4, kPacketH = 2;

// Renders one frame in packets of up to 4 x 2 pixels (tiles of 16 x 16):
// `trace(rays, n, shades, hit_mask)` traces n rays; returns hits.
template <typename Trace>
size_t render_packets(const Camera& cam, std::vector<float>* image, Trace&& trace) {
  image->assign(size_t(cam.width) * cam.height, 0.0f);
  return tbb::parallel_reduce(
      tbb::blocked_range2d<int>(0, cam.height, 16, 0, cam.width, 16), size_t{0},
      [&](const tbb::blocked_range2d<int>& r, size_t hits) {
        for (int y = r.rows().begin(); y < r.rows().end(); y += kPacketH)
          for (int x = r.cols().begin(); x < r.cols().end(); x += kPacketW) {
            Ray rays[kPacketW * kPacketH];
            size_t at[kPacketW * kPacketH];
            int n = 0;
            for (int dy = 0; dy < kPacketH && y + dy < r.rows().end(); ++dy)
              for (int dx = 0; dx < kPacketW && x + dx < r.cols().end(); ++dx) {
                rays[n] = cam.ray(x + dx, y + dy);
                at[n++] = size_t(y + dy) * cam.width + (x + dx);
              }
            float shade[kPacketW * kPacketH];
            const uint32_t mask = trace(rays, n, shade);
            for (int i = 0; i < n; ++i)
              if (mask >> i & 1) {
                (*image)[at[i]] = shade[i];
                ++hits;
              }
          }
        return hits;
      },
      std::plus<>());
}

// A frame's timing: `render_once` (returning the hits) once to warm up, then `frames` times.
struct FrameTiming {
  double seconds, cpu, mrays;  // per frame: wall, process CPU; rays per wall second / 1e6
  size_t hits;
};
template <typename Render>
FrameTiming time_frames(int frames, double rays, Render&& render_once) {
  render_once();
  const auto t = Clock::now();
  const double c = cpu_seconds();
  size_t hits = 0;
  for (int f = 0; f < frames; ++f) hits = render_once();
  FrameTiming r;
  r.seconds = seconds_since(t) / frames;
  r.cpu = (cpu_seconds() - c) / frames;
  r.mrays = rays / r.seconds / 1e6;
  r.hits = hits;
  return r;
}

void write_pgm(const std::string& path, const std::vector<float>& img, int w, int h) {
  std::ofstream out(path, std::ios::binary);
  out << "P5\n" << w << " " << h << "\n255\n";
  for (float v : img) out.put(static_cast<char>(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

TriangleMesh replicate(const TriangleMesh& m, int copies) {
  TriangleMesh out;
  out.source = m.source + " x" + std::to_string(copies);
  const Vec3 step{m.bounds().diagonal().x * 1.1f, 0, 0};
  for (int c = 0; c < copies; ++c) {
    const uint32_t base = static_cast<uint32_t>(out.vertices.size());
    for (Vec3 v : m.vertices)
      out.vertices.push_back(v + step * float(c % 5) + Vec3{0, 0, 150.0f * (c / 5)});
    for (auto t : m.triangles) out.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  return out;
}

#ifdef HFRT_HAVE_EMBREE
// Embree's packet of eight from n <= 8 rays (t in [0, inf)); lanes past n are invalid.
void fill_ray8(const Ray* rays, int n, RTCRay8* ray, int valid[8]) {
  for (int i = 0; i < 8; ++i) {
    const Ray& r = rays[i < n ? i : 0];
    valid[i] = i < n ? -1 : 0;
    ray->org_x[i] = r.org.x, ray->org_y[i] = r.org.y, ray->org_z[i] = r.org.z;
    ray->dir_x[i] = r.dir.x, ray->dir_y[i] = r.dir.y, ray->dir_z[i] = r.dir.z;
    ray->tnear[i] = 0, ray->tfar[i] = std::numeric_limits<float>::infinity();
    ray->mask[i] = ~0u, ray->flags[i] = 0, ray->time[i] = 0;
  }
}
#endif

}  // namespace

int main(int argc, char** argv) {
  int threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  int frames = 5, copies = 20;
  std::string out_dir;
  std::string corpus = HFRT_CORPUS_DIR;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--threads")
      threads = std::stoi(next());
    else if (a == "--frames")
      frames = std::stoi(next());
    else if (a == "--copies")
      copies = std::stoi(next());
    else if (a == "--out")
      out_dir = next();
    else if (a == "--corpus")
      corpus = next();
    else {
      std::fprintf(stderr, "usage: %s [--threads T] [--frames K] [--copies C] [--out DIR]\n",
                   argv[0]);
      return 2;
    }
  }
  if (copies < 1 || frames < 1 || threads < 1) {
    // (--copies 0 used to abort in the BVH build of an empty replicated mesh.)
    std::fprintf(stderr, "%s: --copies, --frames and --threads must be at least 1\n", argv[0]);
    return 2;
  }
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
  std::printf("threads: %d\n", threads);

  // ---- Armadillo: load + build, then primary rays.
  auto t0 = Clock::now();
  hfrt::Result<TriangleMesh> arm = load_mesh(corpus + "/meshes/armadillo.off");
  if (!arm) {
    std::fprintf(stderr, "%s\n", arm.error().message.c_str());
    return 1;
  }
  const double load_s = seconds_since(t0);
  auto surf = MeshSurface::build(*arm);
  std::printf(
      "armadillo: %zu triangles, load %.3f s, build %.3f s, %zu BVH nodes, depth %d, "
      "%.1f bytes/triangle\n",
      surf->num_triangles(), load_s, surf->stats().build_seconds, surf->nodes().size(),
      surf->stats().bvh_depth, double(surf->memory_bytes()) / surf->num_triangles());
  const int res = 1024;
  const Camera cam = frame(surf->bounds(), res, res, {0, 0, -1}, {0, 1, 0});
  std::vector<float> img;
  auto hfrt_trace = [&](const Ray& r, float* shade) {
    SurfaceHit h;
    if (!surf->intersect(r, 0, std::numeric_limits<float>::infinity(), &h)) return false;
    *shade = std::abs(dot(h.normal, normalize(r.dir)));
    return true;
  };
  const FrameTiming single =
      time_frames(frames, res * double(res), [&] { return render(cam, &img, hfrt_trace); });
  const double hfrt_s = single.seconds, hfrt_cpu = single.cpu, hfrt_mrays = single.mrays;
  const size_t hits = single.hits;
  std::printf(
      "armadillo %dx%d primary rays, hfrt:   %7.2f Mrays/s (%.1f ms/frame, %zu hits; "
      "%.2f Mrays per CPU-second)\n",
      res, res, hfrt_mrays, hfrt_s * 1e3, hits, res * double(res) / hfrt_cpu / 1e6);
  if (!out_dir.empty()) write_pgm(out_dir + "/armadillo_hfrt.pgm", img, res, res);
  std::vector<float> hfrt_img = img;
  auto count_differ = [&](const std::vector<float>& a, const std::vector<float>& b) {
    size_t d = 0;
    for (size_t i = 0; i < a.size(); ++i) d += (a[i] > 0) != (b[i] > 0);
    return d;
  };
  const std::vector<float> inf8(MeshSurface::kPacketRays, std::numeric_limits<float>::infinity());
  const std::vector<float> zero8(MeshSurface::kPacketRays, 0.0f);
  auto hfrt_trace8 = [&](const Ray* rays, int n, float* shade) {
    SurfaceHit h[MeshSurface::kPacketRays];
    const uint32_t mask = surf->intersect_packet(rays, n, zero8.data(), inf8.data(), h);
    for (int i = 0; i < n; ++i)
      if (mask >> i & 1) shade[i] = std::abs(dot(h[i].normal, normalize(rays[i].dir)));
    return mask;
  };
  const FrameTiming packets = time_frames(frames, res * double(res),
                                          [&] { return render_packets(cam, &img, hfrt_trace8); });
  const double hfrt8_s = packets.seconds, hfrt8_cpu = packets.cpu, hfrt8_mrays = packets.mrays;
  const size_t phits = packets.hits;
  std::printf(
      "armadillo %dx%d primary rays, hfrt packets of 8 (%s): %7.2f Mrays/s (%.1f ms/frame, %zu "
      "hits; %.2f Mrays per CPU-second; %.2fx the single rays' rate; pixels whose hit/miss "
      "differ from them: %zu)\n",
      res, res, MeshSurface::packets_use_avx2() ? "AVX2" : "SSE2", hfrt8_mrays, hfrt8_s * 1e3,
      phits, res * double(res) / hfrt8_cpu / 1e6, hfrt8_mrays / hfrt_mrays,
      count_differ(img, hfrt_img));

  // Kept for Embree's shadow rays (read only where Embree is installed: HFRT_HAVE_EMBREE).
  [[maybe_unused]] std::vector<Ray> shadow_rays;
  [[maybe_unused]] size_t shadow_packets = 0, shadow_blocked = 0;
  [[maybe_unused]] double hfrt_shadow1 = 0, hfrt_shadow8 = 0;
  // Shadow rays: from every primary hit (nudged off the surface along its normal) towards one
  // directional light; any hit (occluded, 4-wide BVH) against the nearest hit (intersect) and
  // the binary BVH's any hit (occluded_binary), on the same rays.
  {
    const Vec3 light = normalize(Vec3{-0.4f, 1.0f, 0.7f});
    const float bias = 1e-4f * length(surf->bounds().diagonal());
    std::vector<Ray> shadow;
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x) {
        const Ray r = cam.ray(x, y);
        SurfaceHit h;
        if (!surf->intersect(r, 0, std::numeric_limits<float>::infinity(), &h)) continue;
        Vec3 n = h.normal;
        if (dot(n, r.dir) > 0) n = -n;
        shadow.push_back({r.org + r.dir * h.t + n * bias, light});
      }
    auto time_rays = [&](auto&& query, size_t* blocked) {
      const auto ts = Clock::now();
      double c = cpu_seconds();
      *blocked = 0;
      for (int f = 0; f < frames; ++f)
        *blocked = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, shadow.size(), 256), size_t(0),
            [&](const tbb::blocked_range<size_t>& rg, size_t acc) {
              for (size_t i = rg.begin(); i != rg.end(); ++i) acc += query(shadow[i]);
              return acc;
            },
            std::plus<size_t>());
      const double wall = seconds_since(ts) / frames, cpu = (cpu_seconds() - c) / frames;
      return std::pair<double, double>{shadow.size() / wall / 1e6, shadow.size() / cpu / 1e6};
    };
    const float inf = std::numeric_limits<float>::infinity();
    size_t b_any = 0, b_near = 0, b_bin = 0;
    auto any = time_rays([&](const Ray& r) { return surf->occluded(r, 0, inf); }, &b_any);
    auto nearest = time_rays(
        [&](const Ray& r) {
          SurfaceHit h;
          return surf->intersect(r, 0, inf, &h);
        },
        &b_near);
    auto binary = time_rays([&](const Ray& r) { return surf->occluded_binary(r, 0, inf); }, &b_bin);
    // Packets of eight consecutive shadow rays (neighbouring hits of a row, in scan order).
    shadow_packets = (shadow.size() + 7) / 8;
    auto time_packets = [&](auto&& query, size_t* blocked) {
      const auto ts = Clock::now();
      double c = cpu_seconds();
      *blocked = 0;
      for (int f = 0; f < frames; ++f)
        *blocked = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, shadow_packets, 32), size_t(0),
            [&](const tbb::blocked_range<size_t>& rg, size_t acc) {
              for (size_t p = rg.begin(); p != rg.end(); ++p) {
                const int n = int(std::min<size_t>(8, shadow.size() - 8 * p));
                acc += std::popcount(query(&shadow[8 * p], n));
              }
              return acc;
            },
            std::plus<size_t>());
      const double wall = seconds_since(ts) / frames, cpu = (cpu_seconds() - c) / frames;
      return std::pair<double, double>{shadow.size() / wall / 1e6, shadow.size() / cpu / 1e6};
    };
    size_t b_pkt = 0;
    auto any8 = time_packets(
        [&](const Ray* r, int n) { return surf->occluded_packet(r, n, zero8.data(), inf8.data()); },
        &b_pkt);
    shadow_rays = shadow;
    shadow_blocked = b_any;
    std::printf(
        "armadillo shadow rays (%zu, %zu blocked): any hit %.2f Mrays/s (%.2f per CPU-second), "
        "nearest hit %.2f (%.2f), binary-BVH any hit %.2f (%.2f), any hit in packets of 8 %.2f "
        "(%.2f)%s\n",
        shadow.size(), b_any, any.first, any.second, nearest.first, nearest.second, binary.first,
        binary.second, any8.first, any8.second,
        b_any == b_near && b_any == b_bin && b_any == b_pkt ? "" : " -- DISAGREE");
    hfrt_shadow1 = any.first;
    hfrt_shadow8 = any8.first;
  }

#ifdef HFRT_HAVE_EMBREE
  {
    RTCDevice device = rtcNewDevice(nullptr);
    RTCScene scene = rtcNewScene(device);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                           RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                           arm->vertices.size()));
    for (size_t i = 0; i < arm->vertices.size(); ++i) {
      vb[3 * i] = arm->vertices[i].x, vb[3 * i + 1] = arm->vertices[i].y,
             vb[3 * i + 2] = arm->vertices[i].z;
    }
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), arm->triangles.size()));
    for (size_t i = 0; i < arm->triangles.size(); ++i)
      for (int k = 0; k < 3; ++k) ib[3 * i + k] = arm->triangles[i][k];
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    auto tb = Clock::now();
    rtcCommitScene(scene);
    const double embree_build = seconds_since(tb);
    auto embree_trace = [&](const Ray& r, float* shade) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit rh;
      rh.ray.org_x = r.org.x, rh.ray.org_y = r.org.y, rh.ray.org_z = r.org.z;
      rh.ray.dir_x = r.dir.x, rh.ray.dir_y = r.dir.y, rh.ray.dir_z = r.dir.z;
      rh.ray.tnear = 0, rh.ray.tfar = std::numeric_limits<float>::infinity();
      rh.ray.mask = ~0u, rh.ray.flags = 0, rh.ray.time = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &ctx, &rh);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
      const Vec3 n = normalize(Vec3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
      *shade = std::abs(dot(n, normalize(r.dir)));
      return true;
    };
    const FrameTiming e1 =
        time_frames(frames, res * double(res), [&] { return render(cam, &img, embree_trace); });
    const double e_s = e1.seconds, e_cpu = e1.cpu, e_mrays = e1.mrays;
    const size_t ehits = e1.hits;
    size_t differ = 0;
    for (size_t i = 0; i < img.size(); ++i) differ += (img[i] > 0) != (hfrt_img[i] > 0);
    std::printf(
        "armadillo %dx%d primary rays, Embree: %7.2f Mrays/s (%.1f ms/frame, %zu hits; "
        "%.2f Mrays per CPU-second; build %.3f s)\n",
        res, res, e_mrays, e_s * 1e3, ehits, res * double(res) / e_cpu / 1e6, embree_build);
    std::printf(
        "hfrt / Embree time ratio: %.2fx wall, %.2fx CPU (goal <= 1.5x); pixels whose "
        "hit/miss differ: %zu\n",
        e_mrays / hfrt_mrays, hfrt_cpu / e_cpu, differ);
    if (!out_dir.empty()) write_pgm(out_dir + "/armadillo_embree.pgm", img, res, res);

    // Embree's packets of eight, the same 4 x 2 pixel blocks.
    auto embree_trace8 = [&](const Ray* rays, int n, float* shade) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit8 rh;
      alignas(32) int valid[8];
      fill_ray8(rays, n, &rh.ray, valid);
      for (int i = 0; i < 8; ++i) rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect8(valid, scene, &ctx, &rh);
      uint32_t mask = 0;
      for (int i = 0; i < n; ++i) {
        if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) continue;
        const Vec3 nrm = normalize(Vec3{rh.hit.Ng_x[i], rh.hit.Ng_y[i], rh.hit.Ng_z[i]});
        shade[i] = std::abs(dot(nrm, normalize(rays[i].dir)));
        mask |= 1u << i;
      }
      return mask;
    };
    const FrameTiming e8 = time_frames(frames, res * double(res),
                                       [&] { return render_packets(cam, &img, embree_trace8); });
    const double e8_s = e8.seconds, e8_cpu = e8.cpu, e8_mrays = e8.mrays;
    const size_t e8hits = e8.hits;
    std::printf(
        "armadillo %dx%d primary rays, Embree rtcIntersect8: %7.2f Mrays/s (%.1f ms/frame, %zu "
        "hits; %.2f Mrays per CPU-second)\n",
        res, res, e8_mrays, e8_s * 1e3, e8hits, res * double(res) / e8_cpu / 1e6);
    std::printf(
        "hfrt packets / Embree packets time ratio: %.2fx wall, %.2fx CPU (goal <= 1.5x); pixels "
        "whose hit/miss differ: %zu\n",
        e8_mrays / hfrt8_mrays, hfrt8_cpu / e8_cpu, count_differ(img, hfrt_img));

    // Embree's shadow rays, one at a time and in the same packets of eight.
    auto occluded1 = [&](const Ray& r) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRay ray;
      ray.org_x = r.org.x, ray.org_y = r.org.y, ray.org_z = r.org.z;
      ray.dir_x = r.dir.x, ray.dir_y = r.dir.y, ray.dir_z = r.dir.z;
      ray.tnear = 0, ray.tfar = std::numeric_limits<float>::infinity();
      ray.mask = ~0u, ray.flags = 0, ray.time = 0;
      rtcOccluded1(scene, &ctx, &ray);
      return ray.tfar < 0;  // Embree sets tfar to -inf for an occluded ray
    };
    auto occluded8 = [&](const Ray* rays, int n) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRay8 ray;
      alignas(32) int valid[8];
      fill_ray8(rays, n, &ray, valid);
      rtcOccluded8(valid, scene, &ctx, &ray);
      uint32_t mask = 0;
      for (int i = 0; i < n; ++i) mask |= uint32_t(ray.tfar[i] < 0) << i;
      return mask;
    };
    const std::vector<Ray>& shadow = shadow_rays;
    auto time_shadow = [&](auto&& body) {
      const auto ts = Clock::now();
      size_t blocked = 0;
      for (int f = 0; f < frames; ++f) blocked = body();
      return std::pair<double, size_t>{shadow.size() / (seconds_since(ts) / frames) / 1e6, blocked};
    };
    const auto e_any1 = time_shadow([&] {
      return tbb::parallel_reduce(
          tbb::blocked_range<size_t>(0, shadow.size(), 256), size_t(0),
          [&](const tbb::blocked_range<size_t>& rg, size_t acc) {
            for (size_t i = rg.begin(); i != rg.end(); ++i) acc += occluded1(shadow[i]);
            return acc;
          },
          std::plus<size_t>());
    });
    const auto e_any8 = time_shadow([&] {
      return tbb::parallel_reduce(
          tbb::blocked_range<size_t>(0, shadow_packets, 32), size_t(0),
          [&](const tbb::blocked_range<size_t>& rg, size_t acc) {
            for (size_t p = rg.begin(); p != rg.end(); ++p) {
              const int n = int(std::min<size_t>(8, shadow.size() - 8 * p));
              acc += std::popcount(occluded8(&shadow[8 * p], n));
            }
            return acc;
          },
          std::plus<size_t>());
    });
    std::printf(
        "armadillo shadow rays, Embree: rtcOccluded1 %.2f Mrays/s (%zu blocked), rtcOccluded8 "
        "%.2f (%zu blocked); hfrt / Embree time ratio: %.2fx one at a time, %.2fx in packets "
        "(hfrt blocked %zu)\n",
        e_any1.first, e_any1.second, e_any8.first, e_any8.second, e_any1.first / hfrt_shadow1,
        e_any8.first / hfrt_shadow8, shadow_blocked);
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
#else
  std::printf("Embree: not found at configure time (install libembree-dev to compare)\n");
#endif

  // ---- Teapot: 512x512 frames per second.
  {
    hfrt::Result<PatchSet> tp = load_bpt(corpus + "/bezier/teapot.bpt");
    if (!tp) {
      std::fprintf(stderr, "%s\n", tp.error().message.c_str());
      return 1;
    }
    auto ts = PatchSurface::build(*tp);
    std::printf(
        "teapot: %zu patches, %zu flat pieces, build %.3f s (incl. field tessellation "
        "of %zu triangles, error %.2g)\n",
        tp->patches.size(), ts->num_pieces(), ts->stats().build_seconds, ts->stats().triangles,
        ts->field_error());
    const Camera tcam = frame(ts->bounds(), 512, 512, {-1, 2, -0.8f}, {0, 0, 1});
    auto patch_trace = [&](const Ray& r, float* shade) {
      SurfaceHit h;
      if (!ts->intersect(r, 0, std::numeric_limits<float>::infinity(), &h)) return false;
      *shade = std::abs(dot(h.normal, normalize(r.dir)));
      return true;
    };
    render(tcam, &img, patch_trace);
    t0 = Clock::now();
    const double c0t = cpu_seconds();
    size_t th = 0;
    for (int f = 0; f < frames; ++f) th = render(tcam, &img, patch_trace);
    const double s = seconds_since(t0) / frames;
    const double cpu = (cpu_seconds() - c0t) / frames;
    std::printf(
        "teapot 512x512 primary rays: %.1f frames/s (%.1f ms/frame, %zu hits, %.2f Mrays/s;"
        " %.1f frames per CPU-second, so %.1f frames/s on %d idle cores)\n",
        1 / s, s * 1e3, th, 512.0 * 512 / s / 1e6, 1 / cpu, threads / cpu, threads);
    if (!out_dir.empty()) write_pgm(out_dir + "/teapot.pgm", img, 512, 512);

    // Every crossing of each camera ray (what the renderer's analytic search asks a patch leaf
    // for): one ray at a time (crossings) against packets of 4 x 2 rays walked together
    // (crossings_many: geom/packet_lanes.h), the same crossings.
    auto crossing_shade = [](const std::vector<Crossing>& cr) {
      float s = float(cr.size());
      for (const Crossing& c : cr) s += c.t * 1e-3f + float(c.prim) * 1e-6f;
      return s;
    };
    auto patch_all = [&](const Ray& r, float* shade) {
      thread_local std::vector<Crossing> cr;
      ts->crossings(r, 0, std::numeric_limits<float>::infinity(), &cr);
      *shade = crossing_shade(cr);
      return !cr.empty();
    };
    auto patch_all8 = [&](const Ray* rays, int n, float* shade) {
      thread_local std::vector<Crossing> cr[kPacketW * kPacketH];
      const float inf1 = std::numeric_limits<float>::infinity();
      const float zero[8] = {}, inf[8] = {inf1, inf1, inf1, inf1, inf1, inf1, inf1, inf1};
      ts->crossings_many(rays, size_t(n), zero, inf, cr);
      uint32_t mask = 0;
      for (int i = 0; i < n; ++i) {
        shade[i] = crossing_shade(cr[i]);
        if (!cr[i].empty()) mask |= 1u << i;
      }
      return mask;
    };
    const FrameTiming one =
        time_frames(frames, 512.0 * 512, [&] { return render(tcam, &img, patch_all); });
    const std::vector<float> one_img = img;
    const FrameTiming eight =
        time_frames(frames, 512.0 * 512, [&] { return render_packets(tcam, &img, patch_all8); });
    size_t differ = 0;
    for (size_t i = 0; i < img.size(); ++i) differ += img[i] != one_img[i];
    std::printf(
        "teapot 512x512 all crossings of camera rays: one at a time %.2f Mrays/s (%.1f ms/frame), "
        "packets of 8 %.2f Mrays/s (%.1f ms/frame, %.2fx; pixels whose crossings differ: %zu)\n",
        one.mrays, one.seconds * 1e3, eight.mrays, eight.seconds * 1e3, eight.mrays / one.mrays,
        differ);
  }

  // ---- BVH build per million triangles.
  {
    const TriangleMesh big = replicate(*arm, copies);
    const double mtris = big.triangles.size() / 1e6;
    std::vector<Box> boxes(big.triangles.size());
    for (size_t i = 0; i < boxes.size(); ++i) {
      Box b;
      for (int k = 0; k < 3; ++k) b.extend(big.corner(i, k));
      boxes[i] = b;
    }
    auto tb = Clock::now();
    Bvh bvh = build_bvh(boxes);
    const double bvh_s = seconds_since(tb);
    BvhBuildOptions serial;
    serial.parallel = false;
    tb = Clock::now();
    Bvh bvh1 = build_bvh(boxes, serial);
    const double bvh1_s = seconds_since(tb);
    auto big_surf = MeshSurface::build(big);
    std::printf(
        "BVH build, %.2fM triangles: %.3f s parallel (%.3f s per million), %.3f s one "
        "thread; full MeshSurface build %.3f s (%.3f s per million), %.1f bytes/triangle\n",
        mtris, bvh_s, bvh_s / mtris, bvh1_s, big_surf->stats().build_seconds,
        big_surf->stats().build_seconds / mtris,
        double(big_surf->memory_bytes()) / big_surf->num_triangles());
    const Camera bcam = frame(big_surf->bounds(), 512, 512, {0, 0, -1}, {0, 1, 0});
    auto big_trace = [&](const Ray& r, float* shade) {
      SurfaceHit h;
      if (!big_surf->intersect(r, 0, std::numeric_limits<float>::infinity(), &h)) return false;
      *shade = std::abs(dot(h.normal, normalize(r.dir)));
      return true;
    };
    t0 = Clock::now();
    const size_t bh = render(bcam, &img, big_trace);
    const double s = seconds_since(t0);
    std::printf("%.2fM-triangle mesh 512x512: %.1f ms/frame, %zu hits, %.2f Mrays/s\n", mtris,
                s * 1e3, bh, 512.0 * 512 / s / 1e6);
    if (!out_dir.empty()) write_pgm(out_dir + "/replicated.pgm", img, 512, 512);
  }
  return 0;
}
