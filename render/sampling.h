#pragma once
// Deterministic random numbers for sampling: hashes of (pixel, sample index, purpose), so that
// every sample is the same whatever thread renders it and in whatever order.

#include <cmath>
#include <cstdint>

namespace hfrt::render {

/// splitmix64: a well-mixed 64-bit hash, so neighbouring pixels get unrelated jitter.
inline uint64_t mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// The top 24 bits of `bits` as a float in [0, 1).
inline float unit_float(uint64_t bits) {
  return float(bits >> 40) * (1.0f / 16777216.0f);
}

/// A point of the unit disk from (u, v) in [0, 1)^2 by Shirley's concentric mapping, which keeps
/// strata compact (stratified lens and light samples stay stratified on the disk).
inline void concentric_disk(float u, float v, float* x, float* y) {
  float a = 2 * u - 1, b = 2 * v - 1;
  if (a == 0 && b == 0) {
    *x = *y = 0;
    return;
  }
  float r, phi;
  constexpr float kQuarterPi = 0.78539816339744831f;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = kQuarterPi * (b / a);
  } else {
    r = b;
    phi = 2 * kQuarterPi - kQuarterPi * (a / b);
  }
  *x = r * std::cos(phi);
  *y = r * std::sin(phi);
}

}  // namespace hfrt::render
