#pragma once
// A GoogleTest fixture for tests that run the real `hfrt` binary as scripts do: each test gets
// its own scratch folder (removed afterwards), writes its model files there and runs `hfrt`
// with that folder as the working directory, standard input from a file and both output
// streams captured. Shared by the `hfrt eval` and `hfrt emit` command-line tests.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace hfrt::tools::testing {

/// What one run of the binary left behind.
struct CliRun {
  int exit_code = -1;  ///< -1 when the process did not exit normally
  std::string out, err;
};

/// The whole file, or "" when it cannot be read.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class CliFixture : public ::testing::Test {
 protected:
  /// `prefix` names the scratch folder (with the process id and the test's name, so parallel
  /// CTest processes never share one).
  explicit CliFixture(std::string prefix) : prefix_(std::move(prefix)) {}

  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           (prefix_ + "_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name, std::ios::binary) << text;
  }

  /// Runs the shell command line `cmdline` in the scratch folder with `input` on standard input.
  CliRun shell(const std::string& cmdline, const std::string& input = "") {
    write("stdin.txt", input);
    std::string cmd =
        "cd '" + dir_.string() + "' && " + cmdline + " < stdin.txt > out.txt 2> err.txt";
    int status = std::system(cmd.c_str());
    CliRun r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(dir_ / "out.txt");
    r.err = slurp(dir_ / "err.txt");
    return r;
  }

  /// Runs `hfrt ARGS` (passed through the shell) as shell() does.
  CliRun hfrt(const std::string& args, const std::string& input = "") {
    return shell(HFRT_BINARY_DIR "/tools/hfrt/hfrt " + args, input);
  }

  std::filesystem::path dir_;

 private:
  std::string prefix_;
};

}  // namespace hfrt::tools::testing
