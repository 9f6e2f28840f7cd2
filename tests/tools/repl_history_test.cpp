// `hfrt repl` in a terminal: the persistent history (HFRT_HISTORY) is written line by line,
// so that nothing typed is lost even when the session is killed. Runs hfrt in a pseudo
// terminal (forkpty).
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

/// Reads from the pty until `needle` has appeared `count` times in all the output or 20 s pass.
bool read_until(int fd, std::string* all, const std::string& needle, int count) {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    int seen = 0;
    for (size_t i = all->find(needle); i != std::string::npos; i = all->find(needle, i + 1)) ++seen;
    if (seen >= count) return true;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char buf[4096];
    ssize_t n = read(fd, buf, sizeof buf);
    if (n <= 0) return false;
    all->append(buf, size_t(n));
  }
  return false;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(ReplHistory, WrittenAsYouGoAndReadBack) {
  fs::path dir = fs::temp_directory_path() / ("hfrt_repl_hist_" + std::to_string(getpid()));
  fs::create_directories(dir);
  fs::path hist = dir / "history";
  const std::string bin = HFRT_BINARY_DIR "/tools/hfrt/hfrt";

  for (int round = 0; round < 2; ++round) {
    int fd = -1;
    pid_t pid = forkpty(&fd, nullptr, nullptr, nullptr);
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      setenv("HFRT_HISTORY", hist.c_str(), 1);
      setenv("TERM", "dumb", 1);
      setenv("NO_COLOR", "1", 1);
      execl(bin.c_str(), bin.c_str(), "repl", static_cast<char*>(nullptr));
      _exit(127);
    }
    std::string all;
    ASSERT_TRUE(read_until(fd, &all, "hfrt> ", 1)) << all;
    std::string line = round == 0 ? "ball(x[3], a[1]) { ball = 1 - x[1]; }\n" : ":eval 7 0 0\n";
    ASSERT_EQ(write(fd, line.data(), line.size()), ssize_t(line.size()));
    ASSERT_TRUE(read_until(fd, &all, "hfrt> ", 2)) << all;
    if (round == 0) {
      // Killed without :quit: the line must already be in the file.
      kill(pid, SIGKILL);
    } else {
      ASSERT_EQ(write(fd, ":quit\n", 6), 6);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    close(fd);
    if (round == 1) {
      EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
      // The new session has no objects: the eval fails, the output says so.
      EXPECT_NE(all.find("no current object"), std::string::npos) << all;
    }
  }
  std::string text = slurp(hist);
  // libedit may encode spaces (\040); look for space-free fragments.
  EXPECT_NE(text.find("ball(x[3],"), std::string::npos) << text;
  EXPECT_NE(text.find(":eval"), std::string::npos) << text;
  EXPECT_NE(text.find(":quit"), std::string::npos) << text;
  fs::remove_all(dir);
}

}  // namespace
