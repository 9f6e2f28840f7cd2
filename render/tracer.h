#pragma once
// The scene tracer: recursive (Whitted) ray tracing of several placed objects with materials,
// and the distribution effects that follow from sampling (sphere lights: soft shadows; a thin
// lens: depth of field; roughness: glossy reflection and refraction; adaptive sampling).
//
// Work is organised as in render/renderer.h: square tiles, one unit of work each, every pixel
// computed from deterministic inputs only (its position, its sample index, the bounce), so the
// image is bit-identical for any thread count. Inside a tile the rays advance as a wavefront:
// all camera rays of the tile are searched, shaded and turned into the next generation of
// reflected and refracted rays, which are searched together, and so on to max_depth. Every
// generation (and every batch of shadow rays) goes through the same fast paths as camera rays
// (the batched interval search, the analytic candidates, the BVHs of mesh and patch leaves),
// object by object, so that incoherent secondary rays still reach the evaluators in batches.
//
// Each object is a Field in its own (object) space, capped at its box like a single-model
// render, and placed by a similarity transform (uniform scale, rotation, translation). A ray
// that starts inside a solid (a refracted ray) finds where it leaves it by searching -F, with
// the same method as the object's entries.

#include <atomic>
#include <cstdint>
#include <vector>

#include "render/camera.h"
#include "render/field.h"
#include "render/image.h"
#include "render/material.h"
#include "render/renderer.h"
#include "render/root_search.h"

namespace hfrt::render {

/// Object-to-world placement: p_world = R (scale p_object) + translate, with R the rotation
/// about x, then y, then z (degrees), as the scene file and POV-Ray's `rotate <x, y, z>` do it.
/// Uniform scale keeps ray parameters equal in both spaces (the object-space direction is not
/// unit length) and normals a rotation of object-space normals.
class Transform {
 public:
  Transform() = default;
  /// Scale first, then rotate (degrees about x, y, z in that order), then translate.
  static Transform from_srt(float scale, Vec3 rotate_deg, Vec3 translate);

  Vec3 point_to_world(Vec3 p) const;
  Vec3 point_to_object(Vec3 p) const;
  /// R^T d / scale: a world direction in object space (ray parameters stay the same).
  Vec3 direction_to_object(Vec3 d) const;
  /// R n: an object-space normal in world space (unit when n is).
  Vec3 normal_to_world(Vec3 n) const;
  float scale() const { return scale_; }
  /// The axis-aligned world box enclosing the transformed `box`.
  Box box_to_world(const Box& box) const;

 private:
  float scale_ = 1;
  float r_[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major R
  Vec3 t_{0, 0, 0};
};

/// One placed object of a scene.
struct SceneObject {
  const Field* field = nullptr;  ///< object space; must outlive the trace
  Box bbox;                      ///< object space; the solid is capped at it
  Transform transform;
  int material = 0;  ///< index into the materials given to trace()
  /// How rays find this object's surface. kAuto: analytic when the field lists ray candidates,
  /// else interval when it has intervals, else sign.
  RootMode root = RootMode::kAuto;
  /// Marching step and root tolerance in object units; 0: bbox.max_extent() / 512 and
  /// bbox.max_extent() * 1e-5, as for a single-model render.
  float step = 0, epsilon = 0;
};

struct TraceOptions {
  int width = 512, height = 512;
  Camera camera;
  /// Thin-lens radius in world units; 0: pinhole.
  float aperture = 0;
  /// Distance of the plane in focus along the view direction; 0: |look_at - eye|.
  float focus_distance = 0;
  /// Samples per pixel (the maximum with `adaptive`): stratified, jittered with seeds that
  /// depend only on the pixel and the sample index; 1 sample goes through the pixel centre.
  int spp = 1;
  /// Trace min(spp, kAdaptiveFirst) samples per pixel first, and the rest only where those
  /// disagree by more than `adaptive_threshold` (max over the channels of max - min).
  bool adaptive = false;
  float adaptive_threshold = 0.05f;
  static constexpr int kAdaptiveFirst = 4;
  /// Reflection and refraction bounces after the camera ray; 0: first hits and shadows only.
  int max_depth = 5;
  /// Linear RGB seen by every ray that leaves the scene (also through glass and in mirrors).
  Vec3 background{0.18f, 0.2f, 0.24f};
  /// Empty: default_lights() for the camera.
  std::vector<Light> lights;
  bool shadows = true;
  int threads = 0;  ///< 0: all cores
  int tile_size = 16;
  ProgressFn progress;
  const std::atomic<bool>* cancel = nullptr;
  /// Only samples [sample_begin, sample_begin + sample_count) of each pixel's spp-sample
  /// pattern (sample_count 0: all of them; adaptive sampling is then off). Motion blur traces
  /// each time stratum as a pass of its own samples, so that the passes together are the
  /// spp-sample render, sample s seen at time stratum s.
  int sample_begin = 0, sample_count = 0;
  /// Only these tiles (row-major indices of the tile_size layout, render/tiles.h), when not
  /// null: the other pixels of the image are left as they were. A render split across
  /// processes (MPI) gives each its share.
  const std::vector<size_t>* tiles = nullptr;
};

struct TraceStats {
  double seconds = 0;
  int threads = 0;
  size_t tiles = 0;
  uint64_t camera_rays = 0, secondary_rays = 0, shadow_rays = 0, hits = 0;
  /// Pixels that took more than the first samples (adaptive sampling).
  uint64_t refined_pixels = 0;
  /// Per object: the root mode used (never kAuto).
  std::vector<RootMode> root_used;
  EvalCounters evals;
  /// Thread-seconds in root searches (camera, secondary and shadow rays) and in the rest.
  double search_seconds = 0, shade_seconds = 0;
  bool cancelled = false;

  /// Adds the counts and times of another trace of the same scene (a motion-blur pass, another
  /// batch of tiles); tiles, threads and root_used become the other's.
  void add(const TraceStats& other);
};

struct TraceResult {
  Image image;
  TraceStats stats;
};

/// The reflectance of a smooth dielectric interface for unpolarised light arriving at
/// cos(angle of incidence) `cos_i` from index n1 into index n2 (the exact Fresnel equations;
/// 1 beyond the critical angle).
float fresnel_dielectric(float cos_i, float n1, float n2);

/// Traces the scene. The options and objects must be valid (positive size and spp, a valid
/// camera, non-empty boxes, material indices in range): callers validate user input first.
void trace_into(const std::vector<SceneObject>& objects, const std::vector<Material>& materials,
                const TraceOptions& options, TraceResult* out);
TraceResult trace(const std::vector<SceneObject>& objects, const std::vector<Material>& materials,
                  const TraceOptions& options);

}  // namespace hfrt::render
