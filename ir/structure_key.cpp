// The key of compiled-code sharing (structure_key.h).
#include "ir/structure_key.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

std::string structure_key(const Function& fn) {
  std::string key;
  auto put = [&key](const void* p, size_t size) { key.append(static_cast<const char*>(p), size); };
  auto put_int = [&](int64_t v) { put(&v, sizeof v); };
  auto put_double = [&](double v) { put(&v, sizeof v); };
  put_int(fn.num_inputs);
  put_int(fn.num_params);
  put_int(fn.hoisted_params_from);
  put_int(fn.num_slots);
  put_int(fn.result);
  put_int(int64_t(fn.insts.size()));
  for (const Inst& in : fn.insts) {
    put_int(int64_t(in.op));
    for (ValueId a : in.args) put_int(a);
    put_double(in.imm);
    put_int(in.aux);
    if (in.op != Op::kParam) {
      put_int(in.loc.line);
      put_int(in.loc.col);
    }
  }
  put_int(int64_t(fn.slot_init.size()));
  for (double v : fn.slot_init) put_double(v);
  put_int(int64_t(fn.s_slots.size()));
  for (int32_t s : fn.s_slots) put_int(s);
  put_int(int64_t(fn.tables.size()));
  for (const auto& t : fn.tables) {
    put_int(int64_t(t.size()));
    for (double v : t) put_double(v);
  }
  put_int(int64_t(fn.surfaces.size()));
  for (const auto& s : fn.surfaces) {
    const void* p = s.get();
    put(&p, sizeof p);
  }
  return key;
}

}  // namespace hfrt::ir
