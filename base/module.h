#pragma once
// hfrt's run-time modules: parts of hfrt built as shared objects (libhfrt_<name>.so) and loaded
// with dlopen the first time a command needs them. A module carries a heavy dependency tree
// that most commands never use: OpenImageIO alone brings about 250 shared libraries whose
// relocation cost ~0.3 s of CPU at every process start (issue 25), while `hfrt check`, `hfrt
// eval` or a library user that never writes an image needs none of it.
//
// Where a module is looked for, in this order:
//   1. $HFRT_MODULE_DIR, when set (and then only there: tests and relocated installs use it);
//   2. beside the object that holds this code (the hfrt executable, libhfrt.so or the Python
//      extension), then in its `hfrt/` subfolder and in the install tree's libdir/hfrt relative
//      to the executable's bindir;
//   3. the install folder and the build folder this hfrt was configured with.

#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace hfrt {

/// The folders searched for modules, in order (see above); for error messages and tests.
std::vector<std::string> module_search_dirs();

/// How a module's symbols and its dependencies' are seen by libraries loaded after it.
enum class ModuleScope {
  kLocal,   ///< RTLD_LOCAL: they cannot interpose on later libraries (the default)
  kGlobal,  ///< RTLD_GLOBAL: for a module whose dependencies load plugins of their own that
            ///< resolve symbols in them (Open MPI's components in libmpi)
};

/// The address of `symbol` in module `name` (file libhfrt_<name>.so), loading the module on the
/// first call (with `scope`; later calls get the module as first loaded). Thread-safe; a module
/// is loaded once per process and never unloaded. An environment failure (module not found, not
/// loadable, symbol missing) is an Error naming the module, the folders searched and the
/// loader's message, with a hint.
Result<void*> module_symbol(std::string_view name, const char* symbol,
                            ModuleScope scope = ModuleScope::kLocal);

/// The error of a module whose table has another ABI number: it is left over from another build.
Error stale_module_error(std::string_view name);

/// The function table of module `name`: its entry point `entry_symbol` is an extern "C"
/// function returning `const Table*`, and `Table::abi_version` must equal `abi_version` (the
/// number the loading code was built with; both sides of a module boundary come from one tree
/// and may pass C++ types). Errors as module_symbol's, or stale_module_error.
template <typename Table>
Result<const Table*> module_table(std::string_view name, const char* entry_symbol,
                                  int abi_version) {
  Result<void*> entry = module_symbol(name, entry_symbol);
  if (!entry.ok()) return entry.error();
  using EntryFn = const Table* (*)();
  const Table* table = reinterpret_cast<EntryFn>(entry.value())();
  if (!table || table->abi_version != abi_version) return stale_module_error(name);
  return table;
}

}  // namespace hfrt
