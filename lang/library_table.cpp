// FRep library signature lookups.
#include "lang/library_table.h"

#include <array>

#include "base/check.h"
#include "lang/names.h"

namespace hfrt::lang {
namespace {

struct LibraryInfo {
  std::string_view name;
  std::string_view kinds;
};

constexpr std::array kLibrary = {
#define HFRT_X(e, s, k) LibraryInfo{s, k},
    HFRT_LIBRARY(HFRT_X)
#undef HFRT_X
};
static_assert(kLibrary.size() == kLibraryFnCount);

const LibraryInfo& info(LibraryFn f) {
  auto i = static_cast<size_t>(f);
  HFRT_CHECK_LT(i, kLibrary.size());
  return kLibrary[i];
}

}  // namespace

std::optional<LibraryFn> find_library_fn(std::string_view name) {
  for (size_t i = 0; i < kLibrary.size(); ++i) {
    if (same_name(kLibrary[i].name, name)) return static_cast<LibraryFn>(i);
  }
  return std::nullopt;
}

std::string_view library_fn_name(LibraryFn f) {
  return info(f).name;
}
std::string_view library_fn_kinds(LibraryFn f) {
  return info(f).kinds;
}

}  // namespace hfrt::lang
