#pragma once
// The tile-parallel ray tracer. The image is cut into square tiles; each tile is one unit of
// work for TBB, and each worker thread owns its scratch memory (a RootSearcher, batch buffers).
// Every pixel is computed from deterministic inputs only (its position, its sample index and the
// tile it belongs to, whose layout does not depend on the thread count), so the image is
// bit-identical for any number of threads.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "render/camera.h"
#include "render/field.h"
#include "render/image.h"
#include "render/material.h"
#include "render/root_search.h"

namespace hfrt::render {

/// How rays find the surface (`--root`). kAnalytic needs Field::has_ray_candidates(); kAuto
/// picks analytic when the field has ray candidates, else interval when it has intervals, else
/// sign.
enum class RootMode { kSign, kInterval, kAuto, kAnalytic };

/// "sign", "interval", "auto" or "analytic".
const char* root_mode_name(RootMode mode);
/// The inverse of root_mode_name(); false for any other word.
bool parse_root_mode(std::string_view text, RootMode* mode);

/// Called after each finished tile with (tiles done, tiles in all). Called from worker
/// threads, concurrently: it must be thread-safe (ProgressBar is).
using ProgressFn = std::function<void(size_t done, size_t total)>;

struct RenderOptions {
  int width = 512, height = 512;
  /// The region searched for the surface; the solid is clipped to it (a ray that enters the
  /// box inside the solid hits the box face: the solid is capped, as the original polygoniser
  /// shows it).
  Box bbox{{-10, -10, -10}, {10, 10, 10}};
  Camera camera;
  RootMode root = RootMode::kAuto;
  /// Marching step in world units for the sign-change search; 0: bbox.max_extent() / 512.
  float step = 0;
  /// Root tolerance in world units; 0: bbox.max_extent() * 1e-5.
  float epsilon = 0;
  /// Samples per pixel: stratified, jittered with seeds that depend only on the pixel and the
  /// sample index. 1 sample goes through the pixel centre.
  int spp = 1;
  /// Worker threads; 0: all cores.
  int threads = 0;
  int tile_size = 16;
  /// Empty: a default key light and a fill light placed relative to the camera.
  std::vector<Light> lights;
  /// With the interval search and tile culling: evaluate the tile's intervals on tapes
  /// pruned for its culling slabs (render/tape_regions.h), where the field has tapes.
  bool pruned_tapes = true;
  /// Where the solid lies (framing's extent), when known; empty: unknown. The cell tapes of
  /// pruning (render/tape_regions.h, TapeCells) are laid over it instead of over `bbox`,
  /// which is often far larger than the solid (the default -10..10).
  Box solid_extent{{0, 0, 0}, {-1, -1, -1}};
  bool shadows = true;
  Vec3 background{0.18f, 0.2f, 0.24f};
  /// Surface colour when the model has no colour attributes.
  Vec3 albedo{0.78f, 0.76f, 0.7f};
  /// Per-tile interval culling of empty space (used only when the field has intervals).
  bool tile_culling = true;
  /// The interval search of camera rays marches to the first sample inside and bisects only
  /// what lies before it (RootSearcher::interval_search). false: the plain bisection of the
  /// whole range, whose count of interval evaluations the auto probe compares with its limit
  /// (so that its verdict on a model's enclosures does not depend on that shortcut).
  bool interval_march_first = true;
  /// With interval_march_first: each camera ray's depths are first bisected front to back by
  /// intervals (the tile's rays batched) down to RootSearcher::kPrunedSpan march steps, and
  /// the march visits only the pieces not proven outside, stopping at its first hit; false:
  /// the march covers every depth of the tile's spans up to its hit. The same proof follows
  /// either way. Pruned, a ray beside a silhouette marches nothing but the depths near the
  /// surface. It trades march samples for interval evaluations: with the bench-peers cameras
  /// (bench/README.md) renders take 28 % less time (noise), 18 % (gyroid), 12 % (twist), 9 %
  /// (csg), 3 % (blend), and 9 % more for the gallery's infinity, whose enclosures are dear.
  bool interval_pruned_march = true;
  ProgressFn progress;
  /// When set and it becomes true, the render stops: tiles not yet started are skipped (it is
  /// read once per tile), and RenderStats::cancelled tells the image is incomplete. The REPL
  /// sets it from its SIGINT handler (Ctrl-C).
  const std::atomic<bool>* cancel = nullptr;
};

struct RenderStats {
  double seconds = 0;
  /// Root mode actually used (kSign, kInterval or kAnalytic, never kAuto).
  RootMode root_used = RootMode::kSign;
  uint64_t primary_rays = 0, shadow_rays = 0, hits = 0;
  EvalCounters evals;
  size_t tiles = 0;
  /// Tiles whose whole frustum was proven empty by intervals (no per-ray search at all).
  size_t tiles_empty = 0;
  /// Thread-seconds spent in tile culling, in per-ray root search and in shading (normals,
  /// colours, shadow rays); they add up to about seconds * threads.
  double cull_seconds = 0, search_seconds = 0, shade_seconds = 0;
  /// Pruned tapes (RenderOptions::pruned_tapes): slab tapes registered and their total
  /// length; interval boxes evaluated on them and on the whole program.
  uint64_t pruned_regions = 0, pruned_region_length = 0, pruned_boxes = 0, full_boxes = 0;
  /// The render's cell tapes (render/tape_regions.h, TapeCells), where the slabs' pruning
  /// starts: cells made and their tapes' total length.
  uint64_t pruned_cells = 0, pruned_cell_length = 0;
  int threads = 0;
  /// The first point (in tile order) where F had no value, with the Field's explanation.
  bool has_nan_point = false;
  Vec3 nan_point;
  std::string nan_explanation;
  /// The render was stopped by RenderOptions::cancel: some tiles were not rendered.
  bool cancelled = false;
};

struct RenderResult {
  Image image;
  RenderStats stats;
};

/// The effective marching step and tolerance (world units) for `options`.
float effective_step(const RenderOptions& options);
float effective_epsilon(const RenderOptions& options);
/// How far along the normal a shadow ray starts from the surface point (world units).
float shadow_bias(const RenderOptions& options);

/// The shading of render(): ambient share of the albedo, then per light Lambert plus
/// Blinn-Phong with this weight and exponent (the GPU kernels shade alike: app/gpu_render).
inline constexpr float kAmbient = 0.12f;
inline constexpr float kSpecular = 0.25f;
inline constexpr float kShininess = 48.0f;

/// The default lights for a camera: a key light from the upper left behind the viewer and a
/// weaker fill light from the right.
std::vector<Light> default_lights(const CameraFrame& frame);

/// Renders `field`. The options must be valid (positive size and spp, a valid camera, a
/// non-empty bbox): the command line checks user input before calling.
RenderResult render(const Field& field, const RenderOptions& options);

/// render() into `*result`, reusing the memory of result->image when it is large enough: an
/// interactive session renders again and again, and fresh pages cost a page fault each (23 ms
/// of the 80 ms of a 512x512 frame on a VM); reused ones cost a fill.
void render_into(const Field& field, const RenderOptions& options, RenderResult* result);

}  // namespace hfrt::render
