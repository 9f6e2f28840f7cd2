#pragma once
// kSurface (ir_ops.h) in every domain: the one place that turns a geom::Surface query into a
// scalar value, an interval and a dual number, so the interpreters and the JITs (which call
// the C-ABI helpers below per lane, the surface pointer being a constant of the code) agree
// bit for bit. The surface works in single precision: coordinates are rounded to float (the
// interval domain rounds its box outwards, so the enclosure stays sound).

#include <cstdint>
#include <span>

#include "geom/surface.h"
#include "jit/gradient.h"
#include "jit/interval.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Signed distance (positive inside) at (x, y, z); NaN when a coordinate is NaN.
double surface_value(const geom::Surface& s, double x, double y, double z);

/// An enclosure of surface_value over the box x * y * z (maybe NaN when an argument may be).
Interval surface_interval(const geom::Surface& s, const Interval& x, const Interval& y,
                          const Interval& z);

/// Value and gradient: the surface's gradient (unit, from the closest point) chained with the
/// arguments' derivatives. On the surface itself (|value| < 1e-5 of the surface's size plus
/// Surface::field_tolerance(), e.g. at a ray hit) the closest-point direction is noise: the
/// gradient is then minus the closest primitive's unit normal, and the value's sign the side
/// of its plane.
Dual surface_dual(const geom::Surface& s, const Dual& x, const Dual& y, const Dual& z);

// ---- Sides from a ray's crossings (issue 17: one inside test per ray, not per candidate).
//
// The analytic root search (render/root_search.cpp) finds every crossing of a ray with each
// surface leaf (Model::ray_surface_crossings) and then asks F's sign at one point of each gap
// between candidates, through the sign-only code (hfrt_surface_sign_*: a winding number per
// point and leaf, the most expensive query next to the surface). For a closed surface
// (geom::SurfaceTopology::closed) the winding number is an integer off the surface, 0 outside
// its bounds, and changes by exactly the facing (+1 entering, -1 leaving) at each crossing, so
// along a ray w(t) = w(ref) + the facings of the crossings between ref and t. The reference is
// where the ray leaves (or enters) the surface's bounds inside the searched segment (w = 0
// there: no winding number at all), else the first point asked (one winding number per ray).
// This holds for self-intersecting closed meshes too (w = 2 where two shells overlap).
//
// Per thread, the last ray's leaves are recorded; a sign query whose point lies on a recorded
// leaf ray within its segment is answered from the crossings, any other point (another ray,
// an open surface, a point off the line) by the winding number. The answer is a property of
// the point alone, so a record can never be stale: it is only a faster way to the same side.

/// Forgets the recorded rays of this thread.
void ray_sides_clear();

/// The crossings of `ray` with surface `s` (in the surface's own space) with tmin < t < tmax,
/// sorted, into `out` (cleared first), and for a closed surface their record for the sign
/// queries. The record's search runs on to where the ray leaves the surface's bounds (w = 0
/// there), so that no query on this ray needs a winding number.
void ray_sides_crossings(const geom::Surface& s, const geom::Ray& ray, float tmin, float tmax,
                         std::vector<geom::Crossing>* out);

/// One query of ray_sides_prefetch: what ray_sides_crossings would be asked.
struct PrefetchQuery {
  const geom::Surface* surface;
  geom::Ray ray;
  float tmin, tmax;
};

/// Traces the crossings of `queries` ahead, each surface's rays together
/// (geom::Surface::crossings_many: packets for meshes), replacing this thread's earlier
/// prefetch: a ray_sides_crossings call on this thread with the same surface, ray and segment
/// as one of them, in their order (queries may be skipped), takes its crossings from there.
/// The results are the same either way; only the tracing is shared.
void ray_sides_prefetch(std::span<const PrefetchQuery> queries);
/// Forgets this thread's prefetched crossings.
void ray_sides_prefetch_clear();

/// How this thread's sign queries were answered (tests and statistics).
struct RaySideCounts {
  uint64_t from_crossings = 0;  ///< answered by the recorded crossings alone
  uint64_t winding = 0;         ///< by a winding number (including one reference per ray)
  /// ray_sides_crossings calls whose crossings came from ray_sides_prefetch's tracing.
  uint64_t prefetched = 0;
};
RaySideCounts ray_sides_counts();

}  // namespace hfrt::jit

// The per-lane helpers the JITs call (llvm_session.cpp registers them as absolute symbols);
// `s` is the geom::Surface, a constant of the code. noexcept C-ABI leaves.
extern "C" {
/// surface_value in double / in single precision.
double hfrt_surface_f64(const void* s, double x, double y, double z) noexcept;
float hfrt_surface_f32(const void* s, float x, float y, float z) noexcept;
/// The side only: +1 where surface_value >= 0 (winding number >= 1/2), else -1; NaN for NaN.
double hfrt_surface_sign_f64(const void* s, double x, double y, double z) noexcept;
float hfrt_surface_sign_f32(const void* s, float x, float y, float z) noexcept;
/// surface_interval: in = {xlo, xhi, xnan, ylo, yhi, ynan, zlo, zhi, znan} (nan as 0/1),
/// out = {lo, hi, nan}.
void hfrt_surface_interval(const void* s, const double* in, double* out) noexcept;
/// surface_dual: in = {x.v, x.d[0..2], y.v, ..., z.d[2]} (12), out = {v, d[0], d[1], d[2]}.
void hfrt_surface_dual(const void* s, const double* in, double* out) noexcept;
}
