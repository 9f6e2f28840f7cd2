// `hfrt mesh`: the files it writes (read back by geom's Assimp importer and checked against
// the closed-form sphere), colours in PLY and OBJ, glTF binary, the same file on 1 and 2
// threads, and the text of every user error (no surface, --resolution 0, unwritable output,
// unknown format, --time, a 2-D object). Runs the real binary.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <numbers>
#include <string>
#include <tuple>

#include "geom/mesh.h"
#include "tests/malloc_pages.h"
#include "tests/mesher/mesh_check.h"
#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

using testing::CliFixture;
using testing::CliRun;
using testing::slurp;

class MeshCliTest : public CliFixture {
 protected:
  MeshCliTest() : CliFixture("hfrt_mesh_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("sphere.hf",
          "my_model(x[3], a[1]) { my_model = 1 - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }\n");
    write("colour.hf",
          "my_model(x[3], a[1], s[3]) {\n  s[1] = 1; s[2] = 0.5; s[3] = 0;\n"
          "  my_model = 1 - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]);\n}\n");
    write("empty.hf", "my_model(x[3], a[1]) { my_model = -1 - x[1]*x[1]; }\n");
    write("flat.hf", "my_model(x[2], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2]; }\n");
  }
};

/// Reads a binary STL (80-byte header, count, 50 bytes per triangle) and welds the corners by
/// exact position (STL has no shared vertices).
bool read_binary_stl(const std::string& bytes, std::vector<Vec3>* v,
                     std::vector<std::array<uint32_t, 3>>* tris) {
  if (bytes.size() < 84) return false;
  uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  if (bytes.size() != 84 + size_t(n) * 50) return false;
  std::map<std::tuple<float, float, float>, uint32_t> index;
  for (uint32_t t = 0; t < n; ++t) {
    std::array<uint32_t, 3> tri;
    for (int c = 0; c < 3; ++c) {
      float p[3];
      std::memcpy(p, bytes.data() + 84 + size_t(t) * 50 + 12 + 12 * c, 12);
      auto [it, fresh] = index.try_emplace({p[0], p[1], p[2]}, uint32_t(v->size()));
      if (fresh) v->push_back({p[0], p[1], p[2]});
      tri[c] = it->second;
    }
    tris->push_back(tri);
  }
  return true;
}

TEST_F(MeshCliTest, WritesAClosedSphereAsStl) {
  CliRun r = hfrt("mesh sphere.hf -o ball.stl --resolution 48 --stats");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("hfrt: wrote ball.stl"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("stats: octree"), std::string::npos) << r.err;
  std::vector<Vec3> v;
  std::vector<std::array<uint32_t, 3>> tris;
  ASSERT_TRUE(read_binary_stl(slurp(dir_ / "ball.stl"), &v, &tris));
  EXPECT_EQ(mesher::testing::check_closed_manifold(v, tris), "");
  EXPECT_NEAR(mesher::testing::mesh_volume(v, tris) / (4.0 / 3.0 * std::numbers::pi), 1.0, 0.005);
  // geom's importer (Assimp) reads it back too.
  auto mesh = geom::load_mesh((dir_ / "ball.stl").string());
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  EXPECT_EQ(mesh->triangles.size(), tris.size());
}

// The launcher runs the command with malloc on transparent huge pages where the kernel has
// them in madvise mode (base/memory.h); HFRT_MALLOC_HUGEPAGES=0 and a GLIBC_TUNABLES of the
// user's that already sets glibc.malloc.hugetlb turn it off. The file is the same either way.
TEST_F(MeshCliTest, MallocOnHugePagesWhereTheKernelAdvisesThem) {
  const std::string mode = hfrt::testing::thp_mode();
  const char* kDefault = hfrt::testing::kMallocDefaultPagesLine;
  CliRun on = hfrt("mesh sphere.hf -o on.ply --resolution 24 --stats");
  ASSERT_EQ(on.exit_code, 0) << on.err;
  EXPECT_NE(on.err.find(hfrt::testing::expected_malloc_line()), std::string::npos)
      << "THP mode '" << mode << "'\n"
      << on.err;
  CliRun off = shell("HFRT_MALLOC_HUGEPAGES=0 " HFRT_BINARY_DIR
                     "/tools/hfrt/hfrt mesh sphere.hf -o off.ply --resolution 24 --stats");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  EXPECT_NE(off.err.find(kDefault), std::string::npos) << off.err;
  CliRun user = shell("GLIBC_TUNABLES=glibc.malloc.hugetlb=0 " HFRT_BINARY_DIR
                      "/tools/hfrt/hfrt mesh sphere.hf -o user.ply --resolution 24 --stats");
  ASSERT_EQ(user.exit_code, 0) << user.err;
  EXPECT_NE(user.err.find(kDefault), std::string::npos) << user.err;
  EXPECT_EQ(slurp(dir_ / "on.ply"), slurp(dir_ / "off.ply"));
  EXPECT_EQ(slurp(dir_ / "on.ply"), slurp(dir_ / "user.ply"));
}

// A scene file: each [[object]] meshed in its box and placed. Two unit balls scaled by 0.5 and
// 1.5 and moved apart: two closed shells whose volumes add to (0.5^3 + 1.5^3) 4/3 pi, every
// vertex on one of the placed spheres.
TEST_F(MeshCliTest, SceneFileMeshesEveryObjectPlaced) {
  write("two.toml",
        "[[object]]\nfile = \"sphere.hf\"\nbbox = [-2, -2, -2, 2, 2, 2]\n"
        "scale = 0.5\ntranslate = [-3, 0, 0]\n"
        "[[object]]\nfile = \"sphere.hf\"\nbbox = [-2, -2, -2, 2, 2, 2]\n"
        "scale = 1.5\nrotate = [0, 0, 30]\ntranslate = [2, 1, 0]\n");
  CliRun r = hfrt("mesh two.toml -o two.stl --resolution 48");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<Vec3> v;
  std::vector<std::array<uint32_t, 3>> tris;
  ASSERT_TRUE(read_binary_stl(slurp(dir_ / "two.stl"), &v, &tris));
  EXPECT_EQ(mesher::testing::check_closed_manifold(v, tris), "");
  const double expect = (0.125 + 3.375) * 4.0 / 3.0 * std::numbers::pi;
  EXPECT_NEAR(mesher::testing::mesh_volume(v, tris) / expect, 1.0, 0.01);
  for (const Vec3& p : v) {
    double d1 = std::abs(length(p - Vec3{-3, 0, 0}) - 0.5);
    double d2 = std::abs(length(p - Vec3{2, 1, 0}) - 1.5);
    EXPECT_LT(std::min(d1, d2), 2e-3) << p.x << " " << p.y << " " << p.z;
  }
  // Model options belong to the [[object]]s.
  r = hfrt("mesh two.toml -o x.stl --bbox 1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--bbox, --object and -a apply to a .hf model"), std::string::npos) << r.err;
}

// Time (issue 24): a model moved by x[4] and a scene with keyed translate are meshed where the
// time puts them: every vertex on the unit sphere at its centre for that time.
TEST_F(MeshCliTest, TimeMovesModelsAndScenes) {
  write("moving.hf",
        "my_model(x[4], a[1]) { my_model = 1 - (x[1] - (-2 + 4 * x[4]))^2 - x[2]^2 - x[3]^2; }\n");
  write("keyed.toml",
        "[animation]\nframes = 3\nend = 1\n[[object]]\nfile = \"sphere.hf\"\n"
        "bbox = [-2, -2, -2, 2, 2, 2]\ntranslate = [{ keys = [[0, -2], [1, 2]] }, 0, 0]\n");
  struct Case {
    std::string args;
    double cx;
  };
  for (const Case& c : {Case{"mesh moving.hf -o m.stl --bbox -4,-2,-2,4,2,2 --time 0.75", 1.0},
                        Case{"mesh keyed.toml -o m.stl --time 0.25", -1.0},
                        Case{"mesh keyed.toml -o m.stl", -2.0}}) {
    CliRun r = hfrt(c.args + " --resolution 32");
    ASSERT_EQ(r.exit_code, 0) << c.args << "\n" << r.err;
    std::vector<Vec3> v;
    std::vector<std::array<uint32_t, 3>> tris;
    ASSERT_TRUE(read_binary_stl(slurp(dir_ / "m.stl"), &v, &tris));
    ASSERT_FALSE(v.empty());
    for (const Vec3& p : v) {
      EXPECT_LT(std::abs(length(p - Vec3{float(c.cx), 0, 0}) - 1), 5e-3) << c.args;
    }
  }
}

TEST_F(MeshCliTest, ColoursInPlyAndObj) {
  ASSERT_EQ(hfrt("mesh colour.hf -o c.ply --resolution 16").exit_code, 0);
  const std::string ply = slurp(dir_ / "c.ply");
  EXPECT_NE(ply.find("property uchar red"), std::string::npos) << ply.substr(0, 400);
  ASSERT_EQ(hfrt("mesh colour.hf -o c.obj --resolution 16").exit_code, 0);
  const std::string obj = slurp(dir_ / "c.obj");
  // `v x y z r g b` with s = (1, 0.5, 0).
  EXPECT_NE(obj.find(" 1 0.5 0\n"), std::string::npos) << obj.substr(0, 400);
  ASSERT_EQ(hfrt("mesh colour.hf -o c.glb --resolution 16").exit_code, 0);
  EXPECT_NE(slurp(dir_ / "c.glb").find("COLOR_0"), std::string::npos);
  ASSERT_EQ(hfrt("mesh colour.hf -o plain.ply --resolution 16 --no-color").exit_code, 0);
  EXPECT_EQ(slurp(dir_ / "plain.ply").find("red"), std::string::npos);
}

TEST_F(MeshCliTest, SimplifyGivesFewerTriangles) {
  CliRun full = hfrt("mesh sphere.hf -o full.stl --resolution 40");
  CliRun simple = hfrt("mesh sphere.hf -o simple.stl --resolution 40 --simplify 0.005 --stats");
  ASSERT_EQ(full.exit_code, 0) << full.err;
  ASSERT_EQ(simple.exit_code, 0) << simple.err;
  EXPECT_NE(simple.err.find("stats: simplify "), std::string::npos) << simple.err;
  std::vector<Vec3> v1, v2;
  std::vector<std::array<uint32_t, 3>> t1, t2;
  ASSERT_TRUE(read_binary_stl(slurp(dir_ / "full.stl"), &v1, &t1));
  ASSERT_TRUE(read_binary_stl(slurp(dir_ / "simple.stl"), &v2, &t2));
  EXPECT_LT(t2.size() * 2, t1.size());
  EXPECT_EQ(mesher::testing::check_closed_manifold(v2, t2), "");
  CliRun bad = hfrt("mesh sphere.hf -o s.stl --simplify -1");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err,
            "hfrt mesh: --simplify expects a positive error bound (a distance in model units)\n");
}

TEST_F(MeshCliTest, CellSizeSetsTheGrid) {
  CliRun r = hfrt("mesh sphere.hf -o c.stl --bbox 1.2 --cell 0.05 --stats");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("grid 48x48x48 cells"), std::string::npos) << r.err;
  CliRun fine = hfrt("mesh sphere.hf -o c.stl --bbox 1 --cell 0.0001");
  EXPECT_EQ(fine.exit_code, 2);
  EXPECT_NE(fine.err.find("hfrt mesh: --cell 0.0001 gives 20000 cells along the region's longest "
                          "side (at most 8192)"),
            std::string::npos)
      << fine.err;
  CliRun both = hfrt("mesh sphere.hf -o c.stl --cell 0.05 --resolution 10");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("excludes"), std::string::npos) << both.err;
}

TEST_F(MeshCliTest, WritesGltfBinary) {
  CliRun r = hfrt("mesh sphere.hf -o ball.glb --resolution 16");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(slurp(dir_ / "ball.glb").substr(0, 4), "glTF");
}

TEST_F(MeshCliTest, SameFileOnOneAndTwoThreads) {
  ASSERT_EQ(hfrt("mesh sphere.hf -o one.ply --resolution 40 --threads 1").exit_code, 0);
  ASSERT_EQ(hfrt("mesh sphere.hf -o two.ply --resolution 40 --threads 2").exit_code, 0);
  const std::string one = slurp(dir_ / "one.ply"), two = slurp(dir_ / "two.ply");
  EXPECT_GT(one.size(), 1000u);
  EXPECT_TRUE(one == two);
}

TEST_F(MeshCliTest, NoSurfaceIsALocatedError) {
  CliRun r = hfrt("mesh empty.hf -o e.stl --bbox 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("empty.hf:1:1: error: object 'my_model' has no surface in the box "
                       "-2,-2,-2,2,2,2\n  hint: the solid is where F >= 0"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "e.stl"));
}

TEST_F(MeshCliTest, ResolutionZeroIsRefused) {
  CliRun r = hfrt("mesh sphere.hf -o s.stl --resolution 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hfrt mesh: --resolution expects a cell count from 1 to 8192 (got 0)\n");
}

TEST_F(MeshCliTest, UnwritableOutputIsRefusedBeforeMeshing) {
  CliRun r = hfrt("mesh sphere.hf -o no/such/dir/s.stl");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hfrt: no/such/dir/s.stl: cannot write: no such directory\n");
}

TEST_F(MeshCliTest, UnknownFormatIsRefused) {
  CliRun r = hfrt("mesh sphere.hf -o s.xyz");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hfrt mesh: s.xyz: unknown mesh format '.xyz' (expected .stl, .obj, .ply or .glb)\n");
}

TEST_F(MeshCliTest, TimeOnAThreeDimensionalObjectIsANote) {
  CliRun r = hfrt("mesh sphere.hf -o s.stl --time 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("hfrt: note: --time has no effect: object 'my_model' declares 3 "
                       "coordinates (time is x[4])"),
            std::string::npos)
      << r.err;
}

TEST_F(MeshCliTest, BadTimeIsRefused) {
  CliRun r = hfrt("mesh sphere.hf -o s.stl --time soon");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("hfrt: --time expects a number, e.g. --time 0.5 (got 'soon')"),
            std::string::npos)
      << r.err;
}

TEST_F(MeshCliTest, TwoDimensionalObjectIsRefused) {
  CliRun r = hfrt("mesh flat.hf -o f.stl");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("flat.hf:1:1: error: object 'my_model' has 2 coordinates; hfrt mesh needs a "
                       "3-D object (x[3], or x[4] with time)\n  hint: a 2-D object can be drawn "
                       "with hfrt slice"),
            std::string::npos)
      << r.err;
}

TEST_F(MeshCliTest, BadBboxIsRefused) {
  CliRun r = hfrt("mesh sphere.hf -o s.stl --bbox 1,1,1,0,2,2");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hfrt mesh: --bbox: each min must be below its max (got '1,1,1,0,2,2')\n");
}

}  // namespace
}  // namespace hfrt::tools
