#pragma once
// The device check's cases (docs/gpu.md, "Device check cases"): for each corpus model, the
// model's PTX with points and the values the GPU must reproduce (the CPU f32 JIT's, and the
// same kernels run on this CPU); for a few models, the render kernel's parameters with the
// CPU renderer's image and the host-run kernel's; Prospero at 1024x1024 for the timing. The
// static runner (tools/gpu_runner) replays them on the GPU machine; scripts/gpu-check.sh
// carries both there.

#include <functional>
#include <string>
#include <vector>

#include "base/result.h"

namespace hfrt::app {

struct GpuCaseOptions {
  std::string models_dir;  ///< .hf models (recursively); machine-generated stress tests skipped
  std::string prospero;    ///< the Prospero model (empty: none)
  std::vector<std::string> render_models;  ///< rendered at render_size (paths)
  int eval_points = 16384;
  int render_size = 1024;
  std::string sm = "sm_60";
};

/// Writes one case folder per model under `out_dir` (created); `log` gets a line per case.
/// Returns the number of cases written; models the GPU cannot run are listed in the log.
Result<int> write_gpu_cases(const std::string& out_dir, const GpuCaseOptions& options,
                            const std::function<void(const std::string&)>& log);

}  // namespace hfrt::app
