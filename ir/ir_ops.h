#pragma once
// The one op list of hfrt's IR. Every evaluator (interpreter, scalar JIT, interval, gradient,
// polynomial) is a switch over this list; adding an op here makes every switch that lacks it
// fail to compile (-Wswitch), so no evaluator can silently miss an op.
//
// X(Name, num_args, flags)
//   flags: kPure   - no side effects, result depends only on args/imm (CSE and folding allowed)
//          kValue  - produces a value (ValueId = instruction index)
//          kCtl    - structured control flow marker
//
// Semantics (all values are f64 in the reference interpreter):
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

#define HFRT_IR_OPS(X)            \
  X(Const, 0, kPure | kValue)     \
  X(Input, 0, kPure | kValue)     \
  X(Param, 0, kPure | kValue)     \
  X(LoadSlot, 0, kValue)          \
  X(StoreSlot, 1, 0)              \
  X(LoadIdx, 1, kValue)           \
  X(StoreIdx, 2, 0)               \
  X(TableLoad, 1, kPure | kValue) \
  X(Add, 2, kPure | kValue)       \
  X(Sub, 2, kPure | kValue)       \
  X(Mul, 2, kPure | kValue)       \
  X(Div, 2, kPure | kValue)       \
  X(Neg, 1, kPure | kValue)       \
  X(Abs, 1, kPure | kValue)       \
  X(Min, 2, kPure | kValue)       \
  X(Max, 2, kPure | kValue)       \
  X(Sqrt, 1, kPure | kValue)      \
  X(Exp, 1, kPure | kValue)       \
  X(Log, 1, kPure | kValue)       \
  X(Log10, 1, kPure | kValue)     \
  X(Sin, 1, kPure | kValue)       \
  X(Cos, 1, kPure | kValue)       \
  X(Tan, 1, kPure | kValue)       \
  X(Asin, 1, kPure | kValue)      \
  X(Acos, 1, kPure | kValue)      \
  X(Atan, 1, kPure | kValue)      \
  X(Atan2, 2, kPure | kValue)     \
  X(Sinh, 1, kPure | kValue)      \
  X(Cosh, 1, kPure | kValue)      \
  X(Tanh, 1, kPure | kValue)      \
  X(Floor, 1, kPure | kValue)     \
  X(Ceil, 1, kPure | kValue)      \
  X(Trunc, 1, kPure | kValue)     \
  X(Round, 1, kPure | kValue)     \
  X(Fmod, 2, kPure | kValue)      \
  X(Pow, 2, kPure | kValue)       \
  X(PowHF, 2, kPure | kValue)     \
  X(Sign, 1, kPure | kValue)      \
  X(Lt, 2, kPure | kValue)        \
  X(Le, 2, kPure | kValue)        \
  X(Gt, 2, kPure | kValue)        \
  X(Ge, 2, kPure | kValue)        \
  X(EqTol, 2, kPure | kValue)     \
  X(NeTol, 2, kPure | kValue)     \
  X(Eq, 2, kPure | kValue)        \
  X(Ne, 2, kPure | kValue)        \
  X(Truth, 1, kPure | kValue)     \
  X(And, 2, kPure | kValue)       \
  X(Or, 2, kPure | kValue)        \
  X(Not, 1, kPure | kValue)       \
  X(Select, 3, kPure | kValue)    \
  X(Surface, 3, kPure | kValue)   \
  X(Check, 1, 0)                  \
  X(If, 1, kCtl)                  \
  X(Else, 0, kCtl)                \
  X(EndIf, 0, kCtl)               \
  X(Loop, 0, kCtl)                \
  X(LoopTest, 1, kCtl)            \
  X(EndLoop, 0, kCtl)

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
