// Silhouette comparison for bench/peers/: the fraction of pixels whose inside/outside
// classification differs between two renders of the same scene. A pixel is "covered" when
// its alpha (the last channel of an RGBA or grey+alpha image) is >= 0.5: hfrt's EXR stores
// coverage in alpha, POV-Ray writes it with +UA and a transparent background.
//
// Usage: hfrt_bench_maskdiff A B     prints "differ=F pixels=N covered_a=N covered_b=N"
// Exit codes: 0 = compared, 2 = unreadable images, no alpha, or different sizes.
#include <cstdio>
#include <string>
#include <vector>

#include "render/image.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s A B\n", argv[0]);
    return 2;
  }
  std::vector<std::vector<float>> pix(2);
  int w[2], h[2], c[2];
  for (int i = 0; i < 2; ++i) {
    auto img = hfrt::render::read_image(argv[1 + i], &w[i], &h[i], &c[i]);
    if (!img.ok()) {
      std::fprintf(stderr, "maskdiff: %s\n", img.error().message.c_str());
      return 2;
    }
    if (c[i] != 2 && c[i] != 4) {
      std::fprintf(stderr, "maskdiff: %s has no alpha channel (%d channels)\n", argv[1 + i], c[i]);
      return 2;
    }
    pix[i] = std::move(img).value();
  }
  if (w[0] != w[1] || h[0] != h[1]) {
    std::fprintf(stderr, "maskdiff: sizes differ (%dx%d vs %dx%d)\n", w[0], h[0], w[1], h[1]);
    return 2;
  }
  const size_t n = size_t(w[0]) * size_t(h[0]);
  size_t differ = 0, cov[2] = {0, 0};
  for (size_t p = 0; p < n; ++p) {
    bool in[2];
    for (int i = 0; i < 2; ++i) {
      in[i] = pix[i][p * c[i] + c[i] - 1] >= 0.5f;
      cov[i] += in[i];
    }
    differ += in[0] != in[1];
  }
  std::printf("differ=%.6f pixels=%zu covered_a=%zu covered_b=%zu\n", double(differ) / double(n), n,
              cov[0], cov[1]);
  return 0;
}
