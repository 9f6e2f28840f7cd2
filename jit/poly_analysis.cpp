// The compile-time analysis of the polynomial domain (see poly.h): per-value classification,
// set-operation skeleton, leaves and the derived PolyProgram.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

#include "base/check.h"
#include "ir/r_functions.h"
#include "ir/scalar_ops.h"
#include "jit/poly.h"
#include "lang/library_table.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {

/// Total degrees above this are only tracked as "too high" (no overflow on long products).
constexpr int kDegreeCap = 64;

enum class Kind : uint8_t {
  kPoly,  ///< a polynomial in x of total degree `deg` (emitted when reg >= 0)
  kForm,  ///< A + B sqrt(C), A, B, C polynomials with registers
  kNot,   ///< not polynomial: `why`, broken at instruction `origin`
  kSet,   ///< a set operation (R-function, min, max, ...) of valid operands: a skeleton node
  kSurf,  ///< a kSurface leaf of x entering affinely: a skeleton leaf (never arithmetic)
};

struct VInfo {
  Kind kind = Kind::kNot;
  int deg = 0;
  int32_t reg = -1;
  // kForm: A (ra = -1 means A = 0), B, C (registers and degrees); `origin` = the kSqrt.
  int32_t ra = -1, rb = -1, rc = -1;
  int da = 0, db = 0, dc = 0;
  ValueId origin = kNoValue;
  std::string why;
};

class Analyzer {
 public:
  explicit Analyzer(const Function& fn) : fn_(fn), info_(fn.insts.size()) {}

  PolyAnalysis run() {
    PolyAnalysis out;
    for (ValueId v = 0; v < fn_.insts.size(); ++v) {
      if (op_has_value(fn_.insts[v].op)) classify(v);
    }
    HFRT_CHECK(fn_.result < fn_.insts.size());
    visited_.assign(fn_.insts.size(), 0);
    if (!visit(fn_.result, &out)) {
      out.qualifies = false;
      out.program = {};
      return out;
    }
    out.qualifies = true;
    // Surface leaves go after the polynomial leaves: three degree-1 pseudo-leaves each, the
    // leaf's point x, y, z along the ray (PolyProgram::surfaces).
    out.program.num_poly_leaves = static_cast<int>(out.program.leaves.size());
    for (PolySurfaceLeaf& s : surface_leaves_) {
      s.first_leaf = static_cast<int>(out.program.leaves.size());
      for (int k = 0; k < 3; ++k) {
        const int deg = prog_.insts[s.regs[k]].degree;
        out.program.leaves.push_back({s.regs[k], deg, fn_.insts[s.value].args[k], false});
      }
      out.program.surfaces.push_back(s);
    }
    prune(&out);
    for (int k = 0; k < out.program.num_poly_leaves; ++k)
      out.max_degree = std::max(out.max_degree, out.program.leaves[k].degree);
    return out;
  }

 private:
  // ---- program emission --------------------------------------------------------------------
  int32_t emit(PolyOp op, int deg, int32_t a = -1, int32_t b = -1, int32_t c = -1, double imm = 0,
               int32_t aux = 0, Op scalar_op = Op::kConst) {
    HFRT_CHECK(deg >= 0 && deg <= kPolyMaxDegree);
    PolyInst in;
    in.op = op;
    in.scalar_op = scalar_op;
    in.args[0] = a;
    in.args[1] = b;
    in.args[2] = c;
    in.imm = imm;
    in.aux = aux;
    in.degree = static_cast<int8_t>(deg);
    prog_.insts.push_back(in);
    return static_cast<int32_t>(prog_.insts.size() - 1);
  }
  int32_t konst(double v) { return emit(PolyOp::kConst, 0, -1, -1, -1, v); }

  // ---- classification ----------------------------------------------------------------------
  bool is_poly(ValueId v) const { return info_[v].kind == Kind::kPoly; }
  bool is_scalar(ValueId v) const { return is_poly(v) && info_[v].deg == 0 && info_[v].reg >= 0; }

  void set_poly(ValueId v, int deg, int32_t reg) {
    VInfo& i = info_[v];
    i.kind = Kind::kPoly;
    i.deg = std::min(deg, kDegreeCap);
    i.reg = deg <= kPolyMaxDegree ? reg : -1;
  }
  void set_not(ValueId v, ValueId origin, std::string why) {
    VInfo& i = info_[v];
    i.kind = Kind::kNot;
    i.origin = origin;
    i.why = std::move(why);
  }
  /// A poly of degree <= 4 gets a register; higher degrees are tracked without one.
  void poly_result(ValueId v, int deg, PolyOp op, int32_t a, int32_t b = -1) {
    if (deg > kPolyMaxDegree || a < 0 || (op != PolyOp::kNeg && b < 0)) {
      set_poly(v, deg, -1);
    } else {
      set_poly(v, deg, emit(op, deg, a, b));
    }
  }

  /// The name of the construct at an instruction's location: the identifier written there
  /// (a built-in or library function call), else the op's name.
  std::string construct(ValueId v) const {
    const Inst& in = fn_.insts[v];
    std::string ident = identifier_at(in.loc);
    // A built-in's name; inside a library function the op itself says more.
    if (!ident.empty() && !lang::find_library_fn(ident)) return ident;
    return std::string(op_name(in.op));
  }
  std::string identifier_at(lang::SourceLoc loc) const {
    if (!fn_.source || !loc.valid()) return {};
    std::string_view text = fn_.source->text();
    size_t p = loc.offset, e = p;
    while (e < text.size() && (std::isalnum(static_cast<unsigned char>(text[e])) || text[e] == '_'))
      ++e;
    if (e == p || std::isdigit(static_cast<unsigned char>(text[p]))) return {};
    return std::string(text.substr(p, e - p));
  }

  /// When an argument is not polynomial (or a square-root form used where only polynomials
  /// may go), the value inherits the earliest such breakage. Returns true when it did.
  bool inherit_not(ValueId v, int nargs, bool forms_ok) {
    const Inst& in = fn_.insts[v];
    ValueId best = kNoValue;
    for (int k = 0; k < nargs; ++k) {
      const VInfo& a = info_[in.args[k]];
      if (a.kind == Kind::kNot || a.kind == Kind::kSurf || (a.kind == Kind::kForm && !forms_ok)) {
        if (best == kNoValue || a.origin < info_[best].origin) best = in.args[k];
      }
    }
    if (best == kNoValue) {
      // A set operation's result is fine below another set operation, not inside arithmetic:
      // the breakage is this instruction (e.g. a blend's formula), not the set operation.
      for (int k = 0; k < nargs; ++k) {
        if (info_[in.args[k]].kind == Kind::kSet) {
          set_not(v, v, "the result of a set operation is used in arithmetic");
          return true;
        }
      }
      return false;
    }
    const VInfo& a = info_[best];
    if (a.kind == Kind::kForm) {
      set_not(v, a.origin, "'" + construct(a.origin) + "' is not a polynomial");
    } else {
      set_not(v, a.origin, a.why);
    }
    return true;
  }

  // A + B sqrt(C) forms.
  void set_form(ValueId v, int32_t ra, int da, int32_t rb, int db, int32_t rc, int dc,
                ValueId origin) {
    VInfo& i = info_[v];
    i.kind = Kind::kForm;
    i.ra = ra;
    i.da = da;
    i.rb = rb;
    i.db = db;
    i.rc = rc;
    i.dc = dc;
    i.origin = origin;
  }
  int32_t add_regs(int32_t a, int da, int32_t b, int db, bool subtract, int* deg) {
    *deg = std::max(da, db);
    if (a < 0 && b < 0) return -1;
    if (b < 0) return a;
    if (a < 0) return subtract ? emit(PolyOp::kNeg, db, b) : b;
    return emit(subtract ? PolyOp::kSub : PolyOp::kAdd, *deg, a, b);
  }

  void classify(ValueId v) {
    const Inst& in = fn_.insts[v];
    const int nargs = op_num_args(in.op);
    switch (in.op) {
      case Op::kConst:
        return set_poly(v, 0, konst(in.imm));
      case Op::kInput:
        // x[4], x[5], ... are held at one value along a ray (time, for an animation): the
        // poly domain reads them as the parameters after a[] (kPolyHeldInputs in poly.h).
        if (in.aux >= 3) {
          const int slot = in.aux < fn_.num_inputs ? int(fn_.num_params) + in.aux - 3 : -1;
          return set_poly(v, 0, emit(PolyOp::kParam, 0, -1, -1, -1, 0, slot));
        }
        return set_poly(v, 1, emit(PolyOp::kInput, 1, -1, -1, -1, 0, in.aux));
      case Op::kParam:
        return set_poly(v, 0, emit(PolyOp::kParam, 0, -1, -1, -1, 0, in.aux));
      case Op::kLoadSlot:
        return set_not(v, v, "a variable assigned inside 'if' or 'while' is not analysed");
      case Op::kLoadIdx:
        return set_not(v, v, "an array element with a computed index is not analysed");
      case Op::kSurface: {
        // A mesh or patch leaf is a skeleton leaf when its point is an affine image of x
        // (then its crossings along a ray are the surface's own, in its space, at the same
        // t); it never enters arithmetic.
        std::string name = identifier_at(in.loc);
        if (name.empty()) name = "a mesh or patch leaf";
        for (int k = 0; k < 3; ++k) {
          const VInfo& a = info_[in.args[k]];
          if (a.kind != Kind::kPoly || a.deg > 1 || a.reg < 0) {
            return set_not(v, v,
                           "'" + name +
                               "' is not a polynomial and its point is not an affine "
                               "image of x");
          }
        }
        info_[v].kind = Kind::kSurf;
        info_[v].origin = v;
        info_[v].why = "'" + name + "' (a mesh or patch leaf) is not a polynomial";
        return;
      }
      case Op::kTableLoad:
        if (inherit_not(v, 1, false)) return;
        if (is_scalar(in.args[0])) {
          return set_poly(v, 0, emit(PolyOp::kTable, 0, info_[in.args[0]].reg, -1, -1, 0, in.aux));
        }
        return set_not(v, v, "'" + construct(v) + "' (a table lookup) is not a polynomial");
      // Stores, checks and control flow have no value (run() classifies values only).
      case Op::kStoreSlot:
      case Op::kStoreIdx:
      case Op::kCheck:
      case Op::kIf:
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoop:
      case Op::kLoopTest:
      case Op::kEndLoop:
        return;
        // Every op computed from its arguments: the rules below.
        HFRT_OP_CASES_ARITH
        break;
    }
    const OpPolyRule rule = op_poly_rule(in.op);

    // The power pattern of jit/lower.cpp: select(|b| < 1e-6, 0, b*...*b) read as b*...*b.
    if (in.op == Op::kSelect && is_power_guard(in)) {
      info_[v] = info_[in.args[2]];
      return;
    }

    if (classify_set(v)) return;

    const bool forms_ok = rule == OpPolyRule::kAddSub || rule == OpPolyRule::kNeg ||
                          rule == OpPolyRule::kMul || rule == OpPolyRule::kDiv;
    if (inherit_not(v, nargs, forms_ok)) return;

    // Everything of degree 0 (independent of x) is a constant per ray, whatever the op.
    bool all_scalar = true;
    for (int k = 0; k < nargs; ++k) all_scalar = all_scalar && is_scalar(in.args[k]);
    if (all_scalar) {
      int32_t r[3] = {-1, -1, -1};
      for (int k = 0; k < nargs; ++k) r[k] = info_[in.args[k]].reg;
      return set_poly(v, 0, emit(PolyOp::kScalar, 0, r[0], r[1], r[2], 0, 0, in.op));
    }

    const ValueId a = in.args[0], b = nargs > 1 ? in.args[1] : kNoValue;
    const VInfo* ia = &info_[a];
    const VInfo* ib = b != kNoValue ? &info_[b] : nullptr;
    switch (rule) {
      case OpPolyRule::kAddSub: {
        const bool sub = in.op == Op::kSub;
        if (ia->kind == Kind::kPoly && ib->kind == Kind::kPoly) {
          return poly_result(v, std::max(ia->deg, ib->deg), sub ? PolyOp::kSub : PolyOp::kAdd,
                             ia->reg, ib->reg);
        }
        if (ia->kind == Kind::kForm && ib->kind == Kind::kForm) {
          if (ia->rc != ib->rc) {
            return set_not(
                v, ib->origin,
                "'" + construct(ib->origin) + "' is not a polynomial (a sum of two square roots)");
          }
          int da, db;
          const VInfo fa = *ia, fb = *ib;
          int32_t ra = add_regs(fa.ra, fa.da, fb.ra, fb.da, sub, &da);
          int32_t rb = add_regs(fa.rb, fa.db, fb.rb, fb.db, sub, &db);
          return set_form(v, ra, da, rb, db, fa.rc, fa.dc, std::min(fa.origin, fb.origin));
        }
        // A form and a polynomial.
        const bool form_left = ia->kind == Kind::kForm;
        const VInfo f = form_left ? *ia : *ib;
        const VInfo p = form_left ? *ib : *ia;
        if (p.reg < 0)
          return set_not(v, v, "a polynomial of degree " + std::to_string(p.deg) + " > 4");
        int da;
        int32_t ra, rb = f.rb;
        if (form_left) {
          ra = add_regs(f.ra, f.da, p.reg, p.deg, sub, &da);  // A +- p, B
        } else {
          ra = add_regs(p.reg, p.deg, f.ra, f.da, sub, &da);  // p +- A, +-B
          if (sub) rb = emit(PolyOp::kNeg, f.db, f.rb);
        }
        return set_form(v, ra, da, rb, f.db, f.rc, f.dc, f.origin);
      }
      case OpPolyRule::kNeg:
        if (ia->kind == Kind::kPoly) return poly_result(v, ia->deg, PolyOp::kNeg, ia->reg);
        {
          const VInfo f = *ia;
          int32_t ra = f.ra >= 0 ? emit(PolyOp::kNeg, f.da, f.ra) : -1;
          return set_form(v, ra, f.da, emit(PolyOp::kNeg, f.db, f.rb), f.db, f.rc, f.dc, f.origin);
        }
      case OpPolyRule::kMul: {
        if (ia->kind == Kind::kPoly && ib->kind == Kind::kPoly) {
          return poly_result(v, ia->deg + ib->deg, PolyOp::kMul, ia->reg, ib->reg);
        }
        if (ia->kind == Kind::kForm && ib->kind == Kind::kForm) {
          return set_not(v, v, "a product of square roots is not a polynomial");
        }
        const VInfo f = ia->kind == Kind::kForm ? *ia : *ib;
        const VInfo p = ia->kind == Kind::kForm ? *ib : *ia;
        if (p.reg < 0)
          return set_not(v, v, "a polynomial of degree " + std::to_string(p.deg) + " > 4");
        if (f.da + p.deg > kPolyMaxDegree || f.db + p.deg > kPolyMaxDegree) {
          return set_not(v, v, "a polynomial of degree > 4 times a square root");
        }
        int32_t ra = f.ra >= 0 ? emit(PolyOp::kMul, f.da + p.deg, f.ra, p.reg) : -1;
        int32_t rb = emit(PolyOp::kMul, f.db + p.deg, f.rb, p.reg);
        return set_form(v, ra, f.da + p.deg, rb, f.db + p.deg, f.rc, f.dc, f.origin);
      }
      case OpPolyRule::kDiv: {
        if (!is_scalar(b)) return set_not(v, v, "division by a variable");
        if (ia->kind == Kind::kPoly) {
          if (ia->reg < 0) return set_poly(v, ia->deg, -1);
          return set_poly(v, ia->deg, emit(PolyOp::kDiv, ia->deg, ia->reg, ib->reg));
        }
        const VInfo f = *ia;
        int32_t ra = f.ra >= 0 ? emit(PolyOp::kDiv, f.da, f.ra, ib->reg) : -1;
        return set_form(v, ra, f.da, emit(PolyOp::kDiv, f.db, f.rb, ib->reg), f.db, f.rc, f.dc,
                        f.origin);
      }
      case OpPolyRule::kSqrt:
        if (ia->reg < 0) {
          return set_not(v, v,
                         "'" + construct(v) + "' of a polynomial of degree " +
                             std::to_string(ia->deg) + " > 4");
        }
        return set_form(v, -1, 0, konst(1.0), 0, ia->reg, ia->deg, v);
      case OpPolyRule::kSelect:
        if (is_scalar(a) && ib->kind == Kind::kPoly && info_[in.args[2]].kind == Kind::kPoly) {
          const VInfo& ic = info_[in.args[2]];
          const int deg = std::max(ib->deg, ic.deg);
          if (ib->reg < 0 || ic.reg < 0) return set_poly(v, deg, -1);
          return set_poly(v, deg, emit(PolyOp::kSelect, deg, ia->reg, ib->reg, ic.reg));
        }
        if (!is_scalar(a))
          return set_not(v, v, "a condition that depends on x is not a polynomial");
        return set_not(v, v, "a choice between square roots is not analysed");
      case OpPolyRule::kPow: {
        double e = 0;
        if (is_const(b, &e) && e >= 0 && e <= kPolyMaxDegree && e == std::floor(e) &&
            ia->kind == Kind::kPoly) {
          const int n = static_cast<int>(e);
          if (n == 0) return set_poly(v, 0, konst(1.0));
          if (ia->reg < 0 || ia->deg * n > kPolyMaxDegree) return set_poly(v, ia->deg * n, -1);
          int32_t r = ia->reg;
          for (int i = 1; i < n; ++i) r = emit(PolyOp::kMul, ia->deg * (i + 1), r, ia->reg);
          return set_poly(v, ia->deg * n, r);
        }
        return set_not(v, v,
                       "a power with a variable or non-integral exponent is not a polynomial");
      }
      case OpPolyRule::kMinMax:
        return set_not(
            v, v,
            "'" + construct(v) + "' inside arithmetic is not a set operation of the skeleton");
      case OpPolyRule::kCompare:
        return set_not(v, v, "a comparison that depends on x is not a polynomial");
      case OpPolyRule::kNone:
      case OpPolyRule::kNA:  // not reached: the first switch returned
        return set_not(v, v, "'" + construct(v) + "' is not a polynomial");
    }
    HFRT_CHECK_MSG(false, "poly rule " << static_cast<int>(rule));
  }

  /// Set operations whose operands are valid (polynomials, square-root forms or set
  /// operations themselves, not all independent of x) become skeleton nodes (kSet).
  bool classify_set(ValueId v) {
    const Inst& in = fn_.insts[v];
    auto valid = [&](ValueId a) { return info_[a].kind != Kind::kNot; };
    auto is_set = [&](ValueId a) {
      return info_[a].kind == Kind::kSet || info_[a].kind == Kind::kSurf;
    };
    bool set = false;
    ValueId f1, f2;
    if (match_r_function(v, &f1, &f2)) {
      set = valid(f1) && valid(f2) && !(is_scalar(f1) && is_scalar(f2));
    } else {
      switch (op_poly_rule(in.op)) {
        case OpPolyRule::kMinMax:
          set = valid(in.args[0]) && valid(in.args[1]) &&
                !(is_scalar(in.args[0]) && is_scalar(in.args[1]));
          break;
        case OpPolyRule::kNeg:
          set = is_set(in.args[0]);
          break;
        case OpPolyRule::kMul:
          set = (is_set(in.args[0]) && is_scalar(in.args[1])) ||
                (is_scalar(in.args[0]) && is_set(in.args[1]));
          break;
        case OpPolyRule::kDiv:
          set = is_set(in.args[0]) && is_scalar(in.args[1]);
          break;
        case OpPolyRule::kSelect:
          set = is_scalar(in.args[0]) && valid(in.args[1]) && valid(in.args[2]) &&
                (is_set(in.args[1]) || is_set(in.args[2]));
          break;
        case OpPolyRule::kNA:
        case OpPolyRule::kNone:
        case OpPolyRule::kAddSub:
        case OpPolyRule::kSqrt:
        case OpPolyRule::kPow:
        case OpPolyRule::kCompare:
          break;
      }
    }
    if (!set) return false;
    info_[v].kind = Kind::kSet;
    info_[v].origin = v;
    return true;
  }

  bool is_const(ValueId v, double* out) const {
    const Inst& in = fn_.insts[v];
    if (in.op != Op::kConst) return false;
    *out = in.imm;
    return true;
  }

  /// select(lt(abs(b), 1e-6), 0, v) as jit/lower.cpp lower_power emits for `b ^ n`.
  bool is_power_guard(const Inst& in) const {
    double zero = 1, eps = 0;
    const Inst& cond = fn_.insts[in.args[0]];
    if (cond.op != Op::kLt || !is_const(in.args[1], &zero) || zero != 0) return false;
    const Inst& abs = fn_.insts[cond.args[0]];
    if (abs.op != Op::kAbs || !is_const(cond.args[1], &eps) || eps != kHfEps) return false;
    // The guarded value is the base itself or the chain ((b*b)*b)... (or 1/chain).
    const ValueId base = abs.args[0];
    ValueId v = in.args[2];
    if (fn_.insts[v].op == Op::kDiv) v = fn_.insts[v].args[1];
    return v == base || (fn_.insts[v].op == Op::kMul && fn_.insts[v].args[1] == base);
  }

  // ---- skeleton ----------------------------------------------------------------------------
  /// f1 + f2 +- sqrt(f1*f1 + f2*f2): jit/lower.cpp r_function and the library's R-functions.
  bool match_r_function(ValueId v, ValueId* f1, ValueId* f2) const {
    bool plus = false;
    return jit::match_r_function(fn_, v, f1, f2, &plus);
  }

  bool fail(PolyAnalysis* out, ValueId origin, const std::string& why) {
    out->where = origin;
    out->loc = origin < fn_.insts.size() ? fn_.insts[origin].loc : lang::SourceLoc{};
    // Inside a library function every instruction is located at the call: name the function.
    std::string lib = out->loc.valid() ? identifier_at(out->loc) : std::string();
    if (!lib.empty() && lang::find_library_fn(lib)) {
      out->reason = "'" + lib + "' is not a set operation nor a polynomial (" + why + ")";
    } else {
      out->reason = why;
    }
    return false;
  }

  bool visit(ValueId v, PolyAnalysis* out) {
    if (visited_[v]) return true;
    visited_[v] = 1;
    const VInfo& i = info_[v];
    if (i.kind == Kind::kSurf) {
      const Inst& in = fn_.insts[v];
      PolySurfaceLeaf leaf;
      leaf.surface = in.aux;
      leaf.value = v;
      for (int k = 0; k < 3; ++k) leaf.regs[k] = info_[in.args[k]].reg;
      surface_leaves_.push_back(leaf);
      return true;
    }
    if (i.kind == Kind::kPoly && i.reg >= 0) {
      if (i.deg >= 1) out->program.leaves.push_back({i.reg, i.deg, v, false});
      return true;
    }
    const Inst& in = fn_.insts[v];
    const OpPolyRule rule = op_poly_rule(in.op);
    ValueId f1, f2;
    bool node = true;
    bool ok = true;
    if (match_r_function(v, &f1, &f2)) {
      ok = visit(f1, out) && visit(f2, out);
    } else if (rule == OpPolyRule::kMinMax) {
      ok = visit(in.args[0], out) && visit(in.args[1], out);
    } else if (rule == OpPolyRule::kNeg) {
      ok = visit(in.args[0], out);
    } else if (rule == OpPolyRule::kMul && is_scalar(in.args[0])) {
      ok = visit(in.args[1], out);
    } else if ((rule == OpPolyRule::kMul || rule == OpPolyRule::kDiv) && is_scalar(in.args[1])) {
      ok = visit(in.args[0], out);
    } else if (rule == OpPolyRule::kSelect && is_scalar(in.args[0])) {
      ok = visit(in.args[1], out) && visit(in.args[2], out);
    } else if (rule == OpPolyRule::kSelect && is_power_guard(in)) {
      ok = visit(in.args[2], out);
    } else {
      node = false;
    }
    if (node) {
      out->skeleton.push_back(v);
      return ok;
    }
    if (i.kind == Kind::kForm) {
      const int deg = std::max(i.ra >= 0 ? 2 * i.da : 0, 2 * i.db + i.dc);
      if (deg > kPolyMaxDegree) {
        return fail(out, i.origin,
                    "eliminating '" + construct(i.origin) + "' gives a polynomial of degree " +
                        std::to_string(deg) + " > 4");
      }
      // A^2 - B^2 C: zero wherever A + B sqrt(C) is.
      int32_t bb = emit(PolyOp::kMul, 2 * i.db, i.rb, i.rb);
      int32_t bbc = emit(PolyOp::kMul, 2 * i.db + i.dc, bb, i.rc);
      int32_t r = i.ra >= 0 ? emit(PolyOp::kSub, deg, emit(PolyOp::kMul, 2 * i.da, i.ra, i.ra), bbc)
                            : emit(PolyOp::kNeg, deg, bbc);
      if (deg >= 1) out->program.leaves.push_back({r, deg, v, true});
      return true;
    }
    if (i.kind == Kind::kPoly) {
      return fail(out, v, "a polynomial of degree " + std::to_string(i.deg) + " > 4");
    }
    return fail(out, i.origin, i.why);
  }

  /// Keeps only the instructions the leaves need, renumbered.
  void prune(PolyAnalysis* out) {
    const size_t n = prog_.insts.size();
    std::vector<char> live(n, 0);
    for (const PolyLeaf& leaf : out->program.leaves) live[leaf.reg] = 1;
    for (size_t i = n; i-- > 0;) {
      if (!live[i]) continue;
      for (int32_t a : prog_.insts[i].args) {
        if (a >= 0) live[a] = 1;
      }
    }
    std::vector<int32_t> remap(n, -1);
    PolyProgram& p = out->program;
    for (size_t i = 0; i < n; ++i) {
      if (!live[i]) continue;
      PolyInst in = prog_.insts[i];
      for (int32_t& a : in.args) {
        if (a >= 0) a = remap[a];
      }
      remap[i] = static_cast<int32_t>(p.insts.size());
      p.insts.push_back(in);
    }
    for (PolyLeaf& leaf : p.leaves) leaf.reg = remap[leaf.reg];
  }

  const Function& fn_;
  std::vector<VInfo> info_;
  std::vector<char> visited_;
  std::vector<PolySurfaceLeaf> surface_leaves_;
  PolyProgram prog_;  // every emitted instruction; pruned into the result
};

}  // namespace

PolyAnalysis analyze_polynomial(const Function& fn) {
  return Analyzer(fn).run();
}

}  // namespace hfrt::jit
