// The compile cache's store: see hfrt/compile_cache.h and jit/compile_cache.h.
//
// An entry is one file `<key>.o`: the magic "HFRTOBJ1", the payload's length and its FNV-1a
// 64-bit checksum (8 bytes each, little-endian), then the object file. It is written to a
// temporary name in the same folder and renamed into place, so a reader sees a whole entry or
// none; a load checks magic, length and checksum and removes an entry that fails. A hit
// touches the file's time, and a store trims the folder to its bound by removing the least
// recently used entries.

#include "jit/compile_cache.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <vector>

#include "hfrt/compile_cache.h"

namespace hfrt {

namespace {
namespace fs = std::filesystem;

constexpr char kMagic[8] = {'H', 'F', 'R', 'T', 'O', 'B', 'J', '1'};
constexpr uint64_t kDefaultMaxBytes = 512ull << 20;

struct State {
  std::mutex mutex;
  bool configured = false;
  bool enabled = true;
  std::string dir;
  uint64_t max_bytes = kDefaultMaxBytes;
  std::atomic<uint64_t> hits{0}, misses{0}, corrupt{0}, bypassed{0};
};

State& state() {
  static State s;
  return s;
}

std::string default_dir() {
  if (const char* d = std::getenv("HFRT_CACHE_DIR"); d && *d) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/hfrt";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/hfrt";
  return "";
}

/// The configuration, from the environment on first use.
void ensure_configured(State& s) {
  if (s.configured) return;
  s.configured = true;
  const char* off = std::getenv("HFRT_NO_CACHE");
  s.enabled = !(off && *off && std::string(off) != "0");
  s.dir = default_dir();
  if (s.dir.empty()) s.enabled = false;
}

uint64_t fnv1a(std::string_view data) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : data) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

void put_u64(std::string* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(char((v >> (8 * i)) & 0xff));
}

uint64_t get_u64(const char* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}

/// Removes least recently used entries until the folder holds at most 3/4 of `max_bytes`
/// (when it holds more than max_bytes).
void trim(const fs::path& dir, uint64_t max_bytes) {
  std::error_code ec;
  struct Entry {
    fs::path path;
    uint64_t size;
    fs::file_time_type time;
  };
  std::vector<Entry> entries;
  uint64_t total = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() != ".o") continue;
    const uint64_t size = e.file_size(ec);
    if (ec) continue;
    entries.push_back({e.path(), size, e.last_write_time(ec)});
    total += size;
  }
  if (total <= max_bytes) return;
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.time < b.time; });
  for (const Entry& e : entries) {
    if (total <= max_bytes / 4 * 3) break;
    if (fs::remove(e.path, ec)) total -= e.size;
  }
}
}  // namespace

void configure_compile_cache(bool enabled, const std::string& dir, uint64_t max_bytes) {
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  ensure_configured(s);
  s.dir = dir.empty() ? default_dir() : dir;
  s.enabled = enabled && !s.dir.empty();
  s.max_bytes = max_bytes > 0 ? max_bytes : kDefaultMaxBytes;
}

bool compile_cache_enabled() {
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  ensure_configured(s);
  return s.enabled;
}

std::string compile_cache_dir() {
  State& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  ensure_configured(s);
  return s.dir;
}

CompileCacheStats compile_cache_stats() {
  State& s = state();
  return {s.hits.load(), s.misses.load(), s.corrupt.load(), s.bypassed.load()};
}

long clear_compile_cache(std::string* error) {
  const std::string dir = compile_cache_dir();
  std::error_code ec;
  if (dir.empty() || !fs::exists(dir, ec)) return 0;
  long removed = 0;
  fs::directory_iterator it(dir, ec);
  if (ec) {
    if (error) *error = "cannot read " + dir + ": " + ec.message();
    return -1;
  }
  for (const auto& e : it) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() == ".o" || name.rfind(".tmp-", 0) == 0) {
      if (fs::remove(e.path(), ec)) ++removed;
    }
  }
  return removed;
}

void compile_cache_usage(uint64_t* entries, uint64_t* bytes) {
  *entries = 0;
  *bytes = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(compile_cache_dir(), ec)) {
    if (e.path().extension() != ".o") continue;
    ++*entries;
    *bytes += e.file_size(ec);
  }
}

namespace jit {

std::optional<std::string> compile_cache_load(const std::string& key) {
  State& s = state();
  std::string dir;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    ensure_configured(s);
    if (!s.enabled) return std::nullopt;
    dir = s.dir;
  }
  const fs::path path = fs::path(dir) / (key + ".o");
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string data = ss.str();
  std::error_code ec;
  if (data.size() < 24 || std::memcmp(data.data(), kMagic, 8) != 0 ||
      get_u64(data.data() + 8) != data.size() - 24 ||
      get_u64(data.data() + 16) != fnv1a(std::string_view(data).substr(24))) {
    fs::remove(path, ec);
    s.corrupt++;
    return std::nullopt;
  }
  fs::last_write_time(path, fs::file_time_type::clock::now(), ec);  // recently used
  s.hits++;
  return data.substr(24);
}

void compile_cache_store(const std::string& key, std::string_view object) {
  State& s = state();
  std::string dir;
  uint64_t max_bytes;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    ensure_configured(s);
    if (!s.enabled) return;
    dir = s.dir;
    max_bytes = s.max_bytes;
  }
  s.misses++;
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::string data(kMagic, 8);
  put_u64(&data, object.size());
  put_u64(&data, fnv1a(object));
  data.append(object);
  thread_local std::mt19937_64 rng(std::random_device{}());
  const fs::path tmp =
      fs::path(dir) / (".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(rng()));
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(data.data(), std::streamsize(data.size()));
    out.close();
    if (!out) {
      fs::remove(tmp, ec);
      return;
    }
  }
  fs::rename(tmp, fs::path(dir) / (key + ".o"), ec);
  if (ec) fs::remove(tmp, ec);
  trim(dir, max_bytes);
}

void compile_cache_bypass() {
  state().bypassed++;
}

}  // namespace jit
}  // namespace hfrt
