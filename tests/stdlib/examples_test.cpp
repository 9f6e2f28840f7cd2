// The library's example models (examples/lib_*.hf, one per family) compile without
// diagnostics and are pleasant solids for rendering: inside points exist, and the solid
// stays inside [-10, 10]^3 (F < 0 on the faces of the box).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "hfrt/model.h"

namespace hfrt {
namespace {

class LibExampleTest : public ::testing::TestWithParam<std::string> {};

TEST_P(LibExampleTest, IsABoundedSolidWithoutWarnings) {
  const std::string path = std::string(HFRT_SOURCE_DIR) + "/examples/" + GetParam() + ".hf";
  ModelOptions options;
  options.backend = Backend::kInterp;
  auto compiled = Model::compile_file(path, options);
  ASSERT_TRUE(compiled.ok()) << compiled.rendered << compiled.error;
  EXPECT_TRUE(compiled.diagnostics.empty()) << compiled.rendered;
  const Model& model = *compiled.model;
  constexpr int kN = 21;
  int inside = 0, total = 0, boundary_inside = 0, errors = 0;
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j < kN; ++j) {
      for (int k = 0; k < kN; ++k) {
        const double x = -10 + 20.0 * i / (kN - 1), y = -10 + 20.0 * j / (kN - 1),
                     z = -10 + 20.0 * k / (kN - 1);
        PointValue v = model.eval({x, y, z});
        if (!v.ok() || std::isnan(v.f)) ++errors;
        const bool in = v.f >= 0;
        inside += in;
        ++total;
        const bool on_face = i == 0 || j == 0 || k == 0 || i == kN - 1 || j == kN - 1 ||
                             k == kN - 1;
        if (on_face && in) ++boundary_inside;
      }
    }
  }
  EXPECT_EQ(0, errors);
  EXPECT_GT(inside, total / 100) << "almost empty";
  EXPECT_LT(inside, total * 6 / 10) << "almost full";
  EXPECT_EQ(0, boundary_inside) << "the solid touches the faces of [-10, 10]^3";
}

INSTANTIATE_TEST_SUITE_P(Examples, LibExampleTest,
                         ::testing::Values("lib_primitives", "lib_convolution", "lib_transforms",
                                           "lib_blends", "lib_distance", "lib_attributes"));

}  // namespace
}  // namespace hfrt
