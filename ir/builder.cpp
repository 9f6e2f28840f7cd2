// IrBuilder: the only way IR is made. Three local optimisations happen as instructions are
// appended, so every producer (the AST lowering, the library in stdlib/) gets them for free:
//  - constant folding of pure ops through ir/scalar_ops.h, the same code the interpreter
//    runs, so folding never changes a value;
//  - common-subexpression sharing (hash-consing) of pure ops and of identical checks, scoped
//    to the regions that enclose the insertion point;
//  - store-to-load forwarding of slots within straight-line code, so variables, copied x/a
//    arrays and the like become plain SSA data flow.
// finish() then removes dead code (values nobody uses, stores to slots nobody reads) and
// verifies the function.
#include "ir/builder.h"

#include <cmath>
#include <cstring>
#include <unordered_map>
#include <unordered_set>

#include "base/check.h"
#include "ir/print.h"
#include "ir/scalar_ops.h"
#include "ir/verify.h"

namespace hfrt::ir {

namespace {

struct Key {
  Op op;
  ValueId args[3];
  uint64_t imm_bits;
  int32_t aux;
  bool operator==(const Key& o) const {
    return op == o.op && args[0] == o.args[0] && args[1] == o.args[1] && args[2] == o.args[2] &&
           imm_bits == o.imm_bits && aux == o.aux;
  }
};

struct KeyHash {
  size_t operator()(const Key& k) const {
    uint64_t h = static_cast<uint64_t>(k.op) * 0x9E3779B97F4A7C15ull;
    auto mix = [&](uint64_t v) {
      h = (h ^ v) * 0xBF58476D1CE4E5B9ull;
      h ^= h >> 31;
    };
    mix(k.args[0]);
    mix(k.args[1]);
    mix(k.args[2]);
    mix(k.imm_bits);
    mix(static_cast<uint32_t>(k.aux));
    return static_cast<size_t>(h);
  }
};

uint64_t bits_of(double v) {
  uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

enum class FrameKind { kThen, kElse, kLoop };

struct Frame {
  FrameKind kind;
  size_t cse_mark;                                // cse_log size when the region opened
  std::unordered_map<int, ValueId> known_before;  // forwarding state at the region's entry
  std::unordered_set<int> stored;                 // slots stored in this region (nested included)
  std::unordered_set<int> stored_then;            // if with else: what the then-part stored
};

struct BuilderState {
  std::unordered_map<Key, ValueId, KeyHash> cse;
  std::vector<Key> cse_log;  // keys in insertion order, popped when their region closes
  std::unordered_map<int, ValueId> known;  // slot -> value it holds here (store forwarding)
  std::vector<bool> ever_stored;           // slot stored anywhere before this point
  std::vector<Frame> frames;
  int open_loops = 0;
  bool finished = false;
};

}  // namespace

struct IrBuilder::Impl : BuilderState {};

IrBuilder::IrBuilder(Function& fn) : fn_(fn), impl_(std::make_shared<Impl>()) {
  HFRT_CHECK_EQ(fn_.slot_init.size(), static_cast<size_t>(fn_.num_slots));
  impl_->ever_stored.assign(fn_.num_slots, false);
}

namespace {

ValueId append(Function& fn, lang::SourceLoc loc, Op op, ValueId a0 = kNoValue,
               ValueId a1 = kNoValue, ValueId a2 = kNoValue, double imm = 0, int32_t aux = 0) {
  const ValueId args[3] = {a0, a1, a2};
  for (int k = 0; k < op_num_args(op); ++k) {
    HFRT_CHECK_MSG(args[k] < fn.insts.size() && op_has_value(fn.insts[args[k]].op),
                   "IrBuilder: bad argument %" << args[k] << " of " << op_name(op));
  }
  Inst in;
  in.op = op;
  in.args[0] = a0;
  in.args[1] = a1;
  in.args[2] = a2;
  in.imm = imm;
  in.aux = aux;
  in.loc = loc;
  fn.insts.push_back(in);
  return static_cast<ValueId>(fn.insts.size() - 1);
}

}  // namespace

namespace {

// Appends a pure op unless an identical one is visible from here.
ValueId emit_pure(Function& fn, BuilderState& impl, lang::SourceLoc loc, Op op, ValueId a0,
                  ValueId a1, ValueId a2, double imm, int32_t aux) {
  Key key{op, {a0, a1, a2}, bits_of(imm), aux};
  auto it = impl.cse.find(key);
  if (it != impl.cse.end()) return it->second;
  ValueId v = append(fn, loc, op, a0, a1, a2, imm, aux);
  impl.cse.emplace(key, v);
  impl.cse_log.push_back(key);
  return v;
}

bool is_const(const Function& fn, ValueId v, double* out = nullptr) {
  if (v >= fn.insts.size() || fn.insts[v].op != Op::kConst) return false;
  if (out) *out = fn.insts[v].imm;
  return true;
}

}  // namespace

ValueId IrBuilder::constant(double v) {
  return emit_pure(fn_, *impl_, loc_, Op::kConst, kNoValue, kNoValue, kNoValue, v, 0);
}

ValueId IrBuilder::input(int index0) {
  HFRT_CHECK(index0 >= 0 && index0 < fn_.num_inputs);
  return emit_pure(fn_, *impl_, loc_, Op::kInput, kNoValue, kNoValue, kNoValue, 0, index0);
}

ValueId IrBuilder::param(int index0) {
  HFRT_CHECK(index0 >= 0 && index0 < fn_.num_params);
  return emit_pure(fn_, *impl_, loc_, Op::kParam, kNoValue, kNoValue, kNoValue, 0, index0);
}

ValueId IrBuilder::unary(Op op, ValueId a) {
  HFRT_CHECK_MSG(op_num_args(op) == 1 && op_is_arith(op), "unary() with " << op_name(op));
  double ca;
  if (is_const(fn_, a, &ca)) return constant(apply_op(op, ca, 0, 0));
  // Comparison and logic results are already 0/1: their truth value is themselves.
  if (op == Op::kTruth && op_is_boolean(fn_.insts[a].op)) return a;
  return emit_pure(fn_, *impl_, loc_, op, a, kNoValue, kNoValue, 0, 0);
}

ValueId IrBuilder::binary(Op op, ValueId a, ValueId b) {
  HFRT_CHECK_MSG(op_num_args(op) == 2 && op_is_arith(op), "binary() with " << op_name(op));
  double ca, cb;
  if (is_const(fn_, a, &ca) && is_const(fn_, b, &cb)) return constant(apply_op(op, ca, cb, 0));
  return emit_pure(fn_, *impl_, loc_, op, a, b, kNoValue, 0, 0);
}

ValueId IrBuilder::select(ValueId cond, ValueId a, ValueId b) {
  double cc;
  if (is_const(fn_, cond, &cc)) return cc != 0 ? a : b;
  if (a == b) return a;
  return emit_pure(fn_, *impl_, loc_, Op::kSelect, cond, a, b, 0, 0);
}

ValueId IrBuilder::table_load(int table, ValueId index0) {
  HFRT_CHECK(table >= 0 && table < static_cast<int>(fn_.tables.size()));
  double ci;
  const auto& t = fn_.tables[table];
  if (is_const(fn_, index0, &ci) && ci >= 0 && ci < static_cast<double>(t.size()) &&
      ci == std::floor(ci)) {
    return constant(t[static_cast<size_t>(ci)]);
  }
  return emit_pure(fn_, *impl_, loc_, Op::kTableLoad, index0, kNoValue, kNoValue, 0, table);
}

int IrBuilder::add_table(std::vector<double> values) {
  HFRT_CHECK(!values.empty());
  fn_.tables.push_back(std::move(values));
  return static_cast<int>(fn_.tables.size() - 1);
}

ValueId IrBuilder::surface(int index, ValueId x, ValueId y, ValueId z) {
  HFRT_CHECK(index >= 0 && index < static_cast<int>(fn_.surfaces.size()));
  return emit_pure(fn_, *impl_, loc_, Op::kSurface, x, y, z, 0, index);
}

int IrBuilder::add_surface(std::shared_ptr<const geom::Surface> s) {
  HFRT_CHECK(s != nullptr);
  fn_.surface_uses.resize(fn_.surfaces.size(), 0);
  for (size_t i = 0; i < fn_.surfaces.size(); ++i) {
    if (fn_.surfaces[i] == s) {
      ++fn_.surface_uses[i];
      return static_cast<int>(i);
    }
  }
  fn_.surfaces.push_back(std::move(s));
  fn_.surface_uses.push_back(1);
  return static_cast<int>(fn_.surfaces.size() - 1);
}

int IrBuilder::new_slot(double init) {
  fn_.slot_init.push_back(init);
  impl_->ever_stored.push_back(false);
  return fn_.num_slots++;
}

ValueId IrBuilder::load(int slot) {
  HFRT_CHECK(slot >= 0 && slot < fn_.num_slots);
  auto it = impl_->known.find(slot);
  if (it != impl_->known.end()) return it->second;
  // Never stored so far and no loop back edge can bring a store here: the initial value.
  const double init = fn_.slot_init[slot];
  if (!impl_->ever_stored[slot] && impl_->open_loops == 0 && !std::isnan(init))
    return constant(init);
  ValueId v = append(fn_, loc_, Op::kLoadSlot, kNoValue, kNoValue, kNoValue, 0, slot);
  // Later loads in the same straight-line code see the same value.
  impl_->known[slot] = v;
  return v;
}

namespace {

void note_store(BuilderState& impl, int slot) {
  impl.ever_stored[slot] = true;
  if (!impl.frames.empty()) impl.frames.back().stored.insert(slot);
}

}  // namespace

void IrBuilder::store(int slot, ValueId v) {
  HFRT_CHECK(slot >= 0 && slot < fn_.num_slots);
  auto it = impl_->known.find(slot);
  if (it != impl_->known.end() && it->second == v) return;  // the slot already holds v
  append(fn_, loc_, Op::kStoreSlot, v, kNoValue, kNoValue, 0, slot);
  impl_->known[slot] = v;
  note_store(*impl_, slot);
}

ValueId IrBuilder::load_index(int base_slot, int size, ValueId index1) {
  HFRT_CHECK(size >= 1 && base_slot >= 0 && base_slot + size <= fn_.num_slots);
  double ci;
  if (is_const(fn_, index1, &ci) && ci >= 1 && ci <= size && ci == std::floor(ci)) {
    return load(base_slot + static_cast<int>(ci) - 1);
  }
  return append(fn_, loc_, Op::kLoadIdx, index1, kNoValue, kNoValue, size, base_slot);
}

void IrBuilder::store_index(int base_slot, int size, ValueId index1, ValueId v) {
  HFRT_CHECK(size >= 1 && base_slot >= 0 && base_slot + size <= fn_.num_slots);
  double ci;
  if (is_const(fn_, index1, &ci) && ci >= 1 && ci <= size && ci == std::floor(ci)) {
    store(base_slot + static_cast<int>(ci) - 1, v);
    return;
  }
  append(fn_, loc_, Op::kStoreIdx, index1, v, kNoValue, size, base_slot);
  for (int s = base_slot; s < base_slot + size; ++s) {
    impl_->known.erase(s);
    note_store(*impl_, s);
  }
}

void IrBuilder::check(ValueId cond, ErrorKind kind) {
  double cc;
  if (is_const(fn_, cond, &cc) && cc == 0) return;  // can never fire
  // An identical check that is visible from here already fired if this one would.
  emit_pure(fn_, *impl_, loc_, Op::kCheck, cond, kNoValue, kNoValue, 0, static_cast<int32_t>(kind));
}

namespace {

void pop_cse(BuilderState& impl, size_t mark) {
  while (impl.cse_log.size() > mark) {
    impl.cse.erase(impl.cse_log.back());
    impl.cse_log.pop_back();
  }
}

// Forwarding state after a region: what held before it, minus what the region may have stored.
void restore_known(BuilderState& impl, const Frame& f, const std::unordered_set<int>& stored) {
  impl.known = f.known_before;
  for (int s : stored) impl.known.erase(s);
}

void close_into_parent(BuilderState& impl, const std::unordered_set<int>& stored) {
  if (impl.frames.empty()) return;
  impl.frames.back().stored.insert(stored.begin(), stored.end());
}

}  // namespace

void IrBuilder::begin_if(ValueId cond) {
  append(fn_, loc_, Op::kIf, cond);
  fn_.has_control_flow = true;
  impl_->frames.push_back({FrameKind::kThen, impl_->cse_log.size(), impl_->known, {}, {}});
}

void IrBuilder::begin_else() {
  HFRT_CHECK(!impl_->frames.empty() && impl_->frames.back().kind == FrameKind::kThen);
  append(fn_, loc_, Op::kElse);
  Frame& f = impl_->frames.back();
  pop_cse(*impl_, f.cse_mark);
  f.kind = FrameKind::kElse;
  f.stored_then = std::move(f.stored);
  f.stored.clear();
  impl_->known = f.known_before;  // the else-part starts from the state before the if
}

void IrBuilder::end_if() {
  HFRT_CHECK(!impl_->frames.empty() && impl_->frames.back().kind != FrameKind::kLoop);
  append(fn_, loc_, Op::kEndIf);
  Frame f = std::move(impl_->frames.back());
  impl_->frames.pop_back();
  pop_cse(*impl_, f.cse_mark);
  f.stored.insert(f.stored_then.begin(), f.stored_then.end());
  restore_known(*impl_, f, f.stored);
  close_into_parent(*impl_, f.stored);
}

void IrBuilder::begin_loop() {
  append(fn_, loc_, Op::kLoop);
  fn_.has_control_flow = true;
  impl_->frames.push_back({FrameKind::kLoop, impl_->cse_log.size(), impl_->known, {}, {}});
  ++impl_->open_loops;
  // The body may store any slot and the back edge brings that to the header: forget all.
  impl_->known.clear();
}

void IrBuilder::loop_test(ValueId cond) {
  HFRT_CHECK(!impl_->frames.empty() && impl_->frames.back().kind == FrameKind::kLoop);
  append(fn_, loc_, Op::kLoopTest, cond);
}

void IrBuilder::end_loop() {
  HFRT_CHECK(!impl_->frames.empty() && impl_->frames.back().kind == FrameKind::kLoop);
  append(fn_, loc_, Op::kEndLoop);
  Frame f = std::move(impl_->frames.back());
  impl_->frames.pop_back();
  --impl_->open_loops;
  pop_cse(*impl_, f.cse_mark);
  restore_known(*impl_, f, f.stored);
  close_into_parent(*impl_, f.stored);
}

namespace {

// Removes instructions whose effects nobody observes: values that no live instruction uses,
// loads of them, and stores to slots that are never read (nor returned as s). Checks and
// control-flow markers always stay. Renumbers the remaining values.
void eliminate_dead_code(Function& fn) {
  const size_t n = fn.insts.size();
  std::vector<bool> live(n, false);
  std::vector<bool> slot_read(fn.num_slots, false);
  for (int32_t s : fn.s_slots) slot_read[s] = true;
  auto store_live = [&](const Inst& in) {
    if (in.op == Op::kStoreSlot) return static_cast<bool>(slot_read[in.aux]);
    for (int s = in.aux; s < in.aux + static_cast<int>(in.imm); ++s) {
      if (slot_read[s]) return true;
    }
    return false;
  };
  bool changed = true;
  while (changed) {
    changed = false;
    for (size_t i = n; i-- > 0;) {
      const Inst& in = fn.insts[i];
      if (!live[i]) {
        bool root = i == fn.result || in.op == Op::kCheck ||
                    (op_flags_of(in.op) & op_flags::kCtl) ||
                    ((in.op == Op::kStoreSlot || in.op == Op::kStoreIdx) && store_live(in));
        if (!root) continue;
        live[i] = true;
        changed = true;
      }
      for (int k = 0; k < op_num_args(in.op); ++k) {
        if (!live[in.args[k]]) {
          live[in.args[k]] = true;
          changed = true;
        }
      }
      if (in.op == Op::kLoadSlot && !slot_read[in.aux]) {
        slot_read[in.aux] = true;
        changed = true;
      } else if (in.op == Op::kLoadIdx) {
        for (int s = in.aux; s < in.aux + static_cast<int>(in.imm); ++s) {
          if (!slot_read[s]) {
            slot_read[s] = true;
            changed = true;
          }
        }
      }
    }
  }
  std::vector<ValueId> remap(n, kNoValue);
  std::vector<Inst> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (!live[i]) continue;
    Inst in = fn.insts[i];
    for (int k = 0; k < op_num_args(in.op); ++k) in.args[k] = remap[in.args[k]];
    remap[i] = static_cast<ValueId>(out.size());
    out.push_back(in);
  }
  fn.insts = std::move(out);
  if (fn.result != kNoValue) fn.result = remap[fn.result];
}

}  // namespace

void IrBuilder::finish(ValueId result) {
  HFRT_CHECK(!impl_->finished);
  HFRT_CHECK_MSG(impl_->frames.empty(), "IrBuilder::finish inside an open if or loop");
  HFRT_CHECK(result < fn_.insts.size() && op_has_value(fn_.insts[result].op));
  impl_->finished = true;
  fn_.result = result;
  eliminate_dead_code(fn_);
  fn_.has_control_flow = false;
  for (const Inst& in : fn_.insts) {
    if (in.op == Op::kIf || in.op == Op::kLoop) fn_.has_control_flow = true;
  }
  std::string err = verify(fn_);
  HFRT_CHECK_MSG(err.empty(), "IrBuilder produced malformed IR: " << err << "\n" << print(fn_));
}

}  // namespace hfrt::ir
