#pragma once
// The compile cache's store (hfrt/compile_cache.h): files, bounds and statistics, no LLVM.
// jit/llvm_session.cpp makes the keys and asks it before compiling.

#include <optional>
#include <string>
#include <string_view>

namespace hfrt::jit {

/// The object file stored under `key` (hex), or nothing: missing, unreadable, or corrupt (then
/// removed and counted). Counts a hit when found.
std::optional<std::string> compile_cache_load(const std::string& key);
/// Stores `object` under `key` (atomically; failures are silent: the cache is an
/// optimisation), counts a miss, and trims the folder to its bound.
void compile_cache_store(const std::string& key, std::string_view object);
/// Counts a compile that cannot be cached.
void compile_cache_bypass();

}  // namespace hfrt::jit
