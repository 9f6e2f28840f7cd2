// The library's example models (examples/lib_*.hf, one per family) compile without
// diagnostics and are pleasant solids for rendering: inside points exist, and the solid
// stays inside [-10, 10]^3 (F < 0 on the faces of the box).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
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
        const bool on_face =
            i == 0 || j == 0 || k == 0 || i == kN - 1 || j == kN - 1 || k == kN - 1;
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

namespace hfrt {
namespace {

// Through the whole pipeline: a point array of the wrong size is a located warning, not an
// error, and the model still compiles (corpus/probes/quirk_sentinels.hf depends on it).
TEST(LibWarnings, SentinelsWarnAtThePointArgument) {
  const std::string path = std::string(HFRT_CORPUS_DIR) + "/probes/quirk_sentinels.hf";
  ModelOptions options;
  options.backend = Backend::kInterp;
  auto compiled = Model::compile_file(path, options);
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  std::ifstream in(path);
  std::string line, text;
  int line_no = 0, model_line = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find("hfSphere(") != std::string::npos) model_line = line_no, text = line;
  }
  ASSERT_GT(model_line, 0);
  struct Want {
    std::string call;
    std::string value;
  };
  const Want wants[] = {{"hfSphere(", "-1111111111111.0"},
                        {"hfDConeX(", "-11111111111.0"},
                        {"hfDCylinder(", "-11111111111.1"}};
  ASSERT_EQ(3u, compiled.diagnostics.size()) << compiled.rendered;
  for (const Want& w : wants) {
    const int col = static_cast<int>(text.find(w.call) + w.call.size()) + 1;  // the 'x'
    bool found = false;
    for (const SourceDiagnostic& d : compiled.diagnostics) {
      if (d.line == model_line && d.col == col) {
        found = true;
        EXPECT_EQ(SourceDiagnostic::Severity::kWarning, d.severity);
        EXPECT_EQ(1, d.length);
        EXPECT_EQ(w.call.substr(0, w.call.size() - 1) +
                      ": the point array 'x' has 4 elements, "
                      "not 3; the call returns the failure value " +
                      w.value,
                  d.message);
      }
    }
    EXPECT_TRUE(found) << w.call << " at column " << col << "\n" << compiled.rendered;
  }
  EXPECT_EQ(-1111111111111.0, compiled.model->eval({1, 2, 3, 4}).s.at(0));
}

TEST(LibWarnings, HfRWarnsAndReturnsTheFailureValue) {
  ModelOptions options;
  options.backend = Backend::kInterp;
  auto compiled = Model::compile("m(x[3], a[1]) { m = hfR(x, 2); }", options);
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  ASSERT_EQ(1u, compiled.diagnostics.size()) << compiled.rendered;
  const SourceDiagnostic& d = compiled.diagnostics[0];
  EXPECT_EQ(SourceDiagnostic::Severity::kWarning, d.severity);
  EXPECT_EQ("hfR needs the R package build of HyperFun; it returns the failure value here",
            d.message);
  EXPECT_EQ(1, d.line);
  EXPECT_EQ(21, d.col);  // the call hfR(...)
  EXPECT_EQ(-1111111111111.0, compiled.model->eval({1, 2, 3}).f);
}

}  // namespace
}  // namespace hfrt
