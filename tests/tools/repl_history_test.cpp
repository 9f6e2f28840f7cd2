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
#include <thread>

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

/// hfrt repl in a pseudo terminal (TERM=dumb: no preview), killed at the end if still running.
struct PtyRepl {
  int fd = -1;
  pid_t pid = -1;
  std::string all;

  explicit PtyRepl(const fs::path& hist) {
    const std::string bin = HFRT_BINARY_DIR "/tools/hfrt/hfrt";
    pid = forkpty(&fd, nullptr, nullptr, nullptr);
    if (pid == 0) {
      setenv("HFRT_HISTORY", hist.c_str(), 1);
      setenv("TERM", "dumb", 1);
      setenv("NO_COLOR", "1", 1);
      execl(bin.c_str(), bin.c_str(), "repl", static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~PtyRepl() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
    if (fd >= 0) close(fd);
  }
  void send(const std::string& text) {
    ASSERT_EQ(write(fd, text.data(), text.size()), ssize_t(text.size()));
  }
  bool wait_for(const std::string& needle, int count) {
    return read_until(fd, &all, needle, count);
  }
  /// Waits for the process to exit; its exit status, or -1.
  int wait_exit() {
    int status = 0;
    waitpid(pid, &status, 0);
    pid = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
};

fs::path temp_dir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("hfrt_repl_" + name + "_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir;
}

TEST(ReplTerminal, CtrlCClearsThePromptLineAndCancelsARender) {
  fs::path dir = temp_dir("ctrlc");
  PtyRepl repl(dir / "history");
  ASSERT_GT(repl.pid, 0);
  ASSERT_TRUE(repl.wait_for("hfrt> ", 1)) << repl.all;
  // At the prompt: the half-typed line is dropped, the session goes on. (Typed as a person
  // types: after libedit has set the terminal up; keys sent before that, in cooked mode, are
  // the kernel's to echo or flush.)
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  repl.send(":eval 1 2");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  repl.send("\x03");
  ASSERT_TRUE(repl.wait_for("hfrt> ", 2)) << repl.all;
  // Also inside a multi-line definition: the open definition is dropped.
  repl.send("half(x[3], a[1])\n{\n");
  ASSERT_TRUE(repl.wait_for("...> ", 2)) << repl.all;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  repl.send("\x03");
  ASSERT_TRUE(repl.wait_for("hfrt> ", 3)) << repl.all;
  repl.send("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
  ASSERT_TRUE(repl.wait_for("defined ball", 1)) << repl.all;
  ASSERT_TRUE(repl.wait_for("hfrt> ", 4)) << repl.all;
  // A render of about a billion rays (minutes), cancelled by Ctrl-C: the message comes while
  // the reader still waits (read_until), far sooner than the render could finish.
  repl.send(":render " + (dir / "long.png").string() + " --size 4096x4096 --spp 64 --root sign\n");
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  repl.send("\x03");
  ASSERT_TRUE(repl.wait_for("render cancelled", 1)) << repl.all;
  ASSERT_TRUE(repl.wait_for("hfrt> ", 5)) << repl.all;
  // The session is intact: the Ctrl-C at the prompt did not leave a pending definition.
  repl.send(":eval 0.5 0 0\n");
  ASSERT_TRUE(repl.wait_for("0.75 0", 1)) << repl.all;
  repl.send(":quit\n");
  EXPECT_EQ(repl.wait_exit(), 0);
  EXPECT_FALSE(fs::exists(dir / "long.png"));
  fs::remove_all(dir);
}

TEST(ReplTerminal, WatchPicksUpChangesAndEndsOnCtrlC) {
  fs::path dir = temp_dir("watchc");
  fs::path model = dir / "w.hf";
  std::ofstream(model) << "my_model(x[3], a[1]) { my_model = 1 - x[1]; }\n";
  const std::string image = (dir / "w.png").string();
  PtyRepl repl(dir / "history");
  ASSERT_GT(repl.pid, 0);
  ASSERT_TRUE(repl.wait_for("hfrt> ", 1)) << repl.all;
  repl.send(":load " + model.string() + "\n");
  ASSERT_TRUE(repl.wait_for("hfrt> ", 2)) << repl.all;
  repl.send(":render " + image + " --size 16x16 --bbox 2\n");
  ASSERT_TRUE(repl.wait_for(image + " 16x16", 1)) << repl.all;
  repl.send(":watch " + model.string() + "\n");
  ASSERT_TRUE(repl.wait_for("watching", 1)) << repl.all;
  ASSERT_TRUE(repl.wait_for(image + " 16x16", 2)) << repl.all;  // the watch's first render
  // An editor writes the file: the watch reloads it and renders again.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::ofstream(model) << "my_model(x[3], a[1]) { my_model = 5 - x[1]; }\n";
  ASSERT_TRUE(repl.wait_for(image + " 16x16", 3)) << repl.all;
  repl.send("\x03");
  ASSERT_TRUE(repl.wait_for("watch ended", 1)) << repl.all;
  ASSERT_TRUE(repl.wait_for("hfrt> ", 4)) << repl.all;
  repl.send(":eval 3 0 0\n");
  ASSERT_TRUE(repl.wait_for("\n2 0", 1)) << repl.all;  // 5 - 3: the new definition
  repl.send(":quit\n");
  EXPECT_EQ(repl.wait_exit(), 0);
  fs::remove_all(dir);
}

}  // namespace
