// `hfrt cache info|clear` and `--no-cache` (hfrt/compile_cache.h), through the binary, with a
// cache folder of the test's own.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

using testing::CliFixture;
using testing::CliRun;

class CacheCliTest : public CliFixture {
 protected:
  CacheCliTest() : CliFixture("hfrt_cache_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("sphere.hf",
          "my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
  }
  /// hfrt with the cache on (the suite switches it off) in the test's folder.
  CliRun cached(const std::string& args, const std::string& input = "") {
    return shell("env -u HFRT_NO_CACHE HFRT_CACHE_DIR='" + (dir_ / "cache").string() + "' " +
                     HFRT_BINARY_DIR "/tools/hfrt/hfrt " + args,
                 input);
  }
  size_t entries() {
    size_t n = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir_ / "cache", ec))
      n += e.path().extension() == ".o";
    return n;
  }
};

TEST_F(CacheCliTest, InfoClearAndNoCache) {
  CliRun r = cached("eval sphere.hf", "0.5 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("0.75"), std::string::npos) << r.out;
  const size_t stored = entries();
  EXPECT_GE(stored, 1u);
  // The same answer from the cache.
  r = cached("eval sphere.hf", "0.5 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("0.75"), std::string::npos) << r.out;
  EXPECT_EQ(entries(), stored);

  r = cached("cache info");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("folder: " + (dir_ / "cache").string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("enabled: yes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("entries: " + std::to_string(stored)), std::string::npos) << r.out;

  // --no-cache before or after the subcommand: nothing new is stored.
  write("other.hf", "my_model(x[3], a[1]) { my_model = 2 - x[1]; }\n");
  r = cached("--no-cache eval other.hf", "0 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = cached("eval other.hf --no-cache", "0 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(entries(), stored);
  r = cached("--no-cache cache info");
  EXPECT_NE(r.out.find("enabled: no"), std::string::npos) << r.out;

  r = cached("cache clear");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("hfrt cache: removed " + std::to_string(stored) + " entr"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(entries(), 0u);
  r = cached("cache flush");
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
}  // namespace hfrt::tools
