#pragma once
// Private helpers of the FRep library (stdlib/*.cpp only): an IR value wrapper with C
// arithmetic operators, so that each formula of library.md can be written once, in the
// evaluation order of the original C code, and a per-call context that reads and writes
// array arguments through their slots and reports size problems as located warnings.

#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ir/builder.h"
#include "stdlib/library.h"

namespace hfrt::stdlib::detail {

using ir::IrBuilder;
using ir::Op;
using ir::ValueId;
using lang::LibraryFn;

/// The failure value most library functions return for a point array whose size is not 3.
inline constexpr double kFailure = -1111111111111.0;
/// EPS of the original library (`0.1e-5`).
inline constexpr double kEps = 1e-6;
inline constexpr double kPi = 3.141592653589793;
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// An IR value plus its builder. Operators emit the IEEE op of the same name; since C++
/// groups `a - b - c` as `(a - b) - c` exactly as C does, a formula copied from the
/// original code keeps its evaluation order (which matters at the 1e-15 level).
struct V {
  IrBuilder* b = nullptr;
  ValueId id = ir::kNoValue;
};

inline V bin(Op op, V a, V b) {
  return {a.b, a.b->binary(op, a.id, b.id)};
}
inline V un(Op op, V a) {
  return {a.b, a.b->unary(op, a.id)};
}
inline V cst(IrBuilder* b, double c) {
  return {b, b->constant(c)};
}

inline V operator+(V a, V b) {
  return bin(Op::kAdd, a, b);
}
inline V operator-(V a, V b) {
  return bin(Op::kSub, a, b);
}
inline V operator*(V a, V b) {
  return bin(Op::kMul, a, b);
}
inline V operator/(V a, V b) {
  return bin(Op::kDiv, a, b);
}
inline V operator+(V a, double c) {
  return a + cst(a.b, c);
}
inline V operator-(V a, double c) {
  return a - cst(a.b, c);
}
inline V operator*(V a, double c) {
  return a * cst(a.b, c);
}
inline V operator/(V a, double c) {
  return a / cst(a.b, c);
}
inline V operator+(double c, V a) {
  return cst(a.b, c) + a;
}
inline V operator-(double c, V a) {
  return cst(a.b, c) - a;
}
inline V operator*(double c, V a) {
  return cst(a.b, c) * a;
}
inline V operator/(double c, V a) {
  return cst(a.b, c) / a;
}
inline V operator-(V a) {
  return un(Op::kNeg, a);
}

inline V sqrt(V a) {
  return un(Op::kSqrt, a);
}
inline V abs(V a) {
  return un(Op::kAbs, a);
}
inline V exp(V a) {
  return un(Op::kExp, a);
}
inline V sin(V a) {
  return un(Op::kSin, a);
}
inline V cos(V a) {
  return un(Op::kCos, a);
}
inline V tan(V a) {
  return un(Op::kTan, a);
}
inline V atan(V a) {
  return un(Op::kAtan, a);
}
inline V acos(V a) {
  return un(Op::kAcos, a);
}
inline V floor(V a) {
  return un(Op::kFloor, a);
}
inline V trunc(V a) {
  return un(Op::kTrunc, a);
}
inline V pow(V a, V b) {
  return bin(Op::kPow, a, b);
}
inline V pow(V a, double c) {
  return pow(a, cst(a.b, c));
}
inline V fmod(V a, V b) {
  return bin(Op::kFmod, a, b);
}
inline V fmod(V a, double c) {
  return fmod(a, cst(a.b, c));
}
/// C's `x*x` (SQ in the original sources).
inline V sq(V a) {
  return a * a;
}

// Comparisons give 1.0 / 0.0 (IEEE: false for NaN).
inline V lt(V a, V b) {
  return bin(Op::kLt, a, b);
}
inline V le(V a, V b) {
  return bin(Op::kLe, a, b);
}
inline V gt(V a, V b) {
  return bin(Op::kGt, a, b);
}
inline V ge(V a, V b) {
  return bin(Op::kGe, a, b);
}
inline V eq(V a, V b) {
  return bin(Op::kEq, a, b);
}
inline V lt(V a, double c) {
  return lt(a, cst(a.b, c));
}
inline V le(V a, double c) {
  return le(a, cst(a.b, c));
}
inline V gt(V a, double c) {
  return gt(a, cst(a.b, c));
}
inline V ge(V a, double c) {
  return ge(a, cst(a.b, c));
}
inline V eq(V a, double c) {
  return eq(a, cst(a.b, c));
}
// Logic on 0/1 values.
inline V land(V a, V b) {
  return bin(Op::kAnd, a, b);
}
inline V lor(V a, V b) {
  return bin(Op::kOr, a, b);
}
inline V lnot(V a) {
  return un(Op::kNot, a);
}
/// `cond ? a : b` (cond is 0/1).
inline V sel(V cond, V a, V b) {
  return {cond.b, cond.b->select(cond.id, a.id, b.id)};
}
inline V sel(V cond, double a, V b) {
  return sel(cond, cst(cond.b, a), b);
}
inline V sel(V cond, V a, double b) {
  return sel(cond, a, cst(cond.b, b));
}

/// One library call being lowered: the arguments, the builder and the diagnostics.
class Call {
 public:
  Call(LibraryFn fn, LibContext& ctx, std::span<const LibArg> args);

  LibraryFn fn() const { return fn_; }
  IrBuilder& builder() { return ctx_.b; }
  LibState& state() { return ctx_.state; }
  const Limits& limits() const {
    static const Limits kDefaults;
    return ctx_.limits ? *ctx_.limits : kDefaults;
  }
  std::string_view name() const;

  V k(double c) { return cst(&ctx_.b, c); }
  V nan() { return k(kNaN); }
  /// Real argument i (0-based, call order), already evaluated by the lowering.
  V real(int i) const;
  /// The compile-time value of real argument i when it is a constant.
  bool real_constant(int i, double* out) const;

  /// Declared size of array argument i.
  int size(int i) const;
  /// Element k (0-based) of array argument i: a load of its slot, or NaN past the end
  /// (reads past the end are warned about by need(); they never touch other slots).
  V at(int i, int k);
  /// Element `index1` (a 1-based integral value, already known to be in range) of array
  /// argument i, read at run time (kLoadIdx).
  V at_index(int i, V index1);
  /// Writes element k (0-based) of array argument i; a write past the end is dropped.
  void put(int i, int k, V v);

  /// Point-array check of most functions: when array argument i does not have exactly 3
  /// elements, warns (the original returns `failure` at run time) and returns false.
  bool point3(int i, double failure = kFailure);
  /// Warns when array argument i has fewer than `count` elements (`what` says why the
  /// call needs them); the missing elements read as NaN. Returns true when big enough.
  bool need(int i, int count, std::string_view what);

  /// A located warning at argument i (or at the call when i < 0).
  void warn(int i, const std::string& message, const std::string& hint = {});
  /// A located error at argument i (or at the call when i < 0): the model does not compile.
  void error(int i, const std::string& message, const std::string& hint = {});
  /// File argument i ('F'): the string literal's text.
  const std::string& text(int i) const;
  /// The source text of argument i ("x"), or "argument N" without source.
  std::string arg_text(int i) const;

 private:
  LibraryFn fn_;
  LibContext& ctx_;
  std::span<const LibArg> args_;
};

// One lowering function per family (each switches over the functions of its file).
V lower_primitive(Call& c);    // primitives.cpp: algebraic primitives, blobs, hfNoiseG
V lower_bezier(Call& c);       // primitives.cpp: hfBezierVolume
V lower_convolution(Call& c);  // convolution.cpp
V lower_transform(Call& c);    // transforms.cpp
V lower_blend(Call& c);        // blends.cpp: hfBlend*, hfDBlend*, hfSawtooth
V lower_distance(Call& c);     // distance.cpp: hfDCone*, hfDCylinder, hfDEllipsoid, hfDTorus*
V lower_sardf(Call& c);        // sardf.cpp: hfDUni, hfDInt, hfDSub
V lower_attribute(Call& c);    // attributes.cpp: hfA_* without noise
V lower_noise(Call& c);        // noise.cpp: hfA_NoiseG, hfA_NoiseP, hfA_Turbulence, hfA_Crackles
V lower_surface(Call& c);      // surfaces.cpp: hfMesh, hfTriangles, hfBezier{Surface,Patches}

/// glibc's rand() with its default seed 1, the k-th call (k = 0, 1, ...) (library.md §10).
class GlibcRand {
 public:
  int next();

 private:
  std::vector<uint32_t> r_;  ///< r_0, r_1, ... of the recurrence, grown on demand
  size_t calls_ = 0;
};

/// A Perlin table pair (permutation, unit gradients) as the original's init() builds it
/// from the next 1791 numbers of `rng`. perm has 514 entries, grad 3*514 (x, y, z per entry).
void build_perlin_tables(GlibcRand& rng, std::vector<double>* perm, std::vector<double>* grad);

}  // namespace hfrt::stdlib::detail
