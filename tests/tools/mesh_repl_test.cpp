// The REPL's `:mesh OUT [RESOLUTION]`: the current object meshed to a closed sphere, and its
// usage errors.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <numbers>
#include <string>

#include "geom/mesh.h"
#include "tests/mesher/mesh_check.h"
#include "tools/hfrt/session.h"

namespace hfrt::tools {
namespace {

namespace fs = std::filesystem;

TEST(ReplMesh, MeshesTheCurrentObject) {
  const fs::path dir = fs::temp_directory_path() / ("hfrt_mesh_repl_" + std::to_string(getpid()));
  fs::create_directories(dir);
  Session s;
  SessionResult def =
      s.run("ball(x[3], a[1]) { ball = a[1] - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }");
  ASSERT_TRUE(def.ok) << def.err;
  ASSERT_TRUE(s.run(":set a 1").ok);
  const std::string out = (dir / "ball.ply").string();
  SessionResult r = s.run(":mesh " + out + " 40");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_NE(r.out.find("triangles"), std::string::npos) << r.out;
  auto mesh = geom::load_mesh(out);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  std::vector<std::array<uint32_t, 3>> tris(mesh->triangles.begin(), mesh->triangles.end());
  EXPECT_EQ(mesher::testing::check_closed_manifold(mesh->vertices, tris), "");
  EXPECT_NEAR(mesher::testing::mesh_volume(mesh->vertices, tris) / (4.0 / 3.0 * std::numbers::pi),
              1.0, 0.01);
  fs::remove_all(dir);
}

TEST(ReplMesh, UsageErrors) {
  Session s;
  EXPECT_EQ(s.run(":mesh").err, "hfrt: :mesh expects OUT [RESOLUTION]\n");
  EXPECT_EQ(s.run(":mesh a.stl").err, "hfrt: no current object (define one or :load a file)\n");
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  EXPECT_EQ(s.run(":mesh a.stl 0").err,
            "hfrt: :mesh: RESOLUTION expects a cell count from 1 to 8192 (got '0')\n");
  EXPECT_EQ(s.run(":mesh a.txt").err,
            "hfrt: a.txt: unknown mesh format (expected .stl, .obj, .ply or .glb)\n");
}

}  // namespace
}  // namespace hfrt::tools
