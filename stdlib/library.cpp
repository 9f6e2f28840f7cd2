// Temporary stub so that the tree links while the library is written (stdlib issue).
#include "stdlib/library.h"

#include "lang/check.h"

namespace hfrt::stdlib {

jit::ValueId lower_library_call(lang::LibraryFn fn, LibContext& ctx, std::span<const LibArg> args) {
  HFRT_CHECK_MSG(false, "library function not implemented yet: " << lang::library_fn_name(fn));
}

}  // namespace hfrt::stdlib
