// The terminal front end of `hfrt repl`: line editing, persistent history and completion with
// libedit (its readline interface), the inline ANSI preview, and `:watch`. With stdin not a
// terminal it runs the lines as a script: no prompt, no colour, no preview, results on stdout,
// errors on stderr, exit 1 when any command failed. The session logic is in session.h.
#include <editline/readline.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "lang/library_table.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/session.h"

namespace hfrt::tools {
namespace {

volatile std::sig_atomic_t g_interrupted = 0;
void on_sigint(int) { g_interrupted = 1; }

/// The history file: $HFRT_HISTORY, else ~/.hfrt_history ("" when there is no home).
std::string history_path() {
  if (const char* h = std::getenv("HFRT_HISTORY")) return h;
  if (const char* home = std::getenv("HOME")) return std::string(home) + "/.hfrt_history";
  return "";
}

/// Words offered by completion: commands, render options and library function names.
std::vector<std::string> g_words;

char* word_generator(const char* text, int state) {
  static size_t index;
  if (state == 0) index = 0;
  size_t len = std::strlen(text);
  while (index < g_words.size()) {
    const std::string& w = g_words[index++];
    if (w.compare(0, len, text) == 0) return strdup(w.c_str());
  }
  return nullptr;
}

char** complete(const char* text, int start, int /*end*/) {
  // File paths after :load, :render and :watch; words elsewhere.
  std::string line(rl_line_buffer, start);
  if (start > 0 && (line.rfind(":load", 0) == 0 || line.rfind(":render", 0) == 0 ||
                    line.rfind(":watch", 0) == 0)) {
    if (line.find_first_not_of(' ', line.find(' ')) == std::string::npos) return nullptr;  // default: files
  }
  rl_attempted_completion_over = 1;
  return rl_completion_matches(text, word_generator);
}

int terminal_columns() {
  winsize ws{};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 80;
}

int64_t mtime_ns(const std::string& file) {
  struct stat st{};
  if (stat(file.c_str(), &st) != 0) return -1;
  return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

struct Frontend {
  Session session;
  bool interactive = false;
  bool preview = false;
  bool failed = false;

  void print(const SessionResult& r) {
    if (!r.out.empty()) std::fputs(r.out.c_str(), stdout);
    std::fflush(stdout);
    if (!r.err.empty()) {
      bool color = interactive && use_color(STDERR_FILENO);
      if (color) std::fputs("\x1b[31m", stderr);
      std::fputs(r.err.c_str(), stderr);
      if (color) std::fputs("\x1b[0m", stderr);
    }
    if (!r.ok) failed = true;
    if (r.ok && r.rendered && preview && session.last_image()) {
      std::fputs(ansi_preview(*session.last_image(), std::min(terminal_columns(), 120)).c_str(), stdout);
      std::fflush(stdout);
    }
  }

  /// Reloads and re-renders FILE whenever it changes, until Ctrl-C.
  void watch(const std::string& file) {
    // Ctrl-C ends the watch, not the session: our handler only while watching (elsewhere
    // the default, so that Ctrl-C at the prompt cannot leave libedit in a half-read line).
    struct sigaction sa{}, old{};
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old);
    g_interrupted = 0;
    std::fprintf(stderr, "watching %s (Ctrl-C stops)\n", file.c_str());
    int64_t seen = mtime_ns(file);
    while (!g_interrupted) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      int64_t now = mtime_ns(file);
      if (now == seen) continue;
      seen = now;
      print(session.watch_step(file));
    }
    g_interrupted = 0;
    sigaction(SIGINT, &old, nullptr);
  }

  /// Handles one line; false when the session ends.
  bool line(const std::string& text) {
    std::string t = text;
    size_t b = t.find_first_not_of(" \t");
    if (!session.pending() && b != std::string::npos && t.compare(b, 8, ":preview") == 0) {
      std::string arg = t.substr(b + 8);
      arg.erase(0, arg.find_first_not_of(" \t"));
      arg.erase(arg.find_last_not_of(" \t\r") + 1);
      if (arg == "off" || arg == "ansi") {
        preview = interactive && arg == "ansi";
      } else {
        std::fputs("hfrt: :preview expects off or ansi\n", stderr);
        failed = true;
      }
      return true;
    }
    std::optional<SessionResult> r = session.feed_line(text);
    if (!r) return true;
    print(*r);
    if (r->quit) return false;
    if (!r->watch_file.empty()) watch(r->watch_file);
    return true;
  }
};

}  // namespace

int run_repl(const std::string& model_file) {
  Frontend fe;
  fe.interactive = isatty(STDIN_FILENO) != 0;
  fe.preview = fe.interactive && isatty(STDOUT_FILENO) != 0;
  if (!model_file.empty()) fe.print(fe.session.run(":load " + model_file));

  if (!fe.interactive) {
    std::string text;
    while (std::getline(std::cin, text)) {
      if (!fe.line(text)) break;
    }
    if (fe.session.pending()) {
      std::fputs("hfrt: input ended inside an object definition (unbalanced braces)\n", stderr);
      fe.failed = true;
    }
    return fe.failed ? 1 : 0;
  }

  g_words = Session::command_names();
  for (const std::string& o : Session::option_names()) g_words.push_back(o);
#define HFRT_REPL_NAME(e, name, kinds) g_words.push_back(name);
  HFRT_LIBRARY(HFRT_REPL_NAME)
#undef HFRT_REPL_NAME
  rl_readline_name = "hfrt";
  rl_attempted_completion_function = complete;
  const std::string hist = history_path();
  using_history();
  if (!hist.empty()) read_history(hist.c_str());
  std::fputs("hfrt repl: type a HyperFun object, or :help\n", stdout);
  while (true) {
    char* raw = readline(fe.session.pending() ? "...> " : "hfrt> ");
    if (!raw) break;  // EOF (Ctrl-D)
    std::string text = raw;
    std::free(raw);
    if (text.find_first_not_of(" \t") != std::string::npos) {
      add_history(text.c_str());
      // Written as we go: nothing typed is lost if the session dies.
      if (!hist.empty()) write_history(hist.c_str());
    }
    if (!fe.line(text)) break;
  }
  return 0;
}

}  // namespace hfrt::tools
