// `hfrt ir` as a user runs it: the IR of the chosen object, --poly, and the errors (a missing
// object is located and lists the objects there are; source errors are diagnostics).
#include <gtest/gtest.h>

#include <string>

#include "tests/tools/cli_fixture.h"

namespace hfrt::tools::testing {
namespace {

class IrCliTest : public CliFixture {
 protected:
  IrCliTest() : CliFixture("hfrt_ir_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("m.hf",
          "ball(x[3], a[1]) { ball = 1 - (x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }\n"
          "wave(x[3], a[1]) { wave = sin(x[1]) - x[2]; }\n");
  }
};

TEST_F(IrCliTest, PrintsTheIrOfTheChosenObject) {
  CliRun r = hfrt("ir m.hf --object wave");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("sin"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("; polynomial program"), std::string::npos) << r.out;
}

TEST_F(IrCliTest, PolyPrintsTheProgramOrWhyThereIsNone) {
  CliRun ball = hfrt("ir m.hf --object ball --poly");
  EXPECT_EQ(ball.exit_code, 0) << ball.err;
  EXPECT_NE(ball.out.find("; polynomial program\n"), std::string::npos) << ball.out;
  EXPECT_NE(ball.out.find("leaf 0 = r"), std::string::npos) << ball.out;
  CliRun wave = hfrt("ir m.hf --object wave --poly");
  EXPECT_EQ(wave.exit_code, 0) << wave.err;
  EXPECT_NE(wave.out.find("; not analytic: 'sin' is not a polynomial at m.hf:2:"),
            std::string::npos)
      << wave.out;
}

TEST_F(IrCliTest, MissingObjectIsAnErrorListingTheObjects) {
  CliRun r = hfrt("ir m.hf --object nope");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err,
            "m.hf: error: no object named 'nope' in the file\n"
            "  hint: the objects are: ball, wave\n");
}

TEST_F(IrCliTest, SourceErrorsAndUnreadableFiles) {
  write("bad.hf", "my_model(x[3], a[1]) { my_model = x[1] +* 2; }\n");
  CliRun bad = hfrt("ir bad.hf");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("bad.hf:1:"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("error:"), std::string::npos) << bad.err;
  CliRun missing = hfrt("ir nowhere.hf");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("cannot open 'nowhere.hf'"), std::string::npos) << missing.err;
}

}  // namespace
}  // namespace hfrt::tools::testing
