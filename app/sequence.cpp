// Frame sequences (sequence.h).
#include "app/sequence.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "base/timer.h"

extern char** environ;

namespace hfrt::app {

namespace fs = std::filesystem;

bool parse_frame_pattern(const std::string& path, FramePattern* out, std::string* err) {
  *out = FramePattern{};
  const size_t first = path.find('#');
  if (first == std::string::npos) {
    out->prefix = path;
    return true;
  }
  size_t end = first;
  while (end < path.size() && path[end] == '#') ++end;
  if (path.find('#', end) != std::string::npos) {
    *err = "-o " + path +
           ": the frame number is one run of '#' (e.g. out/frame_####.png), this has two";
    return false;
  }
  if (path.find('/', end) != std::string::npos) {
    *err = "-o " + path +
           ": the frame number ('#') belongs in the file name, not in a folder (e.g. "
           "out/frame_####.png)";
    return false;
  }
  out->prefix = path.substr(0, first);
  out->suffix = path.substr(end);
  out->width = int(end - first);
  if (out->suffix.find('.') == std::string::npos) {
    *err = "-o " + path +
           ": the frames need a file extension after the frame number (e.g. frame_####.png)";
    return false;
  }
  return true;
}

std::string frame_path(const FramePattern& p, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%0*d", p.width, frame);
  return p.prefix + buf + p.suffix;
}

std::string ffmpeg_pattern(const FramePattern& p) {
  auto escape = [](const std::string& s) {
    std::string r;
    for (char c : s) r += c == '%' ? std::string("%%") : std::string(1, c);
    return r;
  };
  return escape(p.prefix) + "%0" + std::to_string(p.width) + "d" + escape(p.suffix);
}

namespace {

/// A non-negative decimal integer (the whole text).
bool parse_count(const std::string& text, long* out) {
  if (text.empty() || text.size() > 9) return false;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
  }
  *out = std::strtol(text.c_str(), nullptr, 10);
  return true;
}

}  // namespace

bool parse_frame_range(const std::string& text, int frames, int* first, int* last,
                       std::string* err) {
  const std::string range = "0:" + std::to_string(frames - 1);
  const size_t colon = text.find(':');
  long a = 0, b = 0;
  bool ok = colon == std::string::npos
                ? parse_count(text, &a) && (b = a, true)
                : parse_count(text.substr(0, colon), &a) && parse_count(text.substr(colon + 1), &b);
  if (!ok) {
    *err = "--frames expects A:B or A (frame numbers from 0; this animation has " + range +
           "), got '" + text + "'";
    return false;
  }
  if (a > b) {
    *err = "--frames " + text + ": the first frame is after the last";
    return false;
  }
  if (b >= frames) {
    *err = "--frames " + text + ": the animation has " + std::to_string(frames) + " frame" +
           (frames == 1 ? "" : "s") + " (" + range + ")";
    return false;
  }
  *first = int(a);
  *last = int(b);
  return true;
}

bool parse_shard(const std::string& text, int* k, int* n, std::string* err) {
  const size_t slash = text.find('/');
  long a = 0, b = 0;
  if (slash == std::string::npos || !parse_count(text.substr(0, slash), &a) ||
      !parse_count(text.substr(slash + 1), &b)) {
    *err =
        "--shard expects K/N (this job renders every N-th frame from the K-th; 0 <= K < N), "
        "got '" +
        text + "'";
    return false;
  }
  if (b < 1 || a >= b) {
    *err = "--shard " + text + ": K must be at least 0 and less than N (e.g. 0/4 ... 3/4)";
    return false;
  }
  *k = int(a);
  *n = int(b);
  return true;
}

std::vector<int> plan_frames(int first, int last, int shard_k, int shard_n, bool resume,
                             const FramePattern& pattern, std::vector<int>* skipped) {
  std::vector<int> frames;
  for (int f = first + shard_k; f <= last; f += shard_n) {
    std::error_code ec;
    if (resume && fs::is_regular_file(frame_path(pattern, f), ec)) {
      if (skipped) skipped->push_back(f);
      continue;
    }
    frames.push_back(f);
  }
  return frames;
}

Result<std::vector<std::string>> write_image_atomic(const render::Image& image,
                                                    const std::string& path,
                                                    const render::AovSet& aovs) {
  const fs::path final_path(path);
  const std::string name = final_path.filename().string();
  const std::string tag = ".hfrt-partial-" + std::to_string(::getpid()) + "-";
  const fs::path tmp = final_path.parent_path() / (tag + name);
  auto written = render::write_image(image, tmp.string(), aovs);
  if (!written.ok()) {
    // The message names the temporary file; the user asked for `path`.
    std::string msg = written.error().message;
    const std::string t = tmp.string();
    for (size_t at = msg.find(t); at != std::string::npos; at = msg.find(t, at + path.size()))
      msg.replace(at, t.size(), path);
    return Error{msg};
  }
  // write_image puts AOVs beside the image with the same stem: strip the tag from each.
  std::vector<std::string> finals;
  std::string main_tmp, main_final;
  for (const std::string& w : written.value()) {
    fs::path wp(w);
    std::string base = wp.filename().string();
    if (base.rfind(tag, 0) == 0) base = base.substr(tag.size());
    const fs::path dest = wp.parent_path() / base;
    if (w == tmp.string()) {
      main_tmp = w;
      main_final = dest.string();
      continue;
    }
    std::error_code ec;
    fs::rename(wp, dest, ec);
    if (ec) return Error{dest.string() + ": cannot rename into place: " + ec.message()};
    finals.push_back(dest.string());
  }
  std::error_code ec;
  fs::rename(main_tmp, main_final, ec);
  if (ec) return Error{main_final + ": cannot rename into place: " + ec.message()};
  finals.insert(finals.begin(), main_final);
  return finals;
}

SequenceProgress::SequenceProgress(size_t total) : total_(total), start_(Clock::now()) {}

std::string SequenceProgress::frame_done(int frame, const std::string& path, double frame_seconds) {
  ++done_;
  const double elapsed = ms_since(start_) / 1000.0;
  const double left = done_ < total_ ? elapsed / double(done_) * double(total_ - done_) : 0;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "hfrt: frame %d (%zu/%zu) %s in %.2f s; %.0f%%, %.1f s elapsed, about %.1f s left",
                frame, done_, total_, path.c_str(), frame_seconds,
                100.0 * double(done_) / double(std::max<size_t>(total_, 1)), elapsed, left);
  return buf;
}

std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::string all = path;
  size_t start = 0;
  while (start <= all.size()) {
    size_t end = all.find(':', start);
    if (end == std::string::npos) end = all.size();
    std::string dir = all.substr(start, end - start);
    if (dir.empty()) dir = ".";
    const std::string candidate = dir + "/" + name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

Result<bool> encode_video(const FramePattern& pattern, int first, int last, int fps,
                          const std::string& video) {
  const std::string ffmpeg = find_on_path("ffmpeg");
  if (ffmpeg.empty()) {
    return Error{
        "--video needs ffmpeg, which is not on PATH (Debian: apt-get install ffmpeg); "
        "the frames are written, encode them later"};
  }
  const std::string log =
      (fs::temp_directory_path() / ("hfrt-ffmpeg-" + std::to_string(::getpid()) + ".log")).string();
  std::vector<std::string> args = {ffmpeg,
                                   "-hide_banner",
                                   "-loglevel",
                                   "error",
                                   "-y",
                                   "-framerate",
                                   std::to_string(fps),
                                   "-start_number",
                                   std::to_string(first),
                                   "-i",
                                   ffmpeg_pattern(pattern),
                                   "-frames:v",
                                   std::to_string(last - first + 1),
                                   "-c:v",
                                   "libx264",
                                   "-pix_fmt",
                                   "yuv420p",
                                   "-vf",
                                   "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                   video};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, ffmpeg.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return Error{"cannot run " + ffmpeg + ": " + std::strerror(rc)};
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::string output;
  {
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) output += (output.empty() ? "" : "\n") + line;
  }
  std::error_code ec;
  fs::remove(log, ec);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return Error{"ffmpeg failed making " + video + (output.empty() ? "" : ":\n" + output)};
  }
  return true;
}

}  // namespace hfrt::app
