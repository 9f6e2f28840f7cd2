// The terminal front end of `hfrt repl`: line editing, persistent history and completion with
// libedit (its readline interface), the inline preview (kitty, sixel or ANSI half blocks,
// preview.h), Ctrl-C, and `:watch`. With stdin not a terminal it runs the lines as a script: no
// prompt, no colour, no preview, results on stdout, errors on stderr, exit 1 when any command
// failed. The session logic is in session.h.
//
// Ctrl-C: one SIGINT handler for the whole interactive session, installed without SA_RESTART
// and with libedit's own signal handling off (rl_catch_signals = 0). While a command runs, it
// sets the Session's cancel flag (a running render stops at its next tile) and ends a :watch;
// at the prompt, the interrupted read() in our rl_getc_function ends the line with a newline
// that is then thrown away (the line, or an unfinished multi-line definition, is cleared and a
// fresh prompt appears) instead of the default action, which would end the process.
#include <editline/readline.h>
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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
/// 1 while a command runs (then Ctrl-C cancels it), 0 at the prompt.
volatile std::sig_atomic_t g_busy = 0;
/// The session's cancel flag, set from the handler: an atomic store is async-signal-safe when
/// lock-free.
std::atomic<bool>* g_cancel = nullptr;
static_assert(std::atomic<bool>::is_always_lock_free);

void on_sigint(int) {
  g_interrupted = 1;
  if (g_busy && g_cancel) g_cancel->store(true);
}

/// Set when the prompt's line was ended by Ctrl-C: the line read is then thrown away.
bool g_discard_line = false;

/// libedit's character source. SIGINT is blocked except inside ppoll(), which unblocks it
/// atomically: a Ctrl-C that comes before the wait (while libedit draws the prompt, or before it
/// has put the terminal in raw mode) is pending and interrupts ppoll at once, instead of being
/// lost ahead of a blocking read().
int getc_interruptible(FILE*) {
  sigset_t block, old;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  while (true) {
    sigprocmask(SIG_BLOCK, &block, &old);
    if (g_interrupted) {
      sigprocmask(SIG_SETMASK, &old, nullptr);
      g_interrupted = 0;
      g_discard_line = true;
      return '\n';
    }
    pollfd p{STDIN_FILENO, POLLIN, 0};
    sigset_t wait_mask = old;
    sigdelset(&wait_mask, SIGINT);
    int ready = ppoll(&p, 1, nullptr, &wait_mask);
    sigprocmask(SIG_SETMASK, &old, nullptr);
    if (ready < 0) {
      if (errno == EINTR) continue;  // the loop's first check sees a Ctrl-C
      return EOF;
    }
    unsigned char c;
    ssize_t n = read(STDIN_FILENO, &c, 1);
    if (n == 1) return c;
    if (n == 0) return EOF;
    if (errno != EINTR && errno != EAGAIN) return EOF;
  }
}

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
    if (line.find_first_not_of(' ', line.find(' ')) == std::string::npos)
      return nullptr;  // default: files
  }
  rl_attempted_completion_over = 1;
  return rl_completion_matches(text, word_generator);
}

/// The terminal's size in pixels (0 when it does not say) and in text cells.
winsize terminal_size() {
  winsize ws{};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) != 0) ws = winsize{};
  if (ws.ws_col == 0) ws.ws_col = 80;
  if (ws.ws_row == 0) ws.ws_row = 24;
  return ws;
}

/// The preview of `image` for the terminal: about half the terminal's width and at most its
/// height (kitty and sixel: pixels; half blocks: columns of two pixel rows each).
std::string preview_text(const render::Image& image, PreviewMode mode, bool keep_cursor = false) {
  if (mode == PreviewMode::kOff || image.width <= 0 || image.height <= 0) return "";
  const winsize ws = terminal_size();
  const double aspect = double(image.width) / double(image.height);
  if (mode == PreviewMode::kAnsi) {
    int cols = std::min<int>(ws.ws_col, 120);
    cols = std::min(cols, std::max(8, int(2 * (ws.ws_row - 3) * aspect)));  // fits in height
    return ansi_preview(image, cols);
  }
  const int cell_w = ws.ws_xpixel > 0 ? ws.ws_xpixel / ws.ws_col : 8;
  const int cell_h = ws.ws_ypixel > 0 ? ws.ws_ypixel / ws.ws_row : 16;
  int width = std::max(64, cell_w * ws.ws_col / 2);
  width = std::min(width, std::max(64, int(cell_h * (ws.ws_row - 3) * aspect)));
  return mode == PreviewMode::kKitty ? kitty_preview(image, width, keep_cursor)
                                     : sixel_preview(image, width);
}

int64_t mtime_ns(const std::string& file) {
  struct stat st {};
  if (stat(file.c_str(), &st) != 0) return -1;
  return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

struct Frontend {
  Session session;
  bool interactive = false;
  PreviewMode preview = PreviewMode::kOff;
  bool failed = false;
  /// A coarse picture is on screen where the full one goes (see show_coarse).
  bool coarse_shown = false;

  /// Session::on_coarse: the coarse render, scaled up to the full size, shown where the full
  /// picture will replace it (kitty: placed without moving the cursor; half blocks: the cursor
  /// goes back up over it). Sixel pictures have no size in text rows that we could know, so
  /// they show only the full picture.
  void show_coarse(const render::Image& coarse) {
    const render::RenderOptions& o = session.render_settings().options;
    if (preview != PreviewMode::kAnsi && preview != PreviewMode::kKitty) return;
    render::Image full = resize_nearest(coarse, o.width, o.height);
    std::string text = preview_text(full, preview, /*keep_cursor=*/true);
    if (preview == PreviewMode::kAnsi) {
      const size_t rows = size_t(std::count(text.begin(), text.end(), '\n'));
      text += "\x1b[" + std::to_string(rows) + "A";
    }
    std::fputs(text.c_str(), stdout);
    std::fflush(stdout);
    coarse_shown = true;
  }

  /// The coarse picture is worth its render only when it can be shown in place.
  void update_coarse_hook() {
    if (interactive && (preview == PreviewMode::kAnsi || preview == PreviewMode::kKitty)) {
      session.on_coarse = [this](const render::Image& coarse) { show_coarse(coarse); };
    } else {
      session.on_coarse = nullptr;
    }
  }

  void show_preview() {
    if (preview == PreviewMode::kOff || !session.last_image()) return;
    std::fputs(preview_text(*session.last_image(), preview).c_str(), stdout);
    std::fflush(stdout);
  }

  void print(const SessionResult& r) {
    const bool show = r.ok && r.rendered && preview != PreviewMode::kOff;
    // The full picture first where the coarse one is; else the result line first.
    if (coarse_shown) {
      if (show) {
        show_preview();
      } else if (preview == PreviewMode::kAnsi) {
        std::fputs("\x1b[J", stdout);  // a cancelled render: clear the coarse picture
      } else {
        std::fputs("\x1b_Ga=d,d=C,q=2\x1b\\", stdout);  // kitty: delete it (it is at the cursor)
      }
    }
    if (!r.out.empty()) std::fputs(r.out.c_str(), stdout);
    std::fflush(stdout);
    if (!r.err.empty()) {
      bool color = interactive && use_color(STDERR_FILENO);
      if (color) std::fputs("\x1b[31m", stderr);
      std::fputs(r.err.c_str(), stderr);
      if (color) std::fputs("\x1b[0m", stderr);
    }
    if (!r.ok) failed = true;
    if (show && !coarse_shown) show_preview();
    coarse_shown = false;
  }

  /// Reloads and re-renders FILE whenever it changes, until Ctrl-C.
  void watch(const std::string& file) {
    // Ctrl-C ends the watch (and cancels a render it started), not the session: the handler
    // is installed by run_repl for the whole interactive session.
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
    std::fputs("watch ended\n", stderr);
  }

  /// Handles one line; false when the session ends.
  bool line(const std::string& text) {
    std::string t = text;
    size_t b = t.find_first_not_of(" \t");
    if (!session.pending() && b != std::string::npos && t.compare(b, 8, ":preview") == 0) {
      std::string arg = t.substr(b + 8);
      arg.erase(0, arg.find_first_not_of(" \t"));
      arg.erase(arg.find_last_not_of(" \t\r") + 1);
      PreviewMode mode = PreviewMode::kOff;
      if (arg == "auto" || arg.empty()) {
        mode = detect_preview([](const char* name) { return std::getenv(name); });
      } else if (!parse_preview_mode(arg, &mode)) {
        std::fputs("hfrt: :preview expects off, ansi, sixel, kitty or auto\n", stderr);
        failed = true;
        return true;
      }
      // A script shows no pictures: the command is accepted and changes nothing.
      if (interactive && isatty(STDOUT_FILENO)) preview = mode;
      update_coarse_hook();
      if (interactive) std::printf("preview %s\n", preview_mode_name(preview));
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
  if (fe.interactive && isatty(STDOUT_FILENO)) {
    fe.preview = detect_preview([](const char* name) { return std::getenv(name); });
  }
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
  // Ctrl-C is ours (see the top of this file).
  rl_catch_signals = 0;
  rl_getc_function = getc_interruptible;
  g_cancel = &fe.session.cancel_flag();
  fe.update_coarse_hook();
  struct sigaction sa {};
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: the prompt's read() must see EINTR
  sigaction(SIGINT, &sa, nullptr);
  const std::string hist = history_path();
  using_history();
  if (!hist.empty()) read_history(hist.c_str());
  std::fputs("hfrt repl: type a HyperFun object, or :help\n", stdout);
  while (true) {
    g_interrupted = 0;
    g_discard_line = false;
    char* raw = readline(fe.session.pending() ? "...> " : "hfrt> ");
    if (!raw) break;  // EOF (Ctrl-D)
    std::string text = raw;
    std::free(raw);
    if (g_discard_line) {  // Ctrl-C at the prompt: the line (and an open definition) is dropped
      fe.session.discard_pending();
      continue;
    }
    if (text.find_first_not_of(" \t") != std::string::npos) {
      add_history(text.c_str());
      // Written as we go: nothing typed is lost if the session dies.
      if (!hist.empty()) write_history(hist.c_str());
    }
    g_busy = 1;
    const bool go_on = fe.line(text);
    g_busy = 0;
    if (!go_on) break;
  }
  return 0;
}

}  // namespace hfrt::tools
