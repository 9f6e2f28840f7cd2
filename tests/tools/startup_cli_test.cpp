// Start-up (issue 25): a command loads only the libraries it needs. The `hfrt` executable is a
// launcher that runs `check` and the help itself (tools/hfrt/main.cpp) and loads the command
// module libhfrt_cli.so (LLVM, TBB, Open MPI) for the other subcommands; OpenImageIO lives in
// the image I/O module (render/image_io_module.h), loaded when an image other than a PNG is
// written, or any image read (PNGs have a writer on zlib, render/png_writer.h). A missing
// module is a clear error.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

using testing::CliFixture;
using testing::CliRun;

class StartupCliTest : public CliFixture {
 protected:
  StartupCliTest() : CliFixture("hfrt_startup_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("ball.hf",
          "my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
  }
  /// The shared objects the dynamic loader opened while running `hfrt ARGS` (LD_DEBUG=files
  /// prints one "file=NAME [0];  needed by" or "dynamically loaded by" line per object).
  std::string loaded(const std::string& args) {
    CliRun r = shell("(LD_DEBUG=files " HFRT_BINARY_DIR "/tools/hfrt/hfrt " + args +
                     " 2>&1 >/dev/null | grep -o 'file=[^ ]*' | sort -u)");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  }
};

TEST_F(StartupCliTest, ExecutableLinksNoHeavyLibrary) {
  CliRun r = shell("readelf -d " HFRT_BINARY_DIR "/tools/hfrt/hfrt");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(NEEDED)"), std::string::npos) << r.out;
  for (const char* lib : {"OpenImageIO", "LLVM", "libtbb", "libmpi", "assimp", "libedit"}) {
    EXPECT_EQ(r.out.find(lib), std::string::npos) << lib << " in\n" << r.out;
  }
}

TEST_F(StartupCliTest, CheckAndHelpLoadNoHeavyLibrary) {
  for (const char* args : {"check ball.hf", "--help", "check --help"}) {
    const std::string files = loaded(args);
    EXPECT_NE(files.find("libc.so"), std::string::npos) << args << ":\n" << files;
    for (const char* lib : {"OpenImageIO", "LLVM", "libtbb", "libmpi", "assimp", "libhfrt_"}) {
      EXPECT_EQ(files.find(lib), std::string::npos) << lib << " for " << args << ":\n" << files;
    }
  }
}

TEST_F(StartupCliTest, HelpListsEverySubcommand) {
  CliRun r = hfrt("--help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* sub :
       {"check", "ir", "eval", "render", "slice", "repl", "emit", "mesh", "cache"}) {
    EXPECT_NE(r.out.find(std::string("\n  ") + sub + " "), std::string::npos) << sub << r.out;
  }
  EXPECT_EQ(r.out.find("gpu-cases"), std::string::npos) << r.out;  // hidden
  EXPECT_NE(r.out.find("--no-cache"), std::string::npos) << r.out;
  // The command module's help of a subcommand, and usage errors, exit as before.
  CliRun e = hfrt("eval --help");
  EXPECT_EQ(e.exit_code, 0) << e.err;
  EXPECT_NE(e.out.find("--interval"), std::string::npos) << e.out;
  EXPECT_EQ(hfrt("").exit_code, 2);
  EXPECT_EQ(hfrt("frobnicate ball.hf").exit_code, 2);
  EXPECT_EQ(hfrt("check").exit_code, 2);
}

TEST_F(StartupCliTest, EvalLoadsTheCommandModuleAndLlvm) {
  CliRun r = hfrt("eval ball.hf", "0.5 0 0\n");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("0.75 ", 0), 0u) << r.out;
  const std::string files = loaded("eval ball.hf");
  EXPECT_NE(files.find("libhfrt_cli.so"), std::string::npos) << files;
#if HFRT_STATIC_LLVM
  // LLVM's components are linked into the module (cmake/HfrtDependencies.cmake): loading the
  // shared libLLVM beside it as well would cost its ~60 ms again, and z3 and libxml2 with it.
  EXPECT_EQ(files.find("libLLVM"), std::string::npos) << files;
  EXPECT_EQ(files.find("libz3"), std::string::npos) << files;
#else
  EXPECT_NE(files.find("libLLVM"), std::string::npos) << files;
#endif
  EXPECT_EQ(files.find("OpenImageIO"), std::string::npos) << files;
}

TEST_F(StartupCliTest, PerfMapNamesTheJitCode) {
  // HFRT_PERF_MAP=1 appends "ADDR SIZE hfrt:UNIT" per compiled unit to /tmp/perf-PID.map,
  // where `perf report` looks up JIT code (jit/llvm_session.cpp; docs/architecture.md).
  const std::string ball = (dir_ / "ball.hf").string();
  CliRun r =
      shell("(echo '0 0 0' | HFRT_PERF_MAP=1 " HFRT_BINARY_DIR "/tools/hfrt/hfrt eval '" + ball +
            "' >/dev/null & p=$!; wait $p; cat /tmp/perf-$p.map; rm -f /tmp/perf-$p.map)");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  unsigned long long addr = 0, size = 0;
  char name[64] = {};
  ASSERT_EQ(std::sscanf(r.out.c_str(), "%llx %llx hfrt:%63s", &addr, &size, name), 3) << r.out;
  EXPECT_NE(addr, 0u);
  EXPECT_GT(size, 16u) << "the entry's size from the object's symbol table";
  EXPECT_EQ(std::string(name).rfind("hfrt_eval_f64", 0), 0u) << r.out;
  // Without the variable nothing is written.
  CliRun off = shell("(echo '0 0 0' | " HFRT_BINARY_DIR "/tools/hfrt/hfrt eval '" + ball +
                     "' >/dev/null & p=$!; wait $p; test ! -e /tmp/perf-$p.map)");
  EXPECT_EQ(off.exit_code, 0);
}

TEST_F(StartupCliTest, MissingCommandModuleIsAClearError) {
  std::filesystem::create_directories(dir_ / "empty");
  CliRun r = shell("HFRT_MODULE_DIR='" + (dir_ / "empty").string() +
                   "' " HFRT_BINARY_DIR "/tools/hfrt/hfrt eval ball.hf");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.err, "hfrt: cannot run 'eval': hfrt module libhfrt_cli.so not found (looked in " +
                       (dir_ / "empty").string() +
                       ")\nhint: hfrt's modules are installed in <libdir>/hfrt; set "
                       "HFRT_MODULE_DIR to the folder that holds libhfrt_cli.so\n");
  // `check` needs no module.
  CliRun c = shell("HFRT_MODULE_DIR='" + (dir_ / "empty").string() +
                   "' " HFRT_BINARY_DIR "/tools/hfrt/hfrt check ball.hf");
  EXPECT_EQ(c.exit_code, 0) << c.err;
}

TEST_F(StartupCliTest, WritingAPngLoadsNoImageModule) {
  // PNG has its own writer on zlib (render/png_writer.h); other formats load the module.
  for (const char* out : {"ball.png", "ball.PNG"}) {
    const std::string files = loaded(std::string("render ball.hf --size 16 -o ") + out);
    EXPECT_EQ(files.find("libhfrt_imageio.so"), std::string::npos) << out << ":\n" << files;
    EXPECT_EQ(files.find("OpenImageIO"), std::string::npos) << out << ":\n" << files;
    EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / out));
  }
  const std::string slice = loaded("slice ball.hf --size 16 -o slice.png");
  EXPECT_EQ(slice.find("libhfrt_imageio.so"), std::string::npos) << slice;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / "slice.png"));
}

TEST_F(StartupCliTest, WritingAnExrLoadsTheModule) {
  const std::string files = loaded("render ball.hf --size 16 -o ball.exr");
  EXPECT_NE(files.find("libhfrt_imageio.so"), std::string::npos) << files;
  EXPECT_NE(files.find("OpenImageIO"), std::string::npos) << files;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / "ball.exr"));
}

TEST_F(StartupCliTest, MissingImageModuleIsAClearError) {
  // A module folder with the command module but without the image module.
  const std::filesystem::path mods = dir_ / "mods";
  std::filesystem::create_directories(mods);
  std::filesystem::copy_file(HFRT_MODULE_BUILD_DIR "/libhfrt_cli.so", mods / "libhfrt_cli.so");
  CliRun r = shell("HFRT_MODULE_DIR='" + mods.string() +
                   "' " HFRT_BINARY_DIR "/tools/hfrt/hfrt render ball.hf --size 16 -o ball.exr");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("hfrt: cannot write 'ball.exr': hfrt module libhfrt_imageio.so not found "
                       "(looked in " +
                       mods.string() + ")"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "ball.exr"));
  // A PNG needs no module.
  CliRun png = shell("HFRT_MODULE_DIR='" + mods.string() +
                     "' " HFRT_BINARY_DIR "/tools/hfrt/hfrt render ball.hf --size 16 -o ball.png");
  EXPECT_EQ(png.exit_code, 0) << png.err;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_ / "ball.png"));
}

}  // namespace
}  // namespace hfrt::tools
