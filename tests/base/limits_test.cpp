// The limits on hostile input (base/limits.h): their ranges and the hint that names them.

#include "base/limits.h"

#include <gtest/gtest.h>

namespace hfrt {
namespace {

TEST(Limits, DefaultsAreValid) {
  EXPECT_EQ(check_limits(Limits{}), "");
}

TEST(Limits, OutOfRangeValuesAreNamed) {
  Limits l;
  l.max_loop_iterations = 0;
  EXPECT_EQ(check_limits(l), "max_loop_iterations must be from 1 to 16777216 (got 0)");
  l.max_loop_iterations = kMaxLoopIterationsCap + 1;
  EXPECT_EQ(check_limits(l), "max_loop_iterations must be from 1 to 16777216 (got 16777217)");
  l.max_loop_iterations = kMaxLoopIterationsCap;
  EXPECT_EQ(check_limits(l), "");
  l.max_mesh_triangles = -5;
  EXPECT_EQ(check_limits(l), "max_mesh_triangles must be at least 1 (got -5)");
}

TEST(Limits, HintNamesEveryWayToSetTheLimit) {
  EXPECT_EQ(limit_hint("max_array_size"),
            "raise the limit with --max-array-size N (hfrt), ModelLimits::max_array_size (C++), "
            "hfrt_compile_options.max_array_size (C) or max_array_size= (Python); see "
            "docs/limits.md");
}

}  // namespace
}  // namespace hfrt
