// The pruned slice (render_slice with ModelField's tapes, docs/tape_vm.md) against today's
// slice (compiled interval and f32 code, SliceOptions::prune off) on every corpus model with
// a tape and on prospero: the same image, pixel for pixel, and tapes that shrink with depth.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "app/model_field.h"
#include "hfrt/model.h"
#include "render/slice.h"

namespace hfrt::app {
namespace {

namespace fs = std::filesystem;

struct SliceCase {
  std::string file;
  float half;  ///< the region [-half, half]^2
  int size;
};

/// Both slices of one model; returns the differing pixels (-1 when the model has no tape).
long compare_slices(const SliceCase& c, size_t* root_length, size_t* deepest_average) {
  auto compiled = Model::compile_file(c.file);
  if (!compiled.ok()) return -1;
  ModelField field(*compiled.model, c.file);
  if (!field.prepare_tapes()) return -1;
  render::SliceOptions o;
  o.width = o.height = c.size;
  o.x0 = o.y0 = -c.half;
  o.x1 = o.y1 = c.half;
  o.z = 0.25f;
  o.threads = 2;
  const render::SliceResult pruned = render::render_slice(field, o);
  EXPECT_TRUE(pruned.stats.pruned) << c.file;
  o.prune = false;
  const render::SliceResult full = render::render_slice(field, o);
  EXPECT_FALSE(full.stats.pruned);
  long diff = 0;
  for (size_t p = 0; p < full.inside.size(); ++p) diff += pruned.inside[p] != full.inside[p];
  EXPECT_EQ(pruned.stats.pixels_inside, full.stats.pixels_inside) << c.file;
  *root_length = pruned.stats.root_tape_length;
  *deepest_average = 0;
  const auto& n = pruned.stats.tapes_by_level;
  for (size_t l = n.size(); l-- > 0;) {
    if (n[l] > 0) {
      *deepest_average = pruned.stats.tape_length_by_level[l] / n[l];
      break;
    }
  }
  return diff;
}

TEST(ModelFieldTapeTest, PrunedSliceEqualsSliceOnCorpus) {
  std::vector<SliceCase> cases;
  for (const auto& e : fs::recursive_directory_iterator(HFRT_CORPUS_DIR "/models")) {
    if (e.is_regular_file() && e.path().extension() == ".hf") {
      cases.push_back({e.path().string(), 4.0f, 96});
    }
  }
  std::sort(cases.begin(), cases.end(),
            [](const SliceCase& a, const SliceCase& b) { return a.file < b.file; });
  int with_tape = 0, shrunk = 0;
  for (const SliceCase& c : cases) {
    size_t root = 0, deepest = 0;
    const long diff = compare_slices(c, &root, &deepest);
    if (diff < 0) continue;
    with_tape++;
    EXPECT_EQ(diff, 0) << c.file;
    if (deepest < root) shrunk++;
  }
  std::printf("pruned slice: %d corpus models with a tape, %d with shorter leaf tapes\n", with_tape,
              shrunk);
  EXPECT_GE(with_tape, 10);
  EXPECT_GE(shrunk, with_tape / 2);
}

TEST(ModelFieldTapeTest, PrunedSliceEqualsSliceOnProspero) {
  size_t root = 0, deepest = 0;
  const long diff =
      compare_slices({HFRT_CORPUS_DIR "/bench/prospero.hf", 1.0f, 256}, &root, &deepest);
  ASSERT_GE(diff, 0) << "prospero has no tape";
  EXPECT_EQ(diff, 0);
  EXPECT_GT(root, 5000u);
  // The leaves' tapes are a small fraction of the whole program.
  EXPECT_LT(deepest * 20, root) << "deepest level average " << deepest;
}

}  // namespace
}  // namespace hfrt::app
