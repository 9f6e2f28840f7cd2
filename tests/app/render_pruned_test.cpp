// The renderer's pruned tapes (render/tape_regions.h, RenderOptions::pruned_tapes): the
// interval search evaluates the boxes inside a tile's culling slabs on tapes pruned for them.
// Pruning only drops min/max branches the f64 interval has decided, so the enclosures, and
// with them every decision of the search, are the whole program's: the image must be the
// same pixel for pixel on every corpus model with a tape, and the boxes must actually go to
// shorter tapes.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "app/model_field.h"
#include "hfrt/model.h"
#include "render/framing.h"
#include "render/renderer.h"
#include "render/tape_regions.h"

namespace hfrt::app {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> corpus_models() {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(HFRT_CORPUS_DIR "/models")) {
    if (e.is_regular_file() && e.path().extension() == ".hf") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

render::RenderOptions framed_options(const render::Field& field, int size) {
  render::RenderOptions o;
  o.width = o.height = size;
  o.bbox = render::Box{{-4, -4, -4}, {4, 4, 4}};
  o.root = render::RootMode::kInterval;
  o.threads = 2;
  const render::Box extent = render::find_extent(field, o.bbox, 5);
  o.camera = render::resolve_camera({}, extent, 1.0f);
  return o;
}

TEST(RenderPrunedTest, PrunedTapesGiveTheWholeProgramsImageOnCorpus) {
  int with_tape = 0, pruned_models = 0;
  for (const std::string& file : corpus_models()) {
    auto compiled = Model::compile_file(file);
    if (!compiled.ok()) continue;
    ModelField field(*compiled.model, file);
    // As the renderer does (app/render_job.cpp render_field): intervals only from the
    // interval JIT; larger objects are rendered by sampling.
    if (compiled.model->interval_engine() != DomainEngine::kJit) continue;
    if (!field.has_interval() || !field.prepare_tapes()) continue;
    with_tape++;
    render::RenderOptions o = framed_options(field, 64);
    o.tile_size = 4;  // small tiles: slabs narrow enough to prune at this size
    const render::RenderResult pruned = render::render(field, o);
    o.pruned_tapes = false;
    const render::RenderResult full = render::render(field, o);
    EXPECT_EQ(full.stats.pruned_boxes, 0u) << file;
    if (pruned.stats.pruned_boxes > 0) pruned_models++;
    EXPECT_EQ(pruned.stats.hits, full.stats.hits) << file;
    size_t differ = 0;
    for (size_t i = 0; i < full.image.alpha.size(); ++i) {
      const bool same_depth =
          full.image.alpha[i] == 0 || full.image.depth[i] == pruned.image.depth[i];
      differ += full.image.alpha[i] != pruned.image.alpha[i] || !same_depth;
    }
    EXPECT_EQ(differ, 0u) << file;
    EXPECT_EQ(full.image.rgb, pruned.image.rgb) << file;
  }
  std::printf("pruned tapes: %d corpus models with a tape, %d rendered with pruned boxes\n",
              with_tape, pruned_models);
  EXPECT_GE(with_tape, 10);
  // c1_gear and c2_colonnade (10-13k boxes each at this size). A third model, hello_world,
  // had one box on a shadow bundle's tape until the interval search's shadow rays stopped
  // being culled in bundles (2026-12-07).
  EXPECT_GE(pruned_models, 2);
}

/// c1_gear (231 tape instructions) compiled, as a field with its tapes.
struct GearField {
  const std::string file =
      HFRT_CORPUS_DIR "/models/github/alexander-penev__FRep-Designer-Bench/c1_gear.hf";
  CompileResult compiled = Model::compile_file(file);
  std::unique_ptr<ModelField> field;
  GearField() {
    if (compiled.ok()) field = std::make_unique<ModelField>(*compiled.model, file);
  }
  bool ok() { return field && field->prepare_tapes(); }
};

/// The gear at 512x512 (16-pixel tiles see a tooth or two): most of its boxes go to slab tapes
/// far shorter than its program.
TEST(RenderPrunedTest, GearBoxesGoToShortTapes) {
  GearField gear;
  ASSERT_TRUE(gear.ok());
  ModelField& field = *gear.field;
  render::RenderOptions o = framed_options(field, 512);
  const render::RenderResult r = render::render(field, o);
  ASSERT_GT(r.stats.pruned_regions, 0u);
  const double average = double(r.stats.pruned_region_length) / double(r.stats.pruned_regions);
  EXPECT_LT(average, 0.35 * double(field.root_tape()->length()));
  EXPECT_GT(r.stats.pruned_boxes, 4 * r.stats.full_boxes);
}

/// The render's cell tapes are laid over the solid's extent (RenderOptions::solid_extent, what
/// framing found), not over the render box: in the default -10..10 box the gear (about 3
/// wide and flat) fits a cell or two of the box's octree, and the first slabs pruned from the
/// near-whole program (23 cells of 222 instructions at 512x512). At 256x256: 39 cells of 167
/// instructions over the solid, 15 of 224 over the box (with the shadow bundles, whose slabs
/// reached deeper cells, until 2026-12-07: 58 of 139 and 21 of 223). The image is the same
/// either way (and without pruning).
TEST(RenderPrunedTest, CellTapesCoverTheSolidNotTheWholeBox) {
  GearField gear;
  ASSERT_TRUE(gear.ok());
  ModelField& field = *gear.field;
  render::RenderOptions o;
  o.width = o.height = 256;
  o.root = render::RootMode::kInterval;
  o.threads = 2;
  const render::Box extent = render::find_extent(field, o.bbox, 6);
  o.camera = render::resolve_camera({}, extent, 1.0f);
  const render::RenderResult over_box = render::render(field, o);
  o.solid_extent = extent;
  const render::RenderResult over_solid = render::render(field, o);
  o.pruned_tapes = false;
  const render::RenderResult full = render::render(field, o);
  const double root = double(field.root_tape()->length());
  ASSERT_GT(over_solid.stats.pruned_cells, 0u);
  ASSERT_GT(over_box.stats.pruned_cells, 0u);
  const double solid_average =
      double(over_solid.stats.pruned_cell_length) / double(over_solid.stats.pruned_cells);
  const double box_average =
      double(over_box.stats.pruned_cell_length) / double(over_box.stats.pruned_cells);
  std::printf("cells over the solid: %llu of %.1f; over the box: %llu of %.1f (root %.0f)\n",
              (unsigned long long)over_solid.stats.pruned_cells, solid_average,
              (unsigned long long)over_box.stats.pruned_cells, box_average, root);
  EXPECT_GT(over_solid.stats.pruned_cells, 2 * over_box.stats.pruned_cells);
  EXPECT_LT(solid_average, 0.8 * root);
  EXPECT_LT(solid_average, 0.8 * box_average);
  EXPECT_EQ(over_solid.image.rgb, full.image.rgb);
  EXPECT_EQ(over_box.image.rgb, full.image.rgb);
}

/// TapeRegions on its own: a region's boxes are evaluated on its tape, enclosing F at points
/// of the box (sound), equal to the whole program's enclosure; other boxes go to the field.
TEST(RenderPrunedTest, RegionsEncloseTheFieldAndRouteByContainment) {
  GearField gear;
  ASSERT_TRUE(gear.ok());
  ModelField& field = *gear.field;
  render::TapeRegions regions(field);
  ASSERT_TRUE(regions.enabled());
  // A box on a tooth's flank: its interval decides nothing, so it is pruned and registered.
  const render::Box region{{0.80f, -0.10f, -0.05f}, {0.95f, 0.05f, 0.10f}};
  render::Interval iv;
  bool nan = false;
  const int node = regions.eval_prune(-1, region, &iv, &nan);
  ASSERT_GE(node, 0) << iv.lo << " " << iv.hi;
  ASSERT_EQ(regions.regions_made(), 1u);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<render::Box> boxes;
  for (int i = 0; i < 200; ++i) {
    render::Box b;
    for (int k = 0; k < 3; ++k) {
      float a = region.lo[k] + (region.hi[k] - region.lo[k]) * u(rng);
      float c = region.lo[k] + (region.hi[k] - region.lo[k]) * u(rng);
      b.lo[k] = std::min(a, c);
      b.hi[k] = std::max(a, c);
    }
    boxes.push_back(b);
  }
  boxes.push_back(render::Box{{0.0f, 0.0f, 0.0f}, {0.1f, 0.1f, 0.1f}});  // outside the region
  std::vector<render::Interval> got(boxes.size()), want(boxes.size());
  std::unique_ptr<bool[]> got_nan(new bool[boxes.size()]), want_nan(new bool[boxes.size()]);
  regions.eval_intervals(boxes.size(), boxes.data(), got.data(), got_nan.get());
  field.eval_intervals(boxes.size(), boxes.data(), want.data(), want_nan.get());
  EXPECT_EQ(regions.pruned_boxes(), 200u);
  EXPECT_EQ(regions.full_boxes(), 1u);
  for (size_t i = 0; i < boxes.size(); ++i) {
    EXPECT_EQ(got[i].lo, want[i].lo) << i;
    EXPECT_EQ(got[i].hi, want[i].hi) << i;
    const render::Box& b = boxes[i];
    float x[8], y[8], z[8], f[8];
    for (int c = 0; c < 8; ++c) {
      x[c] = c & 1 ? b.hi.x : b.lo.x;
      y[c] = c & 2 ? b.hi.y : b.lo.y;
      z[c] = c & 4 ? b.hi.z : b.lo.z;
    }
    field.eval(8, x, y, z, f);
    // The enclosure is sound for F in f64; the f32 points may round past it by an ulp or so.
    for (int c = 0; c < 8; ++c) {
      EXPECT_LE(got[i].lo, f[c] + 1e-5f) << i;
      EXPECT_GE(got[i].hi, f[c] - 1e-5f) << i;
    }
  }
  regions.clear();
  regions.eval_intervals(1, boxes.data(), got.data(), got_nan.get());
  EXPECT_EQ(regions.full_boxes(), 2u);  // no region after clear()
}

/// region_of walks the tree of prunes: a box inside a child region gets the child (whose tape
/// is its parent's pruned further), a box inside a parent but across its children gets the
/// parent, a box outside every region -1, whichever region the previous box was in.
TEST(RenderPrunedTest, RegionOfFindsTheDeepestRegionHoldingTheBox) {
  GearField gear;
  ASSERT_TRUE(gear.ok());
  render::TapeRegions regions(*gear.field);
  ASSERT_TRUE(regions.enabled());
  auto octant = [](const render::Box& b, int o) {
    render::Box c = b;
    for (int k = 0; k < 3; ++k) {
      const float m = 0.5f * (b.lo[k] + b.hi[k]);
      (o >> k & 1 ? c.lo[k] : c.hi[k]) = m;
    }
    return c;
  };
  auto shrunk = [](const render::Box& b, float f) {  // about b's centre, by the factor f
    render::Box c = b;
    for (int k = 0; k < 3; ++k) {
      const float m = 0.5f * (b.lo[k] + b.hi[k]), h = 0.5f * f * (b.hi[k] - b.lo[k]);
      c.lo[k] = m - h;
      c.hi[k] = m + h;
    }
    return c;
  };
  // Cells around the gear's rim that the interval does not decide become root regions, and
  // their octants that it does not decide either become their children.
  struct Node {
    render::Box box;
    int index;
    std::vector<std::pair<render::Box, int>> children;
  };
  std::vector<Node> roots;
  render::Interval iv;
  bool nan = false;
  const float s = 0.2f;
  for (float x = -1.2f; x < 1.2f; x += s) {
    for (float y = -1.2f; y < 1.2f; y += s) {
      const render::Box cell{{x, y, -0.1f}, {x + s, y + s, 0.1f}};
      const int node = regions.eval_prune(-1, cell, &iv, &nan);
      if (node < 0) continue;
      Node n{cell, node, {}};
      for (int o = 0; o < 8; ++o) {
        const render::Box c = octant(cell, o);
        const int child = regions.eval_prune(node, c, &iv, &nan);
        if (child != node) n.children.push_back({c, child});
      }
      roots.push_back(n);
    }
  }
  ASSERT_GE(roots.size(), 2u);
  size_t with_children = 0;
  for (const Node& n : roots) with_children += n.children.empty() ? 0 : 1;
  ASSERT_GE(with_children, 2u);
  // Visit the regions back and forth, so that the last answer is often not on the next box's
  // path.
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t i = 0; i < roots.size(); ++i) {
      const Node& n = roots[pass == 0 ? i : roots.size() - 1 - i];
      for (const auto& [box, child] : n.children) {
        EXPECT_EQ(regions.region_of(shrunk(box, 0.5f)), child);
      }
      // Across the octants' common corner: inside the cell, in no child.
      EXPECT_EQ(regions.region_of(shrunk(n.box, 0.5f)), n.index);
    }
  }
  EXPECT_EQ(regions.region_of(render::Box{{0.0f, 0.0f, 0.5f}, {0.1f, 0.1f, 0.6f}}), -1);
  EXPECT_EQ(regions.region_of(render::Box{{-1.3f, -1.3f, -0.1f}, {1.3f, 1.3f, 0.1f}}), -1);
}

/// The render's cell tapes: a box gets the tape of the deepest loose cell holding it, whose
/// interval over the box is the root tape's to the bit, from two threads at once (each with
/// its own evaluator, making cells concurrently); small boxes get cells, and so tapes shorter
/// than the program, and a box outside the cells the root tape.
TEST(RenderPrunedTest, CellTapesGiveTheRootTapesIntervals) {
  GearField gear;
  ASSERT_TRUE(gear.ok());
  ModelField& field = *gear.field;
  const render::Box bounds{{-1.6f, -1.6f, -1.6f}, {1.6f, 1.6f, 1.6f}};
  render::TapeCells cells(field, bounds);
  ASSERT_TRUE(cells.enabled());
  const render::FieldTape& root = *field.root_tape();
  auto run = [&](unsigned seed, size_t* shorter, size_t* mismatches) {
    std::unique_ptr<render::TapeEvaluator> ev = field.tape_evaluator();
    std::unique_ptr<render::TapeEvaluator> ref = field.tape_evaluator();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.8f, 1.8f), w(0.0f, 1.0f);
    for (int i = 0; i < 3000; ++i) {
      // Sizes from a hundredth of the box to more than half of it.
      const float size = 3.2f * std::pow(w(rng), 3.0f);
      render::Box b;
      for (int k = 0; k < 3; ++k) {
        const float c = u(rng), h = 0.5f * size * (0.2f + w(rng));
        b.lo[k] = c - h;
        b.hi[k] = c + h;
      }
      const render::FieldTape& tape = cells.tape_for(b, *ev);
      bool nan = false, ref_nan = false;
      const render::Interval got = ev->eval_interval(tape, b, &nan);
      const render::Interval want = ref->eval_interval(root, b, &ref_nan);
      if (!(got.lo == want.lo && got.hi == want.hi && nan == ref_nan)) ++*mismatches;
      if (tape.length() < root.length()) ++*shorter;
    }
  };
  size_t shorter[2] = {0, 0}, mismatches[2] = {0, 0};
  std::thread other(run, 11u, &shorter[1], &mismatches[1]);
  run(12u, &shorter[0], &mismatches[0]);
  other.join();
  EXPECT_EQ(mismatches[0] + mismatches[1], 0u);
  EXPECT_GT(shorter[0] + shorter[1], 3000u);
  EXPECT_GT(cells.cells_made(), 0u);
  EXPECT_LT(double(cells.cell_length_sum()) / double(cells.cells_made()), double(root.length()));
  // Outside every cell's loose box: the root tape.
  std::unique_ptr<render::TapeEvaluator> ev = field.tape_evaluator();
  const render::Box far{{5.0f, 5.0f, 5.0f}, {5.1f, 5.1f, 5.1f}};
  EXPECT_EQ(&cells.tape_for(far, *ev), &root);
}

}  // namespace
}  // namespace hfrt::app
