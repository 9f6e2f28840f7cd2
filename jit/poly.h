#pragma once
// The polynomial domain: along a ray x = o + t d, every value of F's "polynomial part" is a
// polynomial in t of degree <= 4 (truncated polynomials, 5 coefficients). This is the fourth
// arithmetic domain derived from the one IR (after scalar, interval and gradient); the
// analytic root search of the renderer (docs/rendering.md) solves its leaves in closed form.
//
// Two steps:
//  1. analyze_polynomial(fn), once per object: a forward pass classifies every IR value as
//       - a polynomial in x of known total degree (x enters affinely through kInput; + - *,
//         division by an x-independent value, integral constant powers keep it; every
//         x-independent value, whatever its op, is a polynomial of degree 0),
//       - a "square-root form" A + B sqrt(C) with A, B, C polynomials, or
//       - not polynomial, with the instruction (and source location) that broke it;
//     then a top-down pass from F extracts the set-operation skeleton: min, max, unary
//     minus, multiplication or division by an x-independent value, kSelect on an
//     x-independent condition, and the R-functions `|`, `&`, `\` (recognised by the shape
//     jit/lower.cpp `r_function` and stdlib emit: f1 + f2 +- sqrt(f1*f1 + f2*f2)). The
//     values right below the skeleton are the leaves; each must be a polynomial of degree
//     <= 4 or a square-root form whose surrogate has degree <= 4.
//  2. PolyInterpreter evaluates, per ray, a small derived program (PolyProgram) that computes
//     the 5 coefficients of every leaf, touching only the leaves' sub-DAG.
//
// Surrogates (library primitives whose field is not polynomial but whose surface is
// algebraic): no IR op and no side table. A leaf A + B sqrt(C) = 0 implies A^2 - B^2 C = 0,
// so the analysis eliminates the one square root itself and uses A^2 - B^2 C as the leaf's
// polynomial: the same zero set plus possibly extra roots (where A = +B sqrt(C)); extra
// roots are harmless, since the renderer checks F's sign at every candidate. This covers
// hfTorusX/Y/Z (r0^2 - |d|^2 - R^2 + 2R sqrt(rho^2) gives (|d|^2 + R^2 - r0^2)^2 - 4R^2 rho^2),
// a hand-written torus or sphere distance (sqrt(x*x+y*y+z*z) - r), and needs nothing from
// stdlib or any other evaluator. hfBlock is an R-function intersection of three products of
// two planes each: the skeleton pattern finds its three degree-2 leaves.
//
// Approximation: HyperFun's `b^n` (integral n) is lowered as select(|b| < 1e-6, 0, b*...*b);
// the analysis reads it as b^n (the two differ by less than 1e-6^n where the select fires).
//
// Not thread-hostile: the analysis is a pure function; PolyInterpreter::eval is const and
// uses per-thread scratch memory.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "ir/ir.h"
#include "jit/llvm_jit.h"  // JitStats (no LLVM types)

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

inline constexpr int kPolyMaxDegree = 4;
inline constexpr int kPolyCoeffs = kPolyMaxDegree + 1;

/// How many values the polynomial domain's parameter vector holds: the function's a[] (with
/// its hoisted numbers), then x[4], x[5], ... for objects with more than three inputs. Along
/// a ray only x[1..3] move; the others (time in an animation) are numbers held for the whole
/// ray, so the analysis reads them as parameters instead of giving up.
inline int poly_num_params(const Function& fn) {
  return fn.num_params + std::max(0, fn.num_inputs - 3);
}

/// One instruction of a PolyProgram; register i is the result of instruction i (5
/// coefficients). Arguments are earlier registers.
enum class PolyOp : uint8_t {
  kConst,  ///< imm
  kInput,  ///< o[aux] + t d[aux] (0 for aux >= 3)
  kParam,  ///< a[aux] (0 past the end)
  kAdd,
  kSub,
  kNeg,
  kMul,     ///< truncated product (the analysis guarantees the true degree is <= 4)
  kDiv,     ///< a / b[0], b of degree 0
  kScalar,  ///< apply_op(scalar_op, a[0], b[0], c[0]) on degree-0 arguments
  kTable,   ///< Function::tables[aux][a[0]] (a of degree 0)
  kSelect,  ///< a[0] != 0 ? b : c (a of degree 0)
};

struct PolyInst {
  PolyOp op = PolyOp::kConst;
  Op scalar_op = Op::kConst;  ///< kScalar only
  int32_t args[3] = {-1, -1, -1};
  double imm = 0;
  int32_t aux = 0;
  int8_t degree = 0;  ///< degree in t (bound): coefficients above it are 0
};

/// One analytic leaf: F's zero set on a ray is contained in the union of the leaves' zero sets.
struct PolyLeaf {
  int32_t reg = -1;          ///< register holding the leaf polynomial
  int degree = 0;            ///< bound on its degree in t
  ValueId value = kNoValue;  ///< the IR value below the skeleton
  bool surrogate = false;    ///< A^2 - B^2 C of a square-root form (same zero set, not the value)
};

/// A mesh or patch leaf (kSurface) whose point is an affine image of x: along the ray its
/// point is p(t) = p0 + t p1, so its zero crossings are the surface's crossings with the ray
/// p0 + t p1, at the same t (analytic candidates without a polynomial).
struct PolySurfaceLeaf {
  int32_t surface = -1;            ///< Function::surfaces index
  int32_t regs[3] = {-1, -1, -1};  ///< before pruning: the registers of x, y, z
  ValueId value = kNoValue;        ///< the kSurface instruction
  int first_leaf = -1;             ///< its point's x, y, z are leaves first_leaf .. + 2
};

struct PolyProgram {
  std::vector<PolyInst> insts;
  /// The polynomial leaves [0, num_poly_leaves), then three pseudo-leaves (degree <= 1) per
  /// surface leaf: the leaf's point along the ray (evaluated by the same interpreter/JIT).
  std::vector<PolyLeaf> leaves;
  int num_poly_leaves = 0;
  std::vector<PolySurfaceLeaf> surfaces;
};

/// What analyze_polynomial found.
struct PolyAnalysis {
  bool qualifies = false;
  int max_degree = 0;
  /// When !qualifies: the first construct that is not polynomial / not a set operation, e.g.
  /// "'sqrt' is not a polynomial", "division by a variable", "'hfBlendUni' is not a set
  /// operation nor a polynomial (division by a variable)", and where (loc may be invalid for
  /// synthesised code).
  std::string reason;
  lang::SourceLoc loc;
  ValueId where = kNoValue;
  PolyProgram program;            ///< valid when qualifies
  std::vector<ValueId> skeleton;  ///< IR values of the skeleton's nodes (tests, debugging)
};

/// The name of a PolyOp as the printer writes it ("mul", "scalar", ...).
std::string_view poly_op_name(PolyOp op);

/// Text form of a polynomial program (`hfrt ir --poly`, tests), like the IR's printer: one
/// register per line with its degree bound and the IR value it computes, e.g.
/// `r4 = mul r2, r3    ; deg 2`, then the leaves (`leaf 0 = r7 ; deg 2, %12`) and the
/// surface leaves.
std::string print(const PolyProgram& program);

/// Classifies the function and, when it qualifies, builds the leaves' program. Pure; linear
/// in the number of instructions.
PolyAnalysis analyze_polynomial(const Function& fn);

/// Reference evaluator of a PolyProgram. The Function and program must outlive it.
class PolyInterpreter {
 public:
  PolyInterpreter(const Function& fn, const PolyProgram& program) : fn_(fn), program_(program) {}

  /// Coefficients of every leaf for the ray o + t d with parameters a: out[5*i + k] is the
  /// coefficient of t^k of leaf i. Const and thread-safe.
  void eval(const double o[3], const double d[3], std::span<const double> a, double* out) const;

 private:
  const Function& fn_;
  const PolyProgram& program_;
};

/// The compiled PolyProgram (jit/llvm_poly.cpp): straight-line LLVM code, each register five
/// <W x double> values (W rays per block), coefficients above a register's degree bound
/// folded away, the same operations in the same order as PolyInterpreter (results equal up
/// to the sign of zero). Immutable after compile(); thread-safe.
class PolyJit {
 public:
  ~PolyJit();
  PolyJit(const PolyJit&) = delete;
  PolyJit& operator=(const PolyJit&) = delete;

  /// `lanes`: rays per SIMD block (power of two; 1 suits the one-ray API).
  static Result<std::unique_ptr<PolyJit>> compile(const Function& fn, const PolyProgram& program,
                                                  int lanes = 1, int opt_level = 2);

  /// n rays, structure of arrays: o[k*n + i], d[k*n + i] (k < 3); leaf coefficient k of
  /// leaf j of ray i to out[(5*j + k)*n + i].
  void eval(int64_t n, const double* o, const double* d, std::span<const double> a,
            double* out) const;
  /// One ray: out[5*j + k] as PolyInterpreter::eval.
  void eval_one(const double o[3], const double d[3], std::span<const double> a, double* out) const;

  int lanes() const;
  const JitStats& stats() const;

 private:
  struct Impl;
  explicit PolyJit(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Evaluates c[0] + c[1] t + ... + c[4] t^4 (Horner).
inline double poly_value(const double c[kPolyCoeffs], double t) {
  return (((c[4] * t + c[3]) * t + c[2]) * t + c[1]) * t + c[0];
}

}  // namespace hfrt::jit
