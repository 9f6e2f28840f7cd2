#pragma once
// kSurface (ir_ops.h) in every domain: the one place that turns a geom::Surface query into a
// scalar value, an interval and a dual number, so the interpreters and the JITs (which call
// the C-ABI helpers below per lane, the surface pointer being a constant of the code) agree
// bit for bit. The surface works in single precision: coordinates are rounded to float (the
// interval domain rounds its box outwards, so the enclosure stays sound).

#include <span>

#include "jit/gradient.h"
#include "jit/interval.h"

namespace hfrt::geom {
class Surface;
}  // namespace hfrt::geom

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Signed distance (positive inside) at (x, y, z); NaN when a coordinate is NaN.
double surface_value(const geom::Surface& s, double x, double y, double z);

/// An enclosure of surface_value over the box x * y * z (maybe NaN when an argument may be).
Interval surface_interval(const geom::Surface& s, const Interval& x, const Interval& y,
                          const Interval& z);

/// Value and gradient: the surface's gradient (unit, from the closest point) chained with the
/// arguments' derivatives. On the surface itself (|value| < 1e-5 of the surface's size, e.g.
/// at a ray hit) the closest-point direction is rounding noise: the gradient is then the
/// normalised central difference of the distance with a step of 1e-4 of the size.
Dual surface_dual(const geom::Surface& s, const Dual& x, const Dual& y, const Dual& z);

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
