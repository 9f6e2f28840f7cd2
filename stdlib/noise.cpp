// Noise attribute functions (library.md §10): Gardner noise (hfA_NoiseG, hfA_Crackles) and
// Perlin noise (hfA_NoiseP, hfA_Turbulence) with constant tables built at compile time from
// glibc's rand() stream, following the corpus convention.
#include <array>
#include <cmath>

#include "base/check.h"
#include "ir/builder.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {

int GlibcRand::next() {
  // glibc random_r (TYPE_3, seed 1) as library.md §10 spells it out.
  if (r_.empty()) {
    r_.resize(34);
    r_[0] = 1;
    for (int i = 1; i < 31; ++i) {
      r_[i] = static_cast<uint32_t>((16807ull * r_[i - 1]) % 2147483647ull);
    }
    for (int i = 31; i < 34; ++i) r_[i] = r_[i - 31];
  }
  const size_t want = calls_ + 344;
  while (r_.size() <= want) {
    const size_t i = r_.size();
    r_.push_back(r_[i - 31] + r_[i - 3]);  // mod 2^32 by unsigned wrap-around
  }
  ++calls_;
  return static_cast<int>(r_[want] >> 1);
}

void build_perlin_tables(GlibcRand& rng, std::vector<double>* perm, std::vector<double>* grad) {
  constexpr int kB = 256;
  std::array<int, kB + kB + 2> p{};
  std::array<std::array<double, 3>, kB + kB + 2> g{};
  int i = 0;
  for (i = 0; i < kB; ++i) {
    p[i] = i;
    rng.next();  // g1 (unused by noise3)
    rng.next();  // g2 (unused)
    rng.next();
    for (int j = 0; j < 3; ++j) g[i][j] = static_cast<double>((rng.next() % (kB + kB)) - kB) / kB;
    const double s = std::sqrt(g[i][0] * g[i][0] + g[i][1] * g[i][1] + g[i][2] * g[i][2]);
    for (int j = 0; j < 3; ++j) g[i][j] = g[i][j] / s;
  }
  while (--i) {
    const int k = p[i];
    const int j = rng.next() % kB;
    p[i] = p[j];
    p[j] = k;
  }
  for (i = 0; i < kB + 2; ++i) {
    p[kB + i] = p[i];
    g[kB + i] = g[i];
  }
  perm->assign(p.begin(), p.end());
  grad->clear();
  for (const auto& v : g) grad->insert(grad->end(), v.begin(), v.end());
}

namespace {

using P3 = std::array<V, 3>;

constexpr int kPerlinEntries = 514;
constexpr int kRandPerTable = 1791;

/// The combined table of one Perlin function: 514 permutation entries, then 3*514 gradient
/// components.
std::vector<double> perlin_table(int block) {
  GlibcRand rng;
  for (int i = 0; i < block * kRandPerTable; ++i) rng.next();
  std::vector<double> perm, grad;
  build_perlin_tables(rng, &perm, &grad);
  perm.insert(perm.end(), grad.begin(), grad.end());
  return perm;
}

/// The table id of hfA_NoiseP's or hfA_Turbulence's table in the function being built. The
/// first of the two lowered takes the first block of the stream (static lowering order
/// stands for the original's first-call order).
int perlin_table_id(Call& c, bool noisep) {
  LibState& st = c.state();
  int& block = noisep ? st.perlin_block_noisep : st.perlin_block_turbulence;
  int& id = noisep ? st.perlin_table_noisep : st.perlin_table_turbulence;
  if (block < 0) block = st.perlin_tables_built++;
  std::vector<double> content = perlin_table(block);
  const auto& tables = c.builder().function().tables;
  if (id < 0 || id >= static_cast<int>(tables.size()) || tables[id] != content) {
    id = c.builder().add_table(std::move(content));
  }
  return id;
}

/// Perlin's noise3 of the point v, reading the combined table `table`.
V noise3(Call& c, int table, const P3& v) {
  IrBuilder& b = c.builder();
  auto load = [&](V index0) { return V{&b, b.table_load(table, index0.id)}; };
  std::array<V, 3> b0, b1, r0, r1;
  for (int k = 0; k < 3; ++k) {
    V t = v[k] + 4096.0;
    V ti = trunc(t);
    // ((int)t) & 255 as a two's-complement mask = the remainder mod 256 in [0, 256).
    V m = fmod(ti, 256.0);
    m = sel(lt(m, 0.0), m + 256.0, m);
    // NaN/inf coordinates: index 0 (the value is NaN anyway through r0).
    m = sel(land(ge(m, 0.0), le(m, 255.0)), m, 0.0);
    b0[k] = m;
    b1[k] = sel(eq(m, 255.0), 0.0, m + 1.0);
    r0[k] = t - ti;
    r1[k] = r0[k] - 1.0;
  }
  V i = load(b0[0]);
  V j = load(b1[0]);
  V b00 = load(i + b0[1]);
  V b10 = load(j + b0[1]);
  V b01 = load(i + b1[1]);
  V b11 = load(j + b1[1]);
  auto s_curve = [](V t) { return t * t * (3.0 - 2.0 * t); };
  auto lerp = [](V t, V a, V bb) { return a + t * (bb - a); };
  auto at3 = [&](V corner, V rx, V ry, V rz) {
    V base = 3.0 * corner + static_cast<double>(kPerlinEntries);
    return rx * load(base) + ry * load(base + 1.0) + rz * load(base + 2.0);
  };
  V t = s_curve(r0[0]);
  V sy = s_curve(r0[1]);
  V sz = s_curve(r0[2]);
  V a = lerp(t, at3(b00 + b0[2], r0[0], r0[1], r0[2]), at3(b10 + b0[2], r1[0], r0[1], r0[2]));
  V bb = lerp(t, at3(b01 + b0[2], r0[0], r1[1], r0[2]), at3(b11 + b0[2], r1[0], r1[1], r0[2]));
  V cc = lerp(sy, a, bb);
  a = lerp(t, at3(b00 + b1[2], r0[0], r0[1], r1[2]), at3(b10 + b1[2], r1[0], r0[1], r1[2]));
  bb = lerp(t, at3(b01 + b1[2], r0[0], r1[1], r1[2]), at3(b11 + b1[2], r1[0], r1[1], r1[2]));
  V d = lerp(sy, a, bb);
  return lerp(sz, cc, d);
}

P3 point(Call& c, int i) {
  c.need(i, 3, "the point's 3 coordinates");
  return {c.at(i, 0), c.at(i, 1), c.at(i, 2)};
}

/// Gardner noise with amplitude 1, normalised to [0, 1] (pattern.h's Noise).
V gardner(V xt, V yt, V zt, V phase, V freq) {
  V ax = freq * xt, ay = freq * yt, az = freq * zt;
  V sx = sin(ax), sy = sin(ay), sz = sin(az);
  const double a1d = 1.0 / 1.17;
  V sx2 = a1d * sin(ax / 1.35 + phase * sz);
  V sy2 = a1d * sin(ay / 1.35 + phase * sx);
  V sz2 = a1d * sin(az / 1.35 + phase * sy);
  V ss = (sx + sx2) * (sy + sy2) * (sz + sz2);
  const double cmin = std::pow(-(2.17 / 1.17), 3);
  const double cmax = -cmin;
  return (ss - cmin) / (cmax - cmin);
}

V a_noise_g(Call& c) {
  P3 p = point(c, 0);
  return gardner(p[0], p[1], p[2], c.real(2), c.real(1));
}

V a_noise_p(Call& c) {
  P3 p = point(c, 0);
  return noise3(c, perlin_table_id(c, true), p);
}

// Iterations of hfA_Turbulence's octave loop are capped: freq halves each time, so 1100
// steps cover every finite double (an infinite freq would loop forever in the original).
constexpr double kTurbulenceMaxOctaves = 1100;

V a_turbulence(Call& c) {
  P3 p = point(c, 0);
  const int table = perlin_table_id(c, false);
  IrBuilder& b = c.builder();
  const int t_slot = b.new_slot(0), f_slot = b.new_slot(0), n_slot = b.new_slot(0);
  b.store(t_slot, c.k(0).id);
  b.store(f_slot, c.real(1).id);
  b.store(n_slot, c.k(0).id);
  b.begin_loop();
  {
    V freq{&b, b.load(f_slot)};
    V n{&b, b.load(n_slot)};
    b.loop_test(land(ge(freq, 1.0), lt(n, kTurbulenceMaxOctaves)).id);
  }
  {
    V freq{&b, b.load(f_slot)};
    V t{&b, b.load(t_slot)};
    V n{&b, b.load(n_slot)};
    V noise = noise3(c, table, {p[0] * freq, p[1] * freq, p[2] * freq});
    b.store(t_slot, (t + abs(2.0 * noise - 1.0) / freq).id);
    b.store(f_slot, (freq / 2.0).id);
    b.store(n_slot, (n + 1.0).id);
  }
  b.end_loop();
  return V{&b, b.load(t_slot)};
}

V a_crackles(Call& c) {
  // hfA_Crackles(x, out, freq, col, map)
  P3 p = point(c, 0);
  const int n = c.size(4), m = c.size(1);
  V xt = p[0], yt = p[1], zt = p[2];
  V phase = (sqrt(xt * xt) + sqrt(yt * yt) + sqrt(zt * zt)) / 3.0;
  V freq = c.real(2);
  V nx = -1.0 + gardner(xt, xt, zt, phase, freq) * 2.0;
  V ny = -1.0 + gardner(yt, yt, xt, phase, freq) * 2.0;
  V nz = -1.0 + gardner(zt, zt, yt, phase, freq) * 2.0;
  V v = nx + ny + nz;
  V j = trunc((v - floor(v)) * 1000.0);
  V noise = (1.0 + sin(j * 2.0 * kPi / 1000.0)) / 2.0;
  // The quirk: col[size(map) + 1] := 1.1 in place, before the lookup.
  if (n < c.size(3)) {
    c.put(3, n, c.k(1.0 + 0.1));
  } else {
    c.warn(3,
           "hfA_Crackles: the original writes 1.1 into element " + std::to_string(n + 1) + " of '" +
               c.arg_text(3) + "', past its end; the write is dropped",
           "declare the colour array with at least size(map) + 1 elements");
  }
  if (n >= 2) c.need(3, m * (n - 1), "one set of size(out) values per map interval");
  // Every matching interval is applied in order: the last match wins.
  std::vector<V> mp;
  for (int i = 0; i < n; ++i) mp.push_back(c.at(4, i));
  std::vector<V> match;
  for (int i = 0; i + 1 < n; ++i) match.push_back(land(ge(noise, mp[i]), lt(noise, mp[i + 1])));
  for (int i = 0; i + 1 < n; ++i) {
    for (int k = 0; k < m; ++k) c.put(1, k, sel(match[i], c.at(3, m * i + k), c.at(1, k)));
  }
  return c.k(1);
}

}  // namespace

V lower_noise(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kANoiseG:
      return a_noise_g(c);
    case LibraryFn::kANoiseP:
      return a_noise_p(c);
    case LibraryFn::kATurbulence:
      return a_turbulence(c);
    case LibraryFn::kACrackles:
      return a_crackles(c);
    default:
      HFRT_CHECK_MSG(false, "not a noise function: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
