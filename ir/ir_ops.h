#pragma once
// The one op list of hfrt's IR. Every evaluator (interpreter, scalar JIT, interval, gradient,
// polynomial, POV-Ray text) is a switch over this list without a `default:` (ir/ and jit/
// build with -Werror=switch), so adding an op fails to compile until every domain handles it.
// What several domains treat alike is a column here, not a hand-written case list: the
// accessors and the generated case labels are in ir.h.
//
// X(Name, num_args, flags, kind, lane, libm, poly)
//   flags: kPure      - no side effects, result depends only on args/imm (CSE, folding allowed)
//          kValue     - produces a value (ValueId = instruction index)
//          kCtl       - structured control flow marker
//          kHoistUse  - an argument may be a constant turned into a parameter (hoist_constants)
//          kTraced    - records which operand can be chosen (the interval min/max/select trace)
//   kind:  Leaf (kConst kInput kParam), Slot (slot loads and stores), Table, Surface, Check,
//          Ctl (control markers), or one of the three kinds computed from the arguments by
//          apply_op (scalar_ops.h): Arith; Step (piecewise constant: zero derivative, not 0/1);
//          Bool (the result is always 0 or 1, hence also piecewise constant)
//   lane:  how the vector emitters compute the value: None (not computed from arguments),
//          Inline (vector code), Intrinsic (an IEEE-exact LLVM intrinsic), Libm (a per-lane call
//          of the libm function `libm` / `libm`f, the very function the interpreter calls),
//          Helper (a per-lane call of hfrt's C helper `libm`_f64 / `libm`_f32)
//   libm:  the C function's name for the Intrinsic (its libm fallback), Libm and Helper lanes;
//          `_` for none
//   poly:  the rule of the polynomial analysis (jit/poly_analysis.cpp): NA (not computed from
//          arguments; handled per op), None (not a polynomial unless independent of x), AddSub,
//          Neg, Mul, Div, Sqrt, Pow, Select, MinMax (a set operation), Compare (0/1 values)
//
// Semantics (all values are f64 in the reference interpreter; the f32 evaluators use the
// float libm functions, except kSin / kCos: hfrt's kernel of ir/trig.h, rounded to float):
//  kConst            imm
//  kInput            x[aux+1] of the evaluated point (0 when the caller passes fewer coords)
//  kParam            a[aux+1]
//  kLoadSlot         current value of mutable slot aux
//  kStoreSlot        slot aux := arg0 (only in lanes that are active under enclosing control)
//  kLoadIdx          arg0 is an integral 1-based index (already range-checked); reads slot
//                    aux + arg0 - 1 of an array of imm elements starting at slot aux
//  kStoreIdx         same addressing; slot := arg1
//  kTableLoad        Function::tables[aux][arg0] (arg0 integral, 0-based, in range)
//  IEEE arithmetic   kAdd kSub kMul kDiv kNeg kAbs kMin kMax kSqrt kExp kLog kLog10 kSin kCos
//                    kTan kAsin kAcos kAtan kAtan2 kSinh kCosh kTanh kFloor kCeil kTrunc
//                    kRound (half away from zero, C round) kFmod (C fmod) kPow (C pow)
//                    kMin/kMax: (a < b ? a : b) / (a > b ? a : b) as written (NaN -> b).
//  kPowHF            HyperFun power value (no error report): |b| < 1e-6 -> 0; integral e
//                    (|frac(e)| < 1e-6) -> b multiplied round(|e|) times, inverted if e < 0;
//                    else exp(e*log(b)) (NaN for b < 0). Errors are separate kCheck ops.
//  kSign             -1, 0, 1 (hfrt semantics)
//  kLt kLe kGt kGe   IEEE comparison -> 1.0 or 0.0
//  kEqTol kNeTol     |a - b| < 1e-6 -> 1/0 (HyperFun '=' and '/=')
//  kEq kNe           exact IEEE equality -> 1/0 (library code)
//  kTruth            |a| >= 1e-6 -> 1/0 (HyperFun truth value)
//  kAnd kOr kNot     on truth values (|v| >= 1e-6) -> 1/0
//  kSelect           arg0 != 0 ? arg1 : arg2 (arg0 is 0/1)
//  kCbrt             real cube root, C cbrt (cbrt(-8) = -2, odd, increasing, NaN stays NaN;
//                    glibc's is not correctly rounded: cbrt(27) = 3 + 1 ulp). Not a
//                    HyperFun built-in: code that builds IR (IrBuilder) may use it
//  kSurface          signed distance (positive inside) of the mesh or patch surface
//                    Function::surfaces[aux] at the point (arg0, arg1, arg2), evaluated in
//                    single precision by geom/ (hfMesh, hfTriangles, hfBezierSurface,
//                    hfBezierPatches; docs/meshes.md)
//  kCheck            run-time error aux (ErrorKind) when arg0 != 0; evaluation of the point
//                    goes on but its result becomes NaN (the interpreter records the first
//                    error and the instruction's location)
//  kIf arg0          structured if; then-part follows; arg0 is 0/1
//  kElse             optional
//  kEndIf
//  kLoop             start of a while loop; the header (condition code) follows
//  kLoopTest arg0    leave the loop when arg0 == 0 (lanes leave independently)
//  kEndLoop          back to kLoop
//
// Structure rules: kIf..kElse..kEndIf and kLoop..kLoopTest..kEndLoop nest properly; a value
// defined inside a region is used only inside it (values cross regions through slots); each
// kLoop has exactly one kLoopTest at its own nesting level.

#define HFRT_IR_OPS(X)                                                      \
  X(Const, 0, kPure | kValue, Leaf, None, _, NA)                            \
  X(Input, 0, kPure | kValue, Leaf, None, _, NA)                            \
  X(Param, 0, kPure | kValue, Leaf, None, _, NA)                            \
  X(LoadSlot, 0, kValue, Slot, None, _, NA)                                 \
  X(StoreSlot, 1, kHoistUse, Slot, None, _, NA)                             \
  X(LoadIdx, 1, kValue, Slot, None, _, NA)                                  \
  X(StoreIdx, 2, 0, Slot, None, _, NA)                                      \
  X(TableLoad, 1, kPure | kValue, Table, None, _, NA)                       \
  X(Add, 2, kPure | kValue | kHoistUse, Arith, Inline, _, AddSub)           \
  X(Sub, 2, kPure | kValue | kHoistUse, Arith, Inline, _, AddSub)           \
  X(Mul, 2, kPure | kValue | kHoistUse, Arith, Inline, _, Mul)              \
  X(Div, 2, kPure | kValue | kHoistUse, Arith, Inline, _, Div)              \
  X(Neg, 1, kPure | kValue | kHoistUse, Arith, Inline, _, Neg)              \
  X(Abs, 1, kPure | kValue, Arith, Inline, _, None)                         \
  X(Min, 2, kPure | kValue | kHoistUse | kTraced, Arith, Inline, _, MinMax) \
  X(Max, 2, kPure | kValue | kHoistUse | kTraced, Arith, Inline, _, MinMax) \
  X(Sqrt, 1, kPure | kValue, Arith, Intrinsic, sqrt, Sqrt)                  \
  X(Exp, 1, kPure | kValue, Arith, Libm, exp, None)                         \
  X(Log, 1, kPure | kValue, Arith, Libm, log, None)                         \
  X(Log10, 1, kPure | kValue, Arith, Libm, log10, None)                     \
  X(Sin, 1, kPure | kValue, Arith, Libm, sin, None)                         \
  X(Cos, 1, kPure | kValue, Arith, Libm, cos, None)                         \
  X(Tan, 1, kPure | kValue, Arith, Libm, tan, None)                         \
  X(Asin, 1, kPure | kValue, Arith, Libm, asin, None)                       \
  X(Acos, 1, kPure | kValue, Arith, Libm, acos, None)                       \
  X(Atan, 1, kPure | kValue, Arith, Libm, atan, None)                       \
  X(Atan2, 2, kPure | kValue, Arith, Libm, atan2, None)                     \
  X(Sinh, 1, kPure | kValue, Arith, Libm, sinh, None)                       \
  X(Cosh, 1, kPure | kValue, Arith, Libm, cosh, None)                       \
  X(Tanh, 1, kPure | kValue, Arith, Libm, tanh, None)                       \
  X(Floor, 1, kPure | kValue, Step, Intrinsic, floor, None)                 \
  X(Ceil, 1, kPure | kValue, Step, Intrinsic, ceil, None)                   \
  X(Trunc, 1, kPure | kValue, Step, Intrinsic, trunc, None)                 \
  X(Round, 1, kPure | kValue, Step, Intrinsic, round, None)                 \
  X(Fmod, 2, kPure | kValue, Arith, Libm, fmod, None)                       \
  X(Pow, 2, kPure | kValue, Arith, Libm, pow, Pow)                          \
  X(PowHF, 2, kPure | kValue, Arith, Helper, hfrt_jit_powhf, Pow)           \
  X(Sign, 1, kPure | kValue, Step, Inline, _, None)                         \
  X(Lt, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Le, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Gt, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Ge, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(EqTol, 2, kPure | kValue, Bool, Inline, _, Compare)                     \
  X(NeTol, 2, kPure | kValue, Bool, Inline, _, Compare)                     \
  X(Eq, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Ne, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Truth, 1, kPure | kValue, Bool, Inline, _, Compare)                     \
  X(And, 2, kPure | kValue, Bool, Inline, _, Compare)                       \
  X(Or, 2, kPure | kValue, Bool, Inline, _, Compare)                        \
  X(Not, 1, kPure | kValue, Bool, Inline, _, Compare)                       \
  X(Select, 3, kPure | kValue | kTraced, Arith, Inline, _, Select)          \
  X(Cbrt, 1, kPure | kValue, Arith, Libm, cbrt, None)                       \
  X(Surface, 3, kPure | kValue, Surface, None, _, NA)                       \
  X(Check, 1, 0, Check, None, _, NA)                                        \
  X(If, 1, kCtl, Ctl, None, _, NA)                                          \
  X(Else, 0, kCtl, Ctl, None, _, NA)                                        \
  X(EndIf, 0, kCtl, Ctl, None, _, NA)                                       \
  X(Loop, 0, kCtl, Ctl, None, _, NA)                                        \
  X(LoopTest, 1, kCtl, Ctl, None, _, NA)                                    \
  X(EndLoop, 0, kCtl, Ctl, None, _, NA)

// X(Name, message) — the run-time errors of the spec, with the original's messages.
#define HFRT_IR_ERRORS(X)                                     \
  X(DivisionByZero, "Division by zero")                       \
  X(NegativeSqrt, "Square root of negative value")            \
  X(LogNonPositive, "Logarithm of non-positive value")        \
  X(AsinRange, "Arcsine argument out of [-1, 1]")             \
  X(AcosRange, "Arccosine argument out of [-1, 1]")           \
  X(NegativePower, "Negative value for power")                \
  X(ZeroPower, "Zero to a non-positive power")                \
  X(IndexOutOfRange, "Array index out of range")              \
  X(Uninitialized, "Not initialized variable")                \
  X(ArrayUninitialized, "Some items of array are unassigned") \
  X(LoopLimit, "Loop iteration limit exceeded")
