#pragma once
// Tapes: a straight-line Function as a compact instruction list over a small register file,
// and its pruning for a box (libfive / Fidget style). The interval VM (tape_vm.h) evaluates a
// tape over a box and records, per kMin/kMax/kSelect, which operand can be the result there
// (the kChoice bits of ir/interval_ops.h); prune() then builds the child tape for that box,
// in which every min/max/select with one possible operand is that operand, followed by dead
// code elimination and register allocation. Tapes shrink level by level of a recursive
// subdivision, so most points are evaluated by a few dozen instructions instead of thousands.
//
// Which functions have a tape (Tape::build): straight-line ones (no kIf/kLoop), without
// tables and mesh/patch leaves. Slots are allowed (without control flow a load reads the last
// store: they become SSA values), array elements only at constant indices. kCheck is kept: a
// check whose argument may be nonzero over the box stays in the child tape; one that cannot
// fire over the box is dropped (like a decided choice). Parameters (kParam) are constants of
// the tape: build one per parameter vector.
//
// Soundness: the interval domain is sound for the f64 scalar evaluation (jit/interval.h), so
// the pruned tape evaluated in double gives bit for bit the full tape's value at every point
// of the box. In float (the renderer's precision), a pruned choice or check can differ from
// the full tape's only where the float rounding of an operand contradicts the f64 enclosure,
// i.e. where two operands (or a check's argument and 0) are within rounding of each other.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ir/ir.h"

namespace hfrt::jit {

/// One instruction of a tape, as the VMs run it: registers, and an optional constant operand.
struct TapeInst {
  static constexpr uint8_t kImmA = 1;     ///< argument 0 is `imm` (not register a)
  static constexpr uint8_t kImmB = 2;     ///< argument 1 is `imm`
  static constexpr uint8_t kSame = 4;     ///< arguments 0 and 1 are the same value (x*x)
  static constexpr uint8_t kRPlus = 8;    ///< an R-function union node (r_function_interval)
  static constexpr uint8_t kRMinus = 16;  ///< an R-function intersection node
  ir::Op op = ir::Op::kConst;
  uint8_t flags = 0;
  uint32_t out = 0;              ///< the register written
  uint32_t a = 0, b = 0, c = 0;  ///< argument registers (kInput: the input index in a)
  uint32_t r1 = 0, r2 = 0;       ///< the R-function node's f1, f2 registers (kRPlus / kRMinus)
  double imm = 0;                ///< kConst value, or the constant argument (kImmA / kImmB)
};

/// A straight-line program with SSA structure (for pruning) and register code (for the VMs).
/// Buffers are reused: prune() into an existing tape does not allocate once it has grown.
class Tape {
 public:
  /// The tape of `fn` with parameters `params` (missing ones are 0), or null with `*why`
  /// (when given) saying what the function has that tapes do not support.
  static std::unique_ptr<Tape> build(const ir::Function& fn, std::span<const double> params,
                                     std::string* why = nullptr);

  /// The register code, in order; the result is in register result_reg().
  std::span<const TapeInst> code() const { return code_; }
  uint32_t result_reg() const { return result_reg_; }
  uint32_t num_regs() const { return num_regs_; }
  int num_inputs() const { return num_inputs_; }
  /// Instructions the VMs run (code().size()).
  size_t length() const { return code_.size(); }
  /// kMin/kMax/kSelect instructions left (those whose choice can still prune).
  size_t num_choices() const { return num_choices_; }

  /// The child of this tape for a box over which the interval VM recorded `choices` (one
  /// byte per instruction of code(), kChoice bits; `check_can_fire` likewise per instruction,
  /// 1 where a kCheck's argument may be nonzero). Overwrites `*child` (reusing its buffers)
  /// and returns true; returns false, leaving `*child` as it was, when nothing was decided
  /// over the box (the child would be this tape: use this one).
  bool prune(std::span<const uint8_t> choices, std::span<const uint8_t> check_can_fire,
             Tape* child) const;

 private:
  /// The SSA form: one node per value; args index earlier nodes (kNoValue: none).
  struct Node {
    ir::Op op = ir::Op::kConst;
    uint32_t args[3] = {ir::kNoValue, ir::kNoValue, ir::kNoValue};
    uint32_t r_args[2] = {ir::kNoValue, ir::kNoValue};
    uint8_t r_kind = 0;  ///< 0, 1 (union) or 2 (intersection): ir/r_functions.h
    int32_t aux = 0;     ///< kInput index
    double imm = 0;      ///< kConst value
    int32_t code = -1;   ///< its instruction in code_, or -1 (a constant folded into its uses)
  };
  friend class TapeBuilder;

  /// Dead code elimination from the result and the checks, then allocate().
  void finish();
  /// The register code of nodes_ (all live).
  void allocate();

  std::vector<Node> nodes_;
  uint32_t result_ = ir::kNoValue;
  std::vector<TapeInst> code_;
  uint32_t result_reg_ = 0;
  uint32_t num_regs_ = 0;
  int num_inputs_ = 0;
  size_t num_choices_ = 0;
  // Scratch of prune() and finish() (kept to avoid allocation).
  std::vector<uint32_t> remap_, last_use_, reg_of_, free_regs_;
  std::vector<uint8_t> live_;
};

}  // namespace hfrt::jit
