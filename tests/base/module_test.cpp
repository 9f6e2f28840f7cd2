// base/module.h: finding hfrt's run-time modules and their symbols, and the errors when either
// is missing. The image I/O module (render/) is the one real module; the build puts it in the
// folder module_search_dirs() ends with.
#include "base/module.h"

#include <gtest/gtest.h>

namespace hfrt {
namespace {

TEST(Module, FindsTheImageModuleOfThisBuild) {
  const std::vector<std::string> dirs = module_search_dirs();
  ASSERT_FALSE(dirs.empty());
  EXPECT_EQ(dirs.back(), HFRT_MODULE_BUILD_DIR);
  auto entry = module_symbol("imageio", "hfrt_image_io_module");
  ASSERT_TRUE(entry.ok()) << entry.error().message;
  EXPECT_NE(entry.value(), nullptr);
  // Loaded once: the second lookup gives the same address.
  auto again = module_symbol("imageio", "hfrt_image_io_module");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value(), entry.value());
}

TEST(Module, MissingSymbolNamesModuleAndSymbol) {
  auto entry = module_symbol("imageio", "hfrt_no_such_entry");
  ASSERT_FALSE(entry.ok());
  EXPECT_EQ(entry.error().message.rfind(
                "hfrt module libhfrt_imageio.so has no symbol hfrt_no_such_entry", 0),
            0u)
      << entry.error().message;
  EXPECT_NE(entry.error().hint.find("HFRT_MODULE_DIR"), std::string::npos);
}

TEST(Module, MissingModuleListsTheFoldersSearched) {
  auto entry = module_symbol("no_such_module", "x");
  ASSERT_FALSE(entry.ok());
  const std::string& m = entry.error().message;
  EXPECT_EQ(m.rfind("hfrt module libhfrt_no_such_module.so not found (looked in ", 0), 0u) << m;
  EXPECT_NE(m.find(HFRT_MODULE_BUILD_DIR), std::string::npos) << m;
}

}  // namespace
}  // namespace hfrt
