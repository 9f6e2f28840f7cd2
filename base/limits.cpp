// Limits on hostile input (base/limits.h).
#include "base/limits.h"

namespace hfrt {

std::string limit_hint(std::string_view name) {
  std::string option(name);
  for (char& c : option) c = c == '_' ? '-' : c;
  const std::string n(name);
  return "raise the limit with --" + option + " N (hfrt), ModelLimits::" + n +
         " (C++), hfrt_compile_options." + n + " (C) or " + n + "= (Python); see docs/limits.md";
}

std::string check_limits(const Limits& limits) {
  auto positive = [](const char* name, int64_t v) -> std::string {
    if (v >= 1) return "";
    return std::string(name) + " must be at least 1 (got " + std::to_string(v) + ")";
  };
  if (limits.max_loop_iterations < 1 || limits.max_loop_iterations > kMaxLoopIterationsCap) {
    return "max_loop_iterations must be from 1 to " + std::to_string(kMaxLoopIterationsCap) +
           " (got " + std::to_string(limits.max_loop_iterations) + ")";
  }
  for (const auto& [name, v] :
       {std::pair<const char*, int64_t>{"max_array_size", limits.max_array_size},
        {"max_slots", limits.max_slots},
        {"max_model_size", limits.max_model_size},
        {"max_source_bytes", limits.max_source_bytes},
        {"max_mesh_bytes", limits.max_mesh_bytes},
        {"max_mesh_triangles", limits.max_mesh_triangles},
        {"max_exact_curves", limits.max_exact_curves}}) {
    std::string e = positive(name, v);
    if (!e.empty()) return e;
  }
  return "";
}

}  // namespace hfrt
