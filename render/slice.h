#pragma once
// 2-D inside/outside images: a 2-D model, or the z = Z slice of a 3-D one (`hfrt slice`).
// Tile-parallel; the interval evaluator settles whole tiles (and quarter tiles, recursively)
// that are entirely inside or outside, and only the rest is evaluated pixel by pixel.

#include <cstdint>
#include <vector>

#include "render/field.h"
#include "render/renderer.h"

namespace hfrt::render {

struct SliceOptions {
  int width = 1024, height = 1024;
  /// The region shown: x in [x0, x1] left to right, y in [y0, y1] bottom to top.
  float x0 = -10, y0 = -10, x1 = 10, y1 = 10;
  float z = 0;
  int threads = 0;
  int tile_size = 32;
  /// Use intervals to fill whole (sub-)tiles when the field has them.
  bool use_interval = true;
  /// With intervals: when the field has a pruning evaluator (Field::root_tape), recurse with
  /// tapes pruned per block and evaluate leaf pixels on the shortest tape (docs/tape_vm.md).
  bool prune = true;
  ProgressFn progress;
};

struct SliceStats {
  double seconds = 0;
  EvalCounters evals;
  /// Pixels settled by an interval (without a point evaluation).
  uint64_t pixels_by_interval = 0;
  uint64_t pixels_inside = 0;
  int threads = 0;
  bool has_nan_point = false;
  Vec3 nan_point;
  std::string nan_explanation;
  /// The pruned path ran (SliceOptions::prune and a field with tapes).
  bool pruned = false;
  /// Pruned path: per recursion level (0 = the whole image), how many tapes were pruned for
  /// blocks of that level and their total length (average: total / count). Level 0's tape is
  /// the root's child for the whole image.
  std::vector<uint64_t> tapes_by_level, tape_length_by_level;
  size_t root_tape_length = 0;
};

/// One byte per pixel, row-major from the top-left: 1 inside (F >= 0), 0 outside or no value.
struct SliceResult {
  int width = 0, height = 0;
  std::vector<uint8_t> inside;
  SliceStats stats;
};

/// Pixel (i, j) samples the point at its centre: x0 + (i + 0.5) (x1 - x0) / width,
/// y1 - (j + 0.5) (y1 - y0) / height, z.
SliceResult render_slice(const Field& field, const SliceOptions& options);

}  // namespace hfrt::render
