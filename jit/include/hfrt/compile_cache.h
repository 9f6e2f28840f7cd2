#pragma once
// hfrt's compile cache on disk (docs/compile_cache.md): the machine code of every JIT compile
// is kept under a key made of the LLVM IR before optimisation, the pipeline options, the host
// CPU and its features, the LLVM version and the cache format, so that a second process that
// compiles the same model with the same options loads the code instead of compiling it.
// Defaults: on, in $HFRT_CACHE_DIR, else $XDG_CACHE_HOME/hfrt, else $HOME/.cache/hfrt, at most
// 512 MiB (least recently used entries go first). HFRT_NO_CACHE=1 switches it off. Entries are
// written atomically (a whole file renamed into place) and checked on load (a corrupt or
// truncated entry is removed and the code compiled again), so concurrent processes share one
// folder safely. Code that holds addresses of this process (mesh and patch leaves) is never
// cached.

#include <cstdint>
#include <string>

namespace hfrt {

struct CompileCacheStats {
  uint64_t hits = 0;      ///< compiles answered from the cache
  uint64_t misses = 0;    ///< compiles that ran (and stored their code)
  uint64_t corrupt = 0;   ///< entries found damaged (removed; the code was compiled again)
  uint64_t bypassed = 0;  ///< compiles that cannot be cached (process addresses in the code)
};

/// Switches the cache on or off for this process (`--no-cache`), and sets its folder ("" = the
/// default above) and size bound (0 = the default).
void configure_compile_cache(bool enabled, const std::string& dir = "", uint64_t max_bytes = 0);
bool compile_cache_enabled();
/// The folder in use.
std::string compile_cache_dir();
/// This process's figures.
CompileCacheStats compile_cache_stats();
/// Removes every entry of the folder (`hfrt cache clear`): the number removed, or -1 with
/// `*error` when the folder cannot be read.
long clear_compile_cache(std::string* error);
/// Entries and bytes in the folder (`hfrt cache info`).
void compile_cache_usage(uint64_t* entries, uint64_t* bytes);

}  // namespace hfrt
