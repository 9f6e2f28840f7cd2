// `hfrt render` with time (issue 24), end to end: `--time` on a .hf model, frame sequences of a
// scene's [animation] (`-o frame_####.png`, `--frames`, `--shard`), `--resume` after a killed
// run (only the missing frames are rendered; the files equal an uninterrupted run's), `--video`
// through ffmpeg, every bad value's message, and the same binary under mpirun: frames and a
// single tiled image bit-identical to one process.

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "app/sequence.h"
#include "render/image.h"
#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

using testing::CliRun;
using testing::slurp;
namespace fs = std::filesystem;

// The unit sphere moved by x[4] from x = -2 (time 0) to x = 2 (time 1).
const char* const kMoving =
    "my_model(x[4], a[1]) {\n"
    "  cx = -2 + 4 * x[4];\n"
    "  my_model = 1 - (x[1] - cx)^2 - x[2]^2 - x[3]^2;\n"
    "}\n";

// Orthographic, 8 units over 64 pixels wide: pixel x has its centre at (x + 0.5) / 8 - 4.
std::string scene(int frames, const std::string& extra = "", const std::string& size = "64, 16") {
  return "[camera]\neye = [0, 0, 10]\nlook_at = [0, 0, 0]\northo = 8\n"
         "[render]\nsize = [" +
         size + "]\nbackground = [0, 0, 0]\n" + extra +
         "[animation]\nframes = " + std::to_string(frames) +
         "\nend = 1\n[[object]]\nfile = \"moving.hf\"\nbbox = [-4, -2, -2, 4, 2, 2]\n";
}

class SequenceCli : public testing::CliFixture {
 protected:
  SequenceCli() : CliFixture("hfrt_sequence_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("moving.hf", kMoving);
  }

  /// The alpha channel of an image the test wrote.
  std::vector<float> alpha(const std::string& name, int* w = nullptr) {
    int iw = 0, ih = 0, c = 0;
    auto img = render::read_image((dir_ / name).string(), &iw, &ih, &c);
    EXPECT_TRUE(img.ok()) << name;
    std::vector<float> a;
    if (!img.ok() || c < 4) return a;
    for (int i = 0; i < iw * ih; ++i) a.push_back(img.value()[size_t(i) * c + 3]);
    if (w) *w = iw;
    return a;
  }
  /// The mean world x of the covered pixels of the middle row (64 x 16 images).
  double centre(const std::string& name) {
    int w = 0;
    std::vector<float> a = alpha(name, &w);
    double sum = 0, n = 0;
    for (int x = 0; x < w; ++x) {
      const float v = a[size_t(8 * w + x)];
      sum += v * ((x + 0.5) / 8 - 4);
      n += v;
    }
    return n > 0 ? sum / n : NAN;
  }
  std::vector<std::string> files(const std::string& folder) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir_ / folder)) out.push_back(e.path().filename());
    std::sort(out.begin(), out.end());
    return out;
  }
  bool have_mpirun() { return !app::find_on_path("mpirun").empty(); }
};

TEST_F(SequenceCli, TimeOnAModelMovesIt) {
  for (double t : {0.0, 0.25, 0.75}) {
    CliRun r = hfrt(
        "render moving.hf -o m.exr --size 64x16 --ortho 8 --eye 0,0,10 --look-at "
        "0,0,0 --bbox -4,-2,-2,4,2,2 --time " +
        std::to_string(t));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NEAR(centre("m.exr"), -2 + 4 * t, 0.07) << t;
  }
  CliRun r = hfrt("render moving.hf -o m.png --size 8 --time soon");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hfrt render: --time expects a number, e.g. --time 0.5 (got 'soon')\n");
}

TEST_F(SequenceCli, SequenceWritesEveryFrameWhereTheClosedFormPutsIt) {
  write("a.toml", scene(5));
  CliRun r = hfrt("render a.toml -o out/f_##.exr");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(files("out"),
            (std::vector<std::string>{"f_00.exr", "f_01.exr", "f_02.exr", "f_03.exr", "f_04.exr"}));
  for (int f = 0; f < 5; ++f)
    EXPECT_NEAR(centre("out/f_0" + std::to_string(f) + ".exr"), -2 + f, 0.07) << f;
  EXPECT_NE(r.err.find("hfrt: frame 4 (5/5) out/f_04.exr in "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("100%"), std::string::npos);
  EXPECT_NE(r.err.find("hfrt: frames 0..4 of out/f_##.exr: 5 rendered"), std::string::npos);
  // A subset, and a shard of it: every 2nd frame from the 1st.
  r = hfrt("render a.toml -o sub/f_###.png --frames 1:4 --shard 1/2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(files("sub"), (std::vector<std::string>{"f_002.png", "f_004.png"}));
  // One frame of a scene by time.
  r = hfrt("render a.toml -o one.exr --time 0.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(centre("one.exr"), 0, 0.07);
}

TEST_F(SequenceCli, ResumeAfterAKilledRunRendersOnlyTheMissingFrames) {
  write("a.toml", scene(24, "spp = 4\n", "256, 192"));
  CliRun r = hfrt("render a.toml -o ref/f_####.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Kill -9 once the third frame is in place (the frames take tens of milliseconds each).
  r = shell("(" HFRT_BINARY_DIR
            "/tools/hfrt/hfrt render a.toml -o run/f_####.png & pid=$!; "
            "while [ ! -e run/f_0002.png ]; do sleep 0.005; done; kill -9 $pid; wait $pid; "
            "exit 0)");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> before;
  for (const std::string& f : files("run"))
    if (f[0] != '.') before.push_back(f);
  ASSERT_GE(before.size(), 3u);
  ASSERT_LT(before.size(), 24u) << "the run finished before the kill: frames too fast to test";
  // Every file under a final name is complete: equal to the uninterrupted run's.
  for (const std::string& f : before)
    EXPECT_EQ(slurp(dir_ / "run" / f), slurp(dir_ / "ref" / f)) << f;
  r = hfrt("render a.toml -o run/f_####.png --resume");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(
      r.err.find("hfrt: --resume: " + std::to_string(before.size()) + " frames already written, " +
                 std::to_string(24 - before.size()) + " to render"),
      std::string::npos)
      << r.err;
  for (const std::string& f : before)
    EXPECT_EQ(r.err.find(" run/" + f + " in"), std::string::npos) << f << " rendered again";
  std::vector<std::string> after;
  for (const std::string& f : files("run"))
    if (f.rfind(".hfrt-partial-", 0) != 0) after.push_back(f);
  EXPECT_EQ(after, files("ref"));
  for (const std::string& f : files("ref"))
    EXPECT_EQ(slurp(dir_ / "run" / f), slurp(dir_ / "ref" / f)) << f;
}

TEST_F(SequenceCli, VideoThroughFfmpeg) {
  write("a.toml", scene(6));
  CliRun r = hfrt("render a.toml -o out/f_###.png --video clip.mp4 --fps 12");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("hfrt: wrote clip.mp4 (6 frames at 12 fps)"), std::string::npos) << r.err;
  const std::string mp4 = slurp(dir_ / "clip.mp4");
  ASSERT_GT(mp4.size(), 8u);
  EXPECT_EQ(mp4.substr(4, 4), "ftyp");  // an ISO media file
  // Without ffmpeg on PATH: refused before rendering anything.
  r = shell("PATH=/nonexistent " HFRT_BINARY_DIR
            "/tools/hfrt/hfrt render a.toml -o v/f_###.png --video clip2.mp4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hfrt render: --video needs ffmpeg, which is not on PATH (Debian: apt-get install "
            "ffmpeg)\n");
  EXPECT_FALSE(fs::exists(dir_ / "v"));
}

// The REPL's `:set time T` renders a loaded scene at T.
TEST_F(SequenceCli, ReplRendersASceneAtTheTimeSet) {
  write("a.toml", scene(5));
  CliRun r = hfrt("repl", ":scene a.toml\n:set time 0.75\n:scene -o r.exr\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(centre("r.exr"), 1.0, 0.07) << r.out << r.err;
}

// A model's compile warnings reach the user from a scene too (regression: they were dropped).
TEST_F(SequenceCli, ModelWarningsOfAScene) {
  write("warn.hf",
        "my_model(x[4], a[1]) {\n  array c[3];\n  c = [0, 0, 0];\n"
        "  my_model = hfSphere(x, c, 1);\n}\n");
  write("w.toml",
        "[render]\nsize = [8, 8]\n[[object]]\nfile = \"warn.hf\"\nbbox = [-2, -2, -2, 2, 2, 2]\n");
  CliRun r = hfrt("render w.toml -o w.png");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warn.hf:4:23: warning: hfSphere: the point array 'x' has 4 elements, not "
                       "3; the call returns the failure value -1111111111111.0"),
            std::string::npos)
      << r.err;
}

TEST_F(SequenceCli, BadPatternsFramesAndShardsAreRefused) {
  write("a.toml", scene(5));
  struct Case {
    std::string args, err;
  };
  const std::vector<Case> cases = {
      {"a.toml -o f.png --frames 0:3",
       "hfrt render: --frames renders a sequence: give -o a frame number pattern, e.g. -o "
       "out/frame_####.png\n"},
      {"a.toml -o f.png --resume",
       "hfrt render: --resume renders a sequence: give -o a frame number pattern, e.g. -o "
       "out/frame_####.png\n"},
      {"a.toml -o f_##_##.png",
       "hfrt render: -o f_##_##.png: the frame number is one run of '#' (e.g. "
       "out/frame_####.png), this has two\n"},
      {"a.toml -o run_##/f.png",
       "hfrt render: -o run_##/f.png: the frame number ('#') belongs in the file name, not in a "
       "folder (e.g. out/frame_####.png)\n"},
      {"a.toml -o f_##",
       "hfrt render: -o f_##: the frames need a file extension after the frame number (e.g. "
       "frame_####.png)\n"},
      {"a.toml -o f_##.png --frames 3:1",
       "hfrt render: --frames 3:1: the first frame is after the last\n"},
      {"a.toml -o f_##.png --frames 2:9",
       "hfrt render: --frames 2:9: the animation has 5 frames (0:4)\n"},
      {"a.toml -o f_##.png --frames -1:2",
       "hfrt render: --frames expects A:B or A (frame numbers from 0; this animation has 0:4), "
       "got '-1:2'\n"},
      {"a.toml -o f_##.png --shard 2/2",
       "hfrt render: --shard 2/2: K must be at least 0 and less than N (e.g. 0/4 ... 3/4)\n"},
      {"a.toml -o f_##.png --shard two",
       "hfrt render: --shard expects K/N (this job renders every N-th frame from the K-th; 0 <= "
       "K < N), got 'two'\n"},
      {"a.toml -o f_##.png --time 0.5",
       "hfrt render: --time renders one frame; -o f_##.png names a sequence (choose its frames "
       "with --frames A:B)\n"},
      {"a.toml -o f_##.png --shard 0/2 --video v.mp4",
       "hfrt render: --video with --shard: each shard has only part of the frames; encode the "
       "video when every shard is done\n"},
      {"moving.hf -o f_##.png --frames 0:3",
       "hfrt render: --frames renders the frames of a scene file's [animation]; for a .hf model "
       "render one time with --time T (or place it in a scene)\n"},
  };
  for (const Case& c : cases) {
    CliRun r = hfrt("render " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_EQ(r.err, c.err) << c.args;
  }
}

TEST_F(SequenceCli, MpiRanksGiveTheOneProcessResultBitForBit) {
  // scripts/install-deps.sh installs openmpi-bin: a missing mpirun fails, it never skips.
  ASSERT_TRUE(have_mpirun()) << "mpirun is not installed: run scripts/install-deps.sh";
  write("a.toml", scene(4, "spp = 4\n", "96, 48"));
  // Under make test-asan the ranks unwind allocation stacks the slow way, so that LeakSanitizer
  // can name what Open MPI's own progress thread keeps past MPI_Finalize (libevent_core, in
  // scripts/sanitizers/lsan.supp); without a sanitizer ASAN_OPTIONS is read by nobody.
  const std::string mpirun =
      "mpirun --allow-run-as-root --oversubscribe -np 3 "
      "env ASAN_OPTIONS=\"${ASAN_OPTIONS}:fast_unwind_on_malloc=0\" ";
  const std::string hfrt_bin = HFRT_BINARY_DIR "/tools/hfrt/hfrt";
  // A single image by tiles (dynamic batches).
  CliRun one = hfrt("render a.toml -o one.exr --time 0.4");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  CliRun many = shell(mpirun + hfrt_bin + " render a.toml -o many.exr --time 0.4");
  ASSERT_EQ(many.exit_code, 0) << many.err;
  EXPECT_NE(many.err.find("3 processes"), std::string::npos) << many.err;
  int w1 = 0, h1 = 0, c1 = 0, w2 = 0, h2 = 0, c2 = 0;
  auto a = render::read_image((dir_ / "one.exr").string(), &w1, &h1, &c1);
  auto b = render::read_image((dir_ / "many.exr").string(), &w2, &h2, &c2);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a.value(), b.value());  // every float of every channel
  // Frames, split by frame across the ranks.
  one = hfrt("render a.toml -o s1/f_#.png");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  many = shell(mpirun + hfrt_bin + " render a.toml -o s3/f_#.png");
  ASSERT_EQ(many.exit_code, 0) << many.err;
  EXPECT_NE(many.err.find("hfrt[rank 2]: frame 2"), std::string::npos) << many.err;
  EXPECT_EQ(files("s1"), files("s3"));
  for (const std::string& f : files("s1"))
    EXPECT_EQ(slurp(dir_ / "s1" / f), slurp(dir_ / "s3" / f)) << f;
}

}  // namespace
}  // namespace hfrt::tools
