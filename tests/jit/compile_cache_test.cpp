// Tests of the compile cache on disk (hfrt/compile_cache.h, jit/compile_cache.cpp and its use
// in jit/llvm_session.cpp): a second compile of the same code is a hit with the same values;
// a changed model or option never reuses code; damaged entries are found, removed and
// compiled again; concurrent compiles share a folder; the code of mesh leaves is stored and
// linked to each process's own surface; the folder stays within its bound; `clear` empties it.
#include "hfrt/compile_cache.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "jit/llvm_jit.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {
namespace {

namespace fs = std::filesystem;

class CompileCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hfrt_cache_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    configure_compile_cache(true, dir_.string());
  }
  void TearDown() override {
    configure_compile_cache(false);
    fs::remove_all(dir_);
  }

  std::vector<fs::path> entries() const {
    std::vector<fs::path> out;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
      if (e.path().extension() == ".o") out.push_back(e.path());
    }
    return out;
  }

  static Function lowered(const std::string& text) {
    testutil::Compiled c = testutil::compile(text);
    EXPECT_TRUE(c.ok) << c.diagnostics;
    return std::move(c.fn);
  }

  /// F at three points by a fresh compile; `from_cache` tells where the code came from.
  static std::vector<double> values(const Function& fn, bool* from_cache, JitOptions o = {}) {
    auto jit = JitFunction::compile(fn, Precision::kF64, o);
    EXPECT_TRUE(jit.ok());
    if (!jit.ok()) return {};
    *from_cache = jit.value()->stats().from_cache;
    const double xs[9] = {0.5, -1, 2, 0.25, 3, -2, 1, 1, 1};
    std::vector<double> out(3);
    const double a[1] = {0};
    jit.value()->f64()(3, xs, a, out.data(), nullptr);
    return out;
  }

  fs::path dir_;
};

const char* kModel = "my_model(x[3], a[1]) { my_model = 4 - x[1]*x[1] - sin(x[2]) * x[3]; }";

TEST_F(CompileCacheTest, SecondCompileIsAHitWithTheSameValues) {
  const Function fn = lowered(kModel);
  const CompileCacheStats before = compile_cache_stats();
  bool cached = true;
  const std::vector<double> first = values(fn, &cached);
  EXPECT_FALSE(cached);
  EXPECT_EQ(entries().size(), 1u);
  const std::vector<double> second = values(fn, &cached);
  EXPECT_TRUE(cached);
  EXPECT_EQ(first, second);
  EXPECT_EQ(first[0], 4 - 0.25 - std::sin(0.25) * 1);  // x = (0.5, 0.25, 1): structure of arrays
  const CompileCacheStats after = compile_cache_stats();
  EXPECT_EQ(after.hits - before.hits, 1u);
  EXPECT_EQ(after.misses - before.misses, 1u);
}

TEST_F(CompileCacheTest, AChangedModelOrOptionNeverReusesCode) {
  bool cached = true;
  const std::vector<double> a = values(lowered(kModel), &cached);
  EXPECT_FALSE(cached);
  // One number changed: a miss, and its own values.
  const std::vector<double> b = values(
      lowered("my_model(x[3], a[1]) { my_model = 5 - x[1]*x[1] - sin(x[2]) * x[3]; }"), &cached);
  EXPECT_FALSE(cached);
  EXPECT_EQ(b[0], a[0] + 1);
  // The same model with another optimisation level or lane count: misses too.
  JitOptions o1;
  o1.opt_level = 1;
  values(lowered(kModel), &cached, o1);
  EXPECT_FALSE(cached);
  JitOptions l2;
  l2.lanes = 2;
  values(lowered(kModel), &cached, l2);
  EXPECT_FALSE(cached);
  EXPECT_EQ(entries().size(), 4u);
  // And each of them is a hit the second time.
  values(lowered(kModel), &cached, o1);
  EXPECT_TRUE(cached);
}

TEST_F(CompileCacheTest, DamagedEntriesAreRemovedAndCompiledAgain) {
  const Function fn = lowered(kModel);
  bool cached = true;
  const std::vector<double> want = values(fn, &cached);
  ASSERT_EQ(entries().size(), 1u);
  const fs::path entry = entries()[0];
  const uint64_t corrupt0 = compile_cache_stats().corrupt;
  {
    // One byte of the object flipped.
    std::fstream f(entry, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f.put('\x5a');
  }
  EXPECT_EQ(values(fn, &cached), want);
  EXPECT_FALSE(cached);
  EXPECT_EQ(compile_cache_stats().corrupt, corrupt0 + 1);
  // Stored again, whole: a hit.
  EXPECT_EQ(values(fn, &cached), want);
  EXPECT_TRUE(cached);
  // Truncated (a process killed while writing would leave no entry, but a disk may).
  fs::resize_file(entries()[0], 40);
  EXPECT_EQ(values(fn, &cached), want);
  EXPECT_FALSE(cached);
  EXPECT_EQ(compile_cache_stats().corrupt, corrupt0 + 2);
  // Not an entry at all.
  std::ofstream(entries()[0], std::ios::binary) << "garbage";
  EXPECT_EQ(values(fn, &cached), want);
  EXPECT_FALSE(cached);
}

TEST_F(CompileCacheTest, ConcurrentCompilesShareOneFolder) {
  const Function fn = lowered(kModel);
  std::vector<std::vector<double>> got(6);
  std::vector<std::thread> threads;
  for (size_t i = 0; i < got.size(); ++i) {
    threads.emplace_back([&, i] {
      bool cached = false;
      got[i] = values(fn, &cached);
    });
  }
  for (std::thread& t : threads) t.join();
  for (const auto& g : got) EXPECT_EQ(g, got[0]);
  EXPECT_EQ(entries().size(), 1u);
  // No temporary file is left behind, and the entry is whole.
  size_t others = 0;
  for (const auto& e : fs::directory_iterator(dir_)) others += e.path().extension() != ".o";
  EXPECT_EQ(others, 0u);
  bool cached = false;
  EXPECT_EQ(values(fn, &cached), got[0]);
  EXPECT_TRUE(cached);
}

TEST_F(CompileCacheTest, MeshLeafCodeIsStoredAndLinksToItsOwnSurface) {
  // A mesh leaf's code refers to its surface by a symbol defined when it is linked, not by the
  // address (which differs between processes): two meshes of the same program shape share
  // one entry, and each compile still evaluates its own mesh.
  auto model = [](const std::string& v) {
    return lowered("my_model(x[3], a[1]) { array v[9], t[3]; v = [" + v +
                   "]; t = [1, 2, 3]; my_model = hfTriangles(x, v, t); }");
  };
  const Function small = model("0,0,0, 1,0,0, 0,1,0"), large = model("0,0,0, 2,0,0, 0,2,0");
  const uint64_t bypassed = compile_cache_stats().bypassed;
  bool cached = true;
  const std::vector<double> v_small = values(small, &cached);
  EXPECT_FALSE(cached);
  EXPECT_EQ(entries().size(), 1u);
  const std::vector<double> v_large = values(large, &cached);
  EXPECT_TRUE(cached);
  EXPECT_EQ(entries().size(), 1u);
  EXPECT_EQ(compile_cache_stats().bypassed, bypassed);
  EXPECT_NE(v_small, v_large);
  // The values of code compiled without the cache, for each mesh.
  configure_compile_cache(false, dir_.string());
  EXPECT_EQ(values(large, &cached), v_large);
  EXPECT_FALSE(cached);
  EXPECT_EQ(values(small, &cached), v_small);
  configure_compile_cache(true, dir_.string());
}

TEST_F(CompileCacheTest, SwitchedOffItWritesNothing) {
  configure_compile_cache(false, dir_.string());
  EXPECT_FALSE(compile_cache_enabled());
  bool cached = true;
  values(lowered(kModel), &cached);
  values(lowered(kModel), &cached);
  EXPECT_FALSE(cached);
  EXPECT_FALSE(fs::exists(dir_));
}

TEST_F(CompileCacheTest, TheFolderStaysWithinItsBoundAndClearEmptiesIt) {
  bool cached = false;
  values(lowered(kModel), &cached);
  ASSERT_EQ(entries().size(), 1u);
  const uint64_t one = fs::file_size(entries()[0]);
  // Room for about three entries: the least recently used go first.
  configure_compile_cache(true, dir_.string(), 3 * one + one / 2);
  for (int k = 0; k < 8; ++k) {
    values(lowered("my_model(x[3], a[1]) { my_model = " + std::to_string(k + 10) +
                   " - x[1]*x[1] - sin(x[2]) * x[3]; }"),
           &cached);
  }
  uint64_t entries_now = 0, bytes = 0;
  compile_cache_usage(&entries_now, &bytes);
  EXPECT_LE(bytes, 3 * one + one / 2);
  EXPECT_GE(entries_now, 1u);
  EXPECT_EQ(compile_cache_dir(), dir_.string());
  std::string error;
  EXPECT_EQ(clear_compile_cache(&error), long(entries_now));
  EXPECT_TRUE(entries().empty());
}

}  // namespace
}  // namespace hfrt::jit
