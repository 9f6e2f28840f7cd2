// Helper of bench/mesher/mesh_vs_grid.py (hfrt mesh vs scikit-image marching cubes):
//
//   hfrt_bench_mesh_tool grid MODEL.hf x0,y0,z0,x1,y1,z1 N OUT.f32 [THREADS]
//       samples F (f32 JIT, Model::eval_batch) at the (N+1)^3 nodes of the cube grid over the
//       box (N cells along the longest side; nodes lo + i * h) and writes them as float32,
//       x index slowest (numpy shape (nx+1, ny+1, nz+1)); prints "grid NX NY NZ H SECONDS".
//   hfrt_bench_mesh_tool dist MODEL.hf MESH.{stl,ply,obj}|VERTS.f32
//       the distance of every vertex from the surface F = 0: Newton steps along the f64
//       gradient (x <- x - F g / |g|^2) until |F| stops falling; prints "dist MAX MEAN N"
//       (and how many vertices did not converge). VERTS.f32 is n*3 float32.
//   hfrt_bench_mesh_tool mesh MODEL.hf x0,y0,z0,x1,y1,z1 N [THREADS] [REPEAT]
//       runs the mesher (as `hfrt mesh --bbox BOX --resolution N`, without writing) REPEAT
//       times in one process and prints each run's phases and the minimum and median: for
//       A/B comparisons of mesher changes and for `perf record` of the mesher alone.
//
// Both with the model's own JIT, so the grid and the mesher see the same function.

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "app/mesh_job.h"
#include "geom/mesh.h"
#include "hfrt/model.h"

namespace {

bool parse_box(const char* s, double b[6]) {
  return std::sscanf(s, "%lf,%lf,%lf,%lf,%lf,%lf", &b[0], &b[1], &b[2], &b[3], &b[4], &b[5]) == 6;
}

int grid(const hfrt::Model& model, const double b[6], int n, const char* out) {
  const double ext = std::max({b[3] - b[0], b[4] - b[1], b[5] - b[2]});
  const double h = ext / n;
  int nn[3];
  for (int a = 0; a < 3; ++a) nn[a] = int(std::ceil((b[a + 3] - b[a]) / h - 1e-9)) + 1;
  const size_t plane = size_t(nn[1]) * nn[2];
  std::vector<float> values(size_t(nn[0]) * plane);
  model.prepare(hfrt::Precision::kF32);
  const auto t0 = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<int>(0, nn[0]), [&](const tbb::blocked_range<int>& r) {
    std::vector<float> xs(3 * plane);
    for (int i = r.begin(); i != r.end(); ++i) {
      for (int j = 0; j < nn[1]; ++j)
        for (int k = 0; k < nn[2]; ++k) {
          const size_t p = size_t(j) * nn[2] + k;
          xs[p] = float(b[0] + i * h);
          xs[plane + p] = float(b[1] + j * h);
          xs[2 * plane + p] = float(b[2] + k * h);
        }
      model.eval_batch(int64_t(plane), xs.data(), values.data() + size_t(i) * plane);
    }
  });
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ofstream(out, std::ios::binary)
      .write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * 4));
  std::printf("grid %d %d %d %.9g %.4f\n", nn[0], nn[1], nn[2], h, secs);
  return 0;
}

int dist(const hfrt::Model& model, const std::string& path) {
  std::vector<double> v;  // x, y, z triples
  if (path.size() > 4 && path.substr(path.size() - 4) == ".f32") {
    std::ifstream in(path, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t n = bytes.size() / 4;
    const float* f = reinterpret_cast<const float*>(bytes.data());
    v.assign(f, f + n);
  } else {
    auto mesh = hfrt::geom::load_mesh(path);
    if (!mesh.ok()) {
      std::fprintf(stderr, "%s\n", mesh.error().message.c_str());
      return 2;
    }
    for (const auto& p : mesh->vertices) v.insert(v.end(), {p.x, p.y, p.z});
  }
  const size_t n = v.size() / 3;
  std::vector<double> d(n, 0);
  std::vector<char> bad(n, 0);
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
        const size_t m = r.size();
        std::vector<double> xs(3 * m), x0(3 * m), out(4 * m);
        for (size_t i = 0; i < m; ++i)
          for (int a = 0; a < 3; ++a) xs[a * m + i] = x0[a * m + i] = v[3 * (r.begin() + i) + a];
        std::vector<double> best(m, 1e300);
        for (int it = 0; it < 30; ++it) {
          model.eval_gradient_batch(int64_t(m), xs.data(), out.data());
          for (size_t i = 0; i < m; ++i) {
            const double f = out[i], g[3] = {out[m + i], out[2 * m + i], out[3 * m + i]};
            const double g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if (!(std::abs(f) < best[i]) || !(g2 > 0)) continue;
            best[i] = std::abs(f);
            for (int a = 0; a < 3; ++a) xs[a * m + i] -= f * g[a] / g2;
          }
        }
        for (size_t i = 0; i < m; ++i) {
          double s = 0;
          for (int a = 0; a < 3; ++a)
            s += (xs[a * m + i] - x0[a * m + i]) * (xs[a * m + i] - x0[a * m + i]);
          d[r.begin() + i] = std::sqrt(s);
          bad[r.begin() + i] = !(best[i] < 1e-9);
        }
      });
  double mx = 0, sum = 0;
  size_t nbad = 0;
  for (size_t i = 0; i < n; ++i) {
    mx = std::max(mx, d[i]);
    sum += d[i];
    nbad += bad[i];
  }
  std::printf("dist %.6g %.6g %zu unconverged %zu\n", mx, n ? sum / n : 0.0, n, nbad);
  return 0;
}

int mesh(const hfrt::Model& model, const std::string& file, const double b[6], int n, int threads,
         int repeat) {
  hfrt::app::MeshJob job;
  job.model = &model;
  job.file = file;
  job.bbox = hfrt::render::Box({float(b[0]), float(b[1]), float(b[2])},
                               {float(b[3]), float(b[4]), float(b[5])});
  job.bbox_given = true;
  job.resolution = n;
  job.threads = threads;
  std::vector<double> totals;
  for (int r = 0; r < repeat; ++r) {
    hfrt::app::MeshJobResult res = hfrt::app::run_mesh_job(job);
    if (res.status != hfrt::app::MeshJobStatus::kOk) {
      std::fprintf(stderr, "%s\n", res.error.c_str());
      return 1;
    }
    const auto& s = res.stats;
    std::printf(
        "run %d: mesh %.4f s (octree %.4f, blocks %.4f, join %.4f, faces %.4f; thread-s sample "
        "%.3f, edges %.3f, vertices %.3f) %zu triangles\n",
        r, s.seconds_total, s.seconds_octree, s.seconds_blocks, s.seconds_join, s.seconds_faces,
        s.thread_seconds_sample, s.thread_seconds_edges, s.thread_seconds_vertices,
        res.mesh.triangles.size());
    totals.push_back(s.seconds_total);
  }
  std::sort(totals.begin(), totals.end());
  std::printf("mesh min %.4f median %.4f s\n", totals.front(), totals[totals.size() / 2]);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s grid MODEL BOX N OUT.f32 [THREADS] | dist MODEL MESH | mesh MODEL BOX N "
                 "[THREADS] [REPEAT]\n",
                 argv[0]);
    return 2;
  }
  const std::string mode = argv[1];
  hfrt::CompileResult compiled = hfrt::Model::compile_file(argv[2]);
  if (!compiled.model) {
    std::fputs(compiled.rendered.c_str(), stderr);
    return 1;
  }
  if (mode == "grid" && argc >= 6) {
    double b[6];
    if (!parse_box(argv[3], b)) return 2;
    const int threads = argc >= 7 ? std::atoi(argv[6]) : 0;
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
      limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    threads);
    return grid(*compiled.model, b, std::atoi(argv[4]), argv[5]);
  }
  if (mode == "dist") return dist(*compiled.model, argv[3]);
  if (mode == "mesh" && argc >= 5) {
    double b[6];
    if (!parse_box(argv[3], b)) return 2;
    return mesh(*compiled.model, argv[2], b, std::atoi(argv[4]), argc >= 6 ? std::atoi(argv[5]) : 0,
                argc >= 7 ? std::max(1, std::atoi(argv[6])) : 5);
  }
  return 2;
}
