// Render times of analytic scenes at 512x512 (render/renderer.h), for both root searches,
// with counters for the split of thread time between per-tile interval culling, per-ray root
// search and shading (normals, colours, shadow rays), plus Mrays/s and evaluator calls.
// The scenes are the analytic Fields of the tests, so the numbers measure the renderer, not
// an evaluator.

#include <benchmark/benchmark.h>

#include <memory>

#include "render/framing.h"
#include "render/renderer.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

std::unique_ptr<testing::AnalyticField> make_scene(int scene) {
  switch (scene) {
    case 0:
      return std::make_unique<testing::SphereField>(Vec3{0, 0, 0}, 4.0);
    case 1:
      return std::make_unique<testing::TorusField>(5.0, 1.5);
    case 2:
      return std::make_unique<testing::ShellField>(6.0, 0.01);
    default: {
      std::vector<testing::BallsField::Ball> balls;
      for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
          for (int k = -1; k <= 1; ++k) balls.push_back({Vec3(i * 5.0f, j * 5.0f, k * 5.0f), 1.8});
      return std::make_unique<testing::BallsField>(std::move(balls));
    }
  }
}

const char* kSceneNames[] = {"sphere", "torus", "thin_shell", "27_balls"};

void BM_Render(benchmark::State& state) {
  const int scene = int(state.range(0));
  const RootMode mode = state.range(1) ? RootMode::kInterval : RootMode::kSign;
  auto field = make_scene(scene);
  RenderOptions o;
  o.width = o.height = 512;
  o.root = mode;
  o.camera = resolve_camera({}, find_extent(*field, o.bbox), 1.0f);
  RenderStats last;
  for (auto _ : state) {
    RenderResult r = render(*field, o);
    last = r.stats;
    benchmark::DoNotOptimize(r.image.rgb.data());
  }
  state.SetLabel(std::string(kSceneNames[scene]) + "/" + root_mode_name(mode));
  state.counters["cull_s"] = last.cull_seconds;
  state.counters["search_s"] = last.search_seconds;
  state.counters["shade_s"] = last.shade_seconds;
  state.counters["tiles_empty"] = double(last.tiles_empty) / double(last.tiles);
  state.counters["Mrays/s"] =
      double(last.primary_rays + last.shadow_rays) / std::max(last.seconds, 1e-9) * 1e-6;
  state.counters["point_evals"] = double(last.evals.eval_points);
  state.counters["interval_evals"] = double(last.evals.interval_calls);
}

BENCHMARK(BM_Render)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->ArgNames({"scene", "interval"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

}  // namespace
}  // namespace hfrt::render

BENCHMARK_MAIN();
