// Blends (library.md §4), distance blends (§8) and hfSawtooth (§9).
#include <cmath>

#include "base/check.h"
#include "ir/builder.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

V blend(Call& c, bool uni) {
  V f1 = c.real(0), f2 = c.real(1), a0 = c.real(2), a1 = c.real(3), a2 = c.real(4);
  V root = sqrt(f1 * f1 + f2 * f2);
  V base = uni ? f2 + f1 + root : f2 + f1 - root;
  return base + a0 / (1.0 + sq(f1 / a1) + sq(f2 / a2));
}

V dblend(Call& c, bool uni) {
  V f1 = c.real(0), f2 = c.real(1), r = c.real(2);
  V in_strip = land(le(f1 - r, f2), le(f2, f1 + r));
  V b = uni ? -2.0 * f1 - 4.0 * r - 2.0 * f2 : -2.0 * f1 + 4.0 * r - 2.0 * f2;
  V cc = uni ? f1 * f1 + f2 * f2 + r * r + 2.0 * f1 * r + 2.0 * f2 * r
             : f1 * f1 + f2 * f2 + r * r - 2.0 * f1 * r - 2.0 * f2 * r;
  V ds = b * b - 8.0 * cc;
  V root = uni ? (-b - sqrt(ds)) / 4.0 : (-b + sqrt(ds)) / 4.0;
  V strip = sel(ge(ds, 0.0), root, 0.0);
  // Outside the strip: the tests in the original's order (the second may override).
  V outside = uni ? sel(gt(f2, f1 + r), f2, sel(lt(f2, f1 - r), f1, 0.0))
                  : sel(gt(f2, f1 + r), f1, sel(lt(f2, f1 - r), f2, 0.0));
  return sel(in_strip, strip, outside);
}

// Iterations of hfSawtooth's sum when n is not a compile-time constant are capped here so
// that a huge n cannot hang the evaluation (the original would loop n - 2 times).
constexpr double kSawtoothMaxTerms = 1e6;

V sawtooth(Call& c) {
  V t = c.real(0), n = c.real(1), a = c.real(2), freq = c.real(3);
  const double two_pi = 2.0 * kPi;
  V scale = 2.0 / (a * kPi);
  double n_const = 0;
  if (c.real_constant(1, &n_const) && std::abs(n_const) <= kSawtoothMaxTerms) {
    const int big_n = static_cast<int>(std::trunc(n_const));
    if (big_n <= 1) return c.k(0);
    V s = c.k(0.5);
    for (int k = 1; k < big_n; ++k) s = s - sin(two_pi * k * freq * t) / static_cast<double>(k);
    return scale * s;
  }
  IrBuilder& b = c.builder();
  V big_n = trunc(n);
  const int k_slot = b.new_slot(1.0), s_slot = b.new_slot(0.5);
  b.store(k_slot, c.k(1).id);
  b.store(s_slot, c.k(0.5).id);
  b.begin_loop();
  V k{&b, b.load(k_slot)};
  b.loop_test(land(lt(k, big_n), le(k, kSawtoothMaxTerms)).id);
  {
    V k_in{&b, b.load(k_slot)};
    V s{&b, b.load(s_slot)};
    b.store(s_slot, (s - sin(two_pi * k_in * freq * t) / k_in).id);
    b.store(k_slot, (k_in + 1.0).id);
  }
  b.end_loop();
  V s{&b, b.load(s_slot)};
  return sel(le(big_n, 1.0), 0.0, scale * s);
}

}  // namespace

V lower_blend(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kBlendUni:
      return blend(c, true);
    case LibraryFn::kBlendInt:
      return blend(c, false);
    case LibraryFn::kDBlendUni:
      return dblend(c, true);
    case LibraryFn::kDBlendInt:
      return dblend(c, false);
    case LibraryFn::kSawtooth:
      return sawtooth(c);
    default:
      HFRT_CHECK_MSG(false, "not a blend: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
