#pragma once
// Limits on what one model may cost to compile and evaluate (docs/limits.md), so that hostile
// or broken input (a `while` that never ends, a 10^9-element array, a 1 GB or endless mesh
// file, object calls that inline into billions of operations) stops with a clear, located
// error instead of hanging or exhausting memory. The public mirror is hfrt::ModelLimits
// (jit/include/hfrt/model.h; jit/model.cpp checks that the defaults agree).

#include <cstdint>
#include <string>
#include <string_view>

namespace hfrt {

struct Limits {
  /// While-loop iterations per evaluation of one point (all loops of the model together,
  /// inlined objects included); beyond it the point gets NaN and a LoopLimit run-time error.
  /// At most kMaxLoopIterationsCap (single-precision evaluation counts exactly up to there).
  int64_t max_loop_iterations = 1'000'000;
  /// Elements of one array: x, a and s in an object header and every `array` declaration.
  int64_t max_array_size = 8192;
  /// Slots of the lowered model: every variable and array element of the model and of every
  /// inlined object call, with their "assigned" flags.
  int64_t max_slots = 32768;
  /// Size of the model after inlining object calls and expanding library calls: expression
  /// and statement nodes lowered plus array elements copied (a call inside an object called
  /// twice counts twice; chains of such calls grow exponentially).
  int64_t max_model_size = 4'000'000;
  /// Bytes of a HyperFun source file.
  int64_t max_source_bytes = int64_t{64} << 20;
  /// Bytes of a mesh or patch file (hfMesh, hfBezierSurface).
  int64_t max_mesh_bytes = int64_t{256} << 20;
  /// Triangles, and vertices, of one mesh (hfMesh, hfTriangles); patches times their
  /// tessellation's triangles for hfBezierSurface and hfBezierPatches.
  int64_t max_mesh_triangles = 10'000'000;
  /// Open border curves of a Bézier patch set (hfBezierSurface, hfBezierPatches: after its
  /// seams cancel and its cracks seal) up to which its field is exact, from the patches;
  /// beyond, the field goes through a tessellation instead (not an error: the exact winding
  /// number visits every curve, ~13 us a point at 528; the tessellation's costs ~1 us and is
  /// off by its measured error). geom::PatchSurface::Options::max_exact_curves.
  int64_t max_exact_curves = 64;
};

/// The largest max_loop_iterations: 2^24, the last integer up to which a single-precision
/// counter counts exactly (the f32 evaluators count in f32).
inline constexpr int64_t kMaxLoopIterationsCap = int64_t{1} << 24;

/// The hint of an error that a limit caused: how to raise it, e.g. for "max_array_size": "raise
/// the limit with --max-array-size N (hfrt), ModelLimits::max_array_size (C++), ...
/// (docs/limits.md)".
std::string limit_hint(std::string_view name);

/// "" when every limit is in range, else what is wrong ("max_loop_iterations must be ...").
std::string check_limits(const Limits& limits);

}  // namespace hfrt
