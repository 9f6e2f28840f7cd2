#include "base/module.h"

#include <dlfcn.h>
#include <sys/stat.h>

#include <cstdlib>
#include <map>
#include <mutex>

namespace hfrt {

namespace {

std::string parent_dir(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

bool is_file(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

/// A loaded module's handle, or the error of the first attempt (not retried: the search's
/// answer does not change within a process, and a command that needs the module several times
/// then reports the same error each time).
struct Loaded {
  void* handle = nullptr;
  std::string error;
};

std::mutex g_mutex;
std::map<std::string, Loaded, std::less<>> g_modules;

Loaded load(std::string_view name, ModuleScope scope) {
  const std::string file = "libhfrt_" + std::string(name) + ".so";
  std::string tried;
  std::string last_error;
  for (const std::string& dir : module_search_dirs()) {
    const std::string path = dir + "/" + file;
    if (!tried.empty()) tried += ", ";
    tried += dir;
    if (!is_file(path)) continue;
    const int flags = RTLD_NOW | (scope == ModuleScope::kGlobal ? RTLD_GLOBAL : RTLD_LOCAL);
    if (void* handle = dlopen(path.c_str(), flags)) return {handle, {}};
    const char* why = dlerror();
    last_error = why ? why : "unknown dlopen error";
  }
  if (!last_error.empty()) return {nullptr, "cannot load hfrt module " + file + ": " + last_error};
  return {nullptr, "hfrt module " + file + " not found (looked in " + tried + ")"};
}

}  // namespace

std::vector<std::string> module_search_dirs() {
  if (const char* env = std::getenv("HFRT_MODULE_DIR"); env && *env) return {env};
  std::vector<std::string> dirs;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&module_search_dirs), &info) && info.dli_fname &&
      *info.dli_fname) {
    const std::string self = parent_dir(info.dli_fname);
    dirs.push_back(self);
    dirs.push_back(self + "/hfrt");
    dirs.push_back(self + "/" HFRT_MODULE_BIN_TO_MODULE_DIR);
  }
  dirs.push_back(HFRT_MODULE_INSTALL_DIR);
  dirs.push_back(HFRT_MODULE_BUILD_DIR);
  return dirs;
}

Error stale_module_error(std::string_view name) {
  return Error{"hfrt module libhfrt_" + std::string(name) + ".so is from another build of hfrt",
               "reinstall hfrt, or point HFRT_MODULE_DIR at this build's modules"};
}

Result<void*> module_symbol(std::string_view name, const char* symbol, ModuleScope scope) {
  std::lock_guard<std::mutex> lock(g_mutex);
  auto it = g_modules.find(name);
  if (it == g_modules.end()) it = g_modules.emplace(std::string(name), load(name, scope)).first;
  const Loaded& m = it->second;
  const std::string hint =
      "hfrt's modules are installed in <libdir>/hfrt; set HFRT_MODULE_DIR to the folder that "
      "holds libhfrt_" +
      std::string(name) + ".so";
  if (!m.handle) return Error{m.error, hint};
  dlerror();
  void* address = dlsym(m.handle, symbol);
  if (!address) {
    const char* why = dlerror();
    return Error{"hfrt module libhfrt_" + std::string(name) + ".so has no symbol " + symbol +
                     (why ? std::string(": ") + why : std::string()),
                 hint};
  }
  return address;
}

}  // namespace hfrt
