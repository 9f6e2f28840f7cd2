// Tapes: building one from a straight-line Function, pruning by interval choices, and the
// register code the VMs run. See tape.h.

#include "jit/tape.h"

#include <algorithm>
#include <cmath>

#include "base/check.h"
#include "ir/interval_ops.h"
#include "ir/r_functions.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;

namespace {

constexpr uint32_t kNone = kNoValue;

bool is_choice_op(Op op) {
  return op == Op::kMin || op == Op::kMax || op == Op::kSelect;
}

}  // namespace

/// Builds the SSA nodes of a Function (the friend of Tape that fills its private lists).
class TapeBuilder {
 public:
  static std::unique_ptr<Tape> build(const Function& fn, std::span<const double> params,
                                     std::string* why) {
    auto fail = [&](std::string reason) -> std::unique_ptr<Tape> {
      if (why) *why = std::move(reason);
      return nullptr;
    };
    if (fn.has_control_flow) return fail("control flow (if / while)");
    if (fn.result == kNoValue) return fail("no result");
    auto tape = std::make_unique<Tape>();
    tape->num_inputs_ = fn.num_inputs;
    std::vector<Tape::Node>& nodes = tape->nodes_;
    std::vector<uint32_t> val(fn.insts.size(), kNone);
    std::vector<uint32_t> slot(static_cast<size_t>(std::max(fn.num_slots, 0)), kNone);
    const RFunctionNodes r = find_r_functions(fn);
    auto constant = [&](double v) {
      Tape::Node n;
      n.op = Op::kConst;
      n.imm = v;
      nodes.push_back(n);
      return static_cast<uint32_t>(nodes.size() - 1);
    };
    auto slot_value = [&](int s) {
      if (slot[s] == kNone) {
        // Never stored: the slot's initial value (NaN = undefined; lowering checks it).
        slot[s] = constant(s < static_cast<int>(fn.slot_init.size()) ? fn.slot_init[s] : 0.0);
      }
      return slot[s];
    };
    // A constant array index (1-based) of a kLoadIdx/kStoreIdx, or -1.
    auto const_index = [&](const Inst& in) -> int {
      const Tape::Node& n = nodes[val[in.args[0]]];
      if (n.op != Op::kConst || n.imm != std::trunc(n.imm) || n.imm < 1 || n.imm > in.imm) {
        return -1;
      }
      return static_cast<int>(n.imm);
    };
    for (size_t i = 0; i < fn.insts.size(); ++i) {
      const Inst& in = fn.insts[i];
      switch (in.op) {
        case Op::kConst:
          val[i] = constant(in.imm);
          break;
        case Op::kParam:
          val[i] = constant(in.aux < static_cast<int>(params.size()) ? params[in.aux] : 0.0);
          break;
        case Op::kInput: {
          Tape::Node n;
          n.op = Op::kInput;
          n.aux = in.aux;
          nodes.push_back(n);
          val[i] = static_cast<uint32_t>(nodes.size() - 1);
          break;
        }
        case Op::kLoadSlot:
          val[i] = slot_value(in.aux);
          break;
        case Op::kStoreSlot:
          slot[in.aux] = val[in.args[0]];
          break;
        case Op::kLoadIdx:
        case Op::kStoreIdx: {
          const int k = const_index(in);
          if (k < 0) return fail("an array index that is not a constant");
          const int s = in.aux + k - 1;
          if (in.op == Op::kLoadIdx) {
            val[i] = slot_value(s);
          } else {
            slot[s] = val[in.args[1]];
          }
          break;
        }
        case Op::kTableLoad:
          return fail("a table");
        case Op::kSurface:
          return fail("a mesh or patch leaf");
        case Op::kCheck: {
          Tape::Node n;
          n.op = Op::kCheck;
          n.args[0] = val[in.args[0]];
          nodes.push_back(n);
          break;
        }
        case Op::kIf:
        case Op::kElse:
        case Op::kEndIf:
        case Op::kLoop:
        case Op::kLoopTest:
        case Op::kEndLoop:
          return fail("control flow (if / while)");
          HFRT_OP_CASES_ARITH {
            Tape::Node n;
            n.op = in.op;
            for (int k = 0; k < op_num_args(in.op); ++k) n.args[k] = val[in.args[k]];
            if (r.kind[i]) {
              n.r_kind = r.kind[i];
              n.r_args[0] = val[r.args[2 * i]];
              n.r_args[1] = val[r.args[2 * i + 1]];
            }
            nodes.push_back(n);
            val[i] = static_cast<uint32_t>(nodes.size() - 1);
            break;
          }
      }
    }
    tape->result_ = val[fn.result];
    HFRT_CHECK(tape->result_ != kNone);
    tape->finish();
    return tape;
  }
};

std::unique_ptr<Tape> Tape::build(const Function& fn, std::span<const double> params,
                                  std::string* why) {
  return TapeBuilder::build(fn, params, why);
}

bool Tape::prune(std::span<const uint8_t> choices, std::span<const uint8_t> check_can_fire,
                 Tape* child) const {
  HFRT_CHECK(child != this);
  HFRT_CHECK(choices.size() >= code_.size() && check_can_fire.size() >= code_.size());
  const size_t n = nodes_.size();
  // What each node becomes: itself, or (a decided choice) the node of its chosen operand.
  std::vector<uint32_t>& alias = child->last_use_;  // scratch, reused below by allocate()
  alias.resize(n);
  bool changed = false;
  for (size_t i = 0; i < n; ++i) {
    const Node& nd = nodes_[i];
    alias[i] = static_cast<uint32_t>(i);
    if (nd.code < 0) continue;
    if (is_choice_op(nd.op)) {
      const uint8_t c = choices[static_cast<size_t>(nd.code)];
      if (c == kChoiceLeft || c == kChoiceRight) {
        // One operand is the result everywhere in the box: the node is that operand.
        int k = c == kChoiceLeft ? 0 : 1;
        if (nd.op == Op::kSelect) ++k;  // select's values are arguments 1 and 2
        alias[i] = alias[nd.args[k]];
        changed = true;
      }
    } else if (nd.op == Op::kCheck && !check_can_fire[static_cast<size_t>(nd.code)]) {
      alias[i] = kNone;  // cannot fire anywhere in the box
      changed = true;
    }
  }
  if (!changed) return false;
  // Liveness on this tape's nodes, through the aliases, from the result and the checks kept.
  std::vector<uint8_t>& live = child->live_;
  live.assign(n, 0);
  live[alias[result_]] = 1;
  for (size_t i = n; i-- > 0;) {
    const Node& nd = nodes_[i];
    if (nd.op == Op::kCheck && alias[i] != kNone) live[i] = 1;
    if (!live[i] || alias[i] != i) continue;
    for (uint32_t a : nd.args) {
      if (a != kNone) live[alias[a]] = 1;
    }
    for (uint32_t a : nd.r_args) {
      if (a != kNone) live[alias[a]] = 1;
    }
  }
  // The live nodes, in order, with their arguments renumbered.
  std::vector<uint32_t>& remap = child->remap_;
  remap.resize(n);
  child->nodes_.clear();
  child->num_inputs_ = num_inputs_;
  for (size_t i = 0; i < n; ++i) {
    if (!live[i]) continue;
    Node m = nodes_[i];
    for (uint32_t& a : m.args) {
      if (a != kNone) a = remap[alias[a]];
    }
    for (uint32_t& a : m.r_args) {
      if (a != kNone) a = remap[alias[a]];
    }
    remap[i] = static_cast<uint32_t>(child->nodes_.size());
    child->nodes_.push_back(m);
  }
  child->result_ = remap[alias[result_]];
  child->allocate();
  return true;
}

void Tape::finish() {
  const size_t n = nodes_.size();
  // Dead code elimination: the result and the checks are the roots.
  live_.assign(n, 0);
  live_[result_] = 1;
  for (size_t i = n; i-- > 0;) {
    Node& nd = nodes_[i];
    if (nd.op == Op::kCheck) live_[i] = 1;
    if (!live_[i]) continue;
    for (uint32_t a : nd.args) {
      if (a != kNone) live_[a] = 1;
    }
    for (uint32_t a : nd.r_args) {
      if (a != kNone) live_[a] = 1;
    }
  }
  // Compaction (in place: live nodes keep their order).
  remap_.assign(n, kNone);
  size_t m = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!live_[i]) continue;
    Node nd = nodes_[i];
    for (uint32_t& a : nd.args) {
      if (a != kNone) a = remap_[a];
    }
    for (uint32_t& a : nd.r_args) {
      if (a != kNone) a = remap_[a];
    }
    remap_[i] = static_cast<uint32_t>(m);
    nodes_[m++] = nd;
  }
  nodes_.resize(m);
  result_ = remap_[result_];
  allocate();
}

void Tape::allocate() {
  const uint32_t m = static_cast<uint32_t>(nodes_.size());
  // Which arguments are registers: a constant second (else first) argument of a binary op is
  // an immediate; every other use of a constant needs it in a register.
  auto imm_arg = [&](const Node& nd) -> int {
    if (op_num_args(nd.op) != 2 || nd.op == Op::kCheck) return -1;
    if (nodes_[nd.args[1]].op == Op::kConst) return 1;
    if (nodes_[nd.args[0]].op == Op::kConst) return 0;
    return -1;
  };
  // Last use of each node as a register (by instruction position = node index here);
  // UINT32_MAX for the result, which must survive to the end.
  last_use_.assign(m, kNone);
  std::vector<uint8_t>& needs_reg = live_;  // reused: 1 = the node gets a register
  needs_reg.assign(m, 0);
  auto use = [&](uint32_t a, uint32_t at) {
    needs_reg[a] = 1;
    last_use_[a] = at;
  };
  for (uint32_t i = 0; i < m; ++i) {
    const Node& nd = nodes_[i];
    if (nd.op != Op::kConst) needs_reg[i] = 1;
    const int imm = imm_arg(nd);
    for (int k = 0; k < 3; ++k) {
      if (nd.args[k] != kNone && k != imm) use(nd.args[k], i);
    }
    for (uint32_t a : nd.r_args) {
      if (a != kNone) use(a, i);
    }
  }
  needs_reg[result_] = 1;
  last_use_[result_] = UINT32_MAX;

  // Linear scan: operands' registers are freed after their last use, before the result is
  // allocated (an instruction may write a register it reads: the VMs read first).
  code_.clear();
  reg_of_.assign(m, kNone);
  free_regs_.clear();
  num_regs_ = 0;
  num_choices_ = 0;
  for (uint32_t i = 0; i < m; ++i) {
    Node& nd = nodes_[i];
    nd.code = -1;
    if (!needs_reg[i] && nd.op != Op::kCheck) continue;  // a constant used only as immediate
    TapeInst t;
    t.op = nd.op;
    const int imm = imm_arg(nd);
    if (nd.op == Op::kConst) t.imm = nd.imm;
    if (nd.op == Op::kInput) t.a = static_cast<uint32_t>(nd.aux);
    if (imm >= 0) {
      t.flags |= imm == 0 ? TapeInst::kImmA : TapeInst::kImmB;
      t.imm = nodes_[nd.args[imm]].imm;
    }
    uint32_t* regs[3] = {&t.a, &t.b, &t.c};
    for (int k = 0; k < 3; ++k) {
      if (nd.args[k] != kNone && k != imm) *regs[k] = reg_of_[nd.args[k]];
    }
    if (op_num_args(nd.op) == 2 && nd.args[0] == nd.args[1]) t.flags |= TapeInst::kSame;
    if (nd.r_kind) {
      t.flags |= nd.r_kind == 1 ? TapeInst::kRPlus : TapeInst::kRMinus;
      t.r1 = reg_of_[nd.r_args[0]];
      t.r2 = reg_of_[nd.r_args[1]];
    }
    // Free the registers whose value dies here (each once, even if used twice).
    auto release = [&](uint32_t a) {
      if (a != kNone && last_use_[a] == i && reg_of_[a] != kNone) {
        free_regs_.push_back(reg_of_[a]);
        reg_of_[a] = kNone;
      }
    };
    for (uint32_t a : nd.args) release(a);
    for (uint32_t a : nd.r_args) release(a);
    if (nd.op != Op::kCheck) {
      uint32_t r;
      if (!free_regs_.empty()) {
        r = free_regs_.back();
        free_regs_.pop_back();
      } else {
        r = num_regs_++;
      }
      reg_of_[i] = r;
      t.out = r;
      // A value nobody reads (possible only for the result) keeps its register.
      if (last_use_[i] == kNone && i != result_) {
        free_regs_.push_back(r);
        reg_of_[i] = kNone;
      }
    }
    if (is_choice_op(nd.op)) ++num_choices_;
    nd.code = static_cast<int32_t>(code_.size());
    code_.push_back(t);
  }
  result_reg_ = reg_of_[result_];
  HFRT_CHECK(result_reg_ != kNone);
}

}  // namespace hfrt::jit
