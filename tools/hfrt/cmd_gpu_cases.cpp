// `hfrt gpu-cases OUT_DIR`: writes the device check's cases (app/gpu_cases.h, docs/gpu.md)
// for scripts/gpu-check.sh: every corpus model's PTX with points and expected values, Prospero
// at 1024x1024, and render cases. A developer's command: hidden from the help.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "app/gpu_cases.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {

namespace {
struct GpuCasesCli {
  std::string out;
  std::string corpus;  ///< --corpus, else $HFRT_CORPUS_DIR, else ../shared/corpus
  std::vector<std::string> render;
  int points = 16384;
  int size = 1024;
  std::string sm = "sm_60";
};

int run_gpu_cases(const GpuCasesCli& cli) {
  app::GpuCaseOptions o;
  std::string corpus = cli.corpus;
  if (corpus.empty())
    corpus = std::getenv("HFRT_CORPUS_DIR") ? std::getenv("HFRT_CORPUS_DIR") : "../shared/corpus";
  o.models_dir = corpus + "/models";
  o.prospero = corpus + "/bench/prospero.hf";
  o.render_models = cli.render;
  if (o.render_models.empty()) {
    o.render_models = {corpus + "/models/github/pmur002__hyperfun-report/csg.hf",
                       corpus + "/models/github/alexander-penev__FRep-Designer-Bench/c1_gear.hf"};
  }
  o.eval_points = cli.points;
  o.render_size = cli.size;
  o.sm = cli.sm;
  if (cli.points < 1 || cli.size < 1) {
    std::fprintf(stderr, "hfrt gpu-cases: --points and --size must be positive\n");
    return 2;
  }
  auto written = app::write_gpu_cases(cli.out, o, [](const std::string& line) {
    std::fprintf(stderr, "hfrt gpu-cases: %s\n", line.c_str());
  });
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt gpu-cases: %s\n", written.error().message.c_str());
    return 2;
  }
  std::fprintf(stderr, "hfrt gpu-cases: wrote %d cases to %s\n", written.value(), cli.out.c_str());
  return written.value() > 0 ? 0 : 1;
}
}  // namespace

CommandRunner register_gpu_cases(CLI::App& app) {
  auto cli = std::make_shared<GpuCasesCli>();
  CLI::App* sub = add_command(app, "gpu-cases");
  sub->add_option("out", cli->out, "folder to write the cases into")->required();
  sub->add_option("--corpus", cli->corpus,
                  "the corpus folder (default $HFRT_CORPUS_DIR, else ../shared/corpus)");
  sub->add_option("--render", cli->render, "models to make render cases of");
  sub->add_option("--points", cli->points, "points per eval case (default 16384)");
  sub->add_option("--size", cli->size, "render case size (default 1024)");
  sub->add_option("--sm", cli->sm, "GPU architecture of the PTX (default sm_60)");
  return [cli] { return run_gpu_cases(*cli); };
}

}  // namespace hfrt::tools
