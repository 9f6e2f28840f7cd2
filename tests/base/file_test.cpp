// Reading files whole, and within a limit (base/file.h): what an endless or huge input costs.

#include "base/file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

namespace hfrt {
namespace {

class LimitedRead : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("hfrt_base_file_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  std::filesystem::path dir_;
};

TEST_F(LimitedRead, ReadsAFileUpToTheLimit) {
  const std::string path = write("ten.txt", "0123456789");
  Result<std::string> r = read_file_limited(path, 10, true, "max_mesh_bytes");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(*r, "0123456789");
}

TEST_F(LimitedRead, AFileOverTheLimitIsRefusedWithTheLimitsHint) {
  const std::string path = write("eleven.txt", "0123456789A");
  Result<std::string> r = read_file_limited(path, 10, true, "max_mesh_bytes");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, path + ": is 11 bytes, more than the limit of 10 bytes");
  EXPECT_NE(r.error().hint.find("--max-mesh-bytes N"), std::string::npos) << r.error().hint;
}

TEST_F(LimitedRead, DevZeroIsRefusedAtOnceOrCutAtTheLimit) {
  const auto t0 = std::chrono::steady_clock::now();
  Result<std::string> r = read_file_limited("/dev/zero", 1 << 20, true, "max_mesh_bytes");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message,
            "/dev/zero: is not a regular file (a device, a pipe or a socket, which may never "
            "end)");
  // A stream may be allowed (a model from a pipe): then it is read up to the limit only.
  Result<std::string> s = read_file_limited("/dev/zero", 1 << 20, false, "max_source_bytes");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message, "/dev/zero: is more than the limit of 1048576 bytes");
  EXPECT_NE(s.error().hint.find("--max-source-bytes N"), std::string::npos);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 30) << "reading /dev/zero must stop at the limit";
}

TEST_F(LimitedRead, MissingFilesAndDirectories) {
  Result<std::string> r = read_file_limited((dir_ / "nope").string(), 10, true, "max_mesh_bytes");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cannot open"), std::string::npos) << r.error().message;
  Result<std::string> d = read_file_limited(dir_.string(), 10, true, "max_mesh_bytes");
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message, dir_.string() + ": is a directory");
}

}  // namespace
}  // namespace hfrt
