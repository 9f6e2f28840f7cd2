#pragma once
// The interval domain's meaning of every pure op, written once: apply_interval is the sound
// enclosure of one op over interval arguments (the contract is in jit/interval.h: every value
// the f64 scalar evaluator computes at a point of the box is inside, or NaN with maybe_nan
// set). The interval interpreter calls it per instruction and the interval JIT's per-lane
// helpers call it for the ops they do not emit as vector code, so both domains' engines agree.

#include <cstdint>

#include "base/interval.h"
#include "ir/ir.h"

namespace hfrt::ir {

/// Values of the min/max/select trace (bit set: 1 = the left operand / then-value can be the
/// result somewhere in the box, 2 = the right one can). 0 = the instruction was not reached
/// (or is not a min/max/select). Loops OR the bits of every iteration.
inline constexpr uint8_t kChoiceNone = 0;
inline constexpr uint8_t kChoiceLeft = 1;
inline constexpr uint8_t kChoiceRight = 2;
inline constexpr uint8_t kChoiceBoth = 3;

/// What a condition can be over a box: true somewhere, false somewhere, or both.
struct Tri {
  bool can_true;
  bool can_false;
};

/// Over a condition value (0/1 normally): where `c != 0` can hold and where it can fail
/// (NaN != 0 is true). How kIf, kLoopTest and kSelect decide over a box.
Tri nonzero(const Interval& c);

/// The sound interval extension of one pure op with arguments (the ops apply_op of
/// scalar_ops.h accepts). `same_args` says that arguments 0 and 1 are the same SSA value
/// (x*x is then a square, never negative). `choice`, when non-null, receives the trace bits
/// for kMin/kMax/kSelect.
Interval apply_interval(Op op, Interval a, Interval b, Interval c, bool same_args = false,
                        uint8_t* choice = nullptr);

/// The enclosure of an R-function node f1 + f2 +- sqrt(f1^2 + f2^2) (match_r_function) given
/// its op-by-op enclosure `composed` and those of f1 and f2: both R-functions are
/// non-decreasing in each argument (d/df1 = 1 +- f1 / sqrt(f1^2 + f2^2) >= 0), so the value
/// lies between the formula at the lower ends and at the upper ends, widened by a bound on
/// the formula's rounding in double (2^-48 (|f1| + |f2|) at most, plus 1e-150 for
/// underflow). Op by op the enclosure is loose (f1 and f2 occur twice: the dependency
/// problem); the result is its intersection with this one. Unchanged when an operand may be
/// NaN, has an infinite end or is beyond 1e150.
Interval r_function_interval(const Interval& composed, const Interval& f1, const Interval& f2,
                             bool plus);

}  // namespace hfrt::ir
