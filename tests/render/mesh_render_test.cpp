// A mesh leaf in CSG with a polynomial solid, rendered through the hfrt binary with the
// analytic root search: the depth (`--aov depth`, the Z channel of the EXR) of every pixel
// against a closed-form answer computed here (issue 10). The cube is a triangle mesh written
// by the test as OFF; the sphere carved out of it is hfSphere, a polynomial leaf.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "render/image.h"

namespace hfrt::render {
namespace {

namespace fs = std::filesystem;

const std::string kHfrt = std::string(HFRT_BINARY_DIR) + "/tools/hfrt/hfrt";

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("hfrt_mesh_render_test_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}

int run_hfrt(const std::string& args, std::string* err) {
  fs::path log = temp_dir() / "stderr.txt";
  std::string cmd = kHfrt + " " + args + " 2> '" + log.string() + "' > /dev/null";
  int status = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  *err = ss.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// The cube [-h, h]^3 as 12 outward triangles.
std::string cube_off(double h) {
  std::ostringstream s;
  s << "OFF\n8 12 0\n";
  for (int k = 0; k < 8; ++k)
    s << (k & 1 ? h : -h) << " " << (k & 2 ? h : -h) << " " << (k & 4 ? h : -h) << "\n";
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                       {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (auto& f : q)
    s << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n3 " << f[0] << " " << f[2] << " " << f[3]
      << "\n";
  return s.str();
}

TEST(MeshRender, CubeMeshMinusSphereHasExactDepth) {
  // The cube [-2, 2]^3 minus the ball of radius 1.5 around (1, 1, 2) (a bite out of the top
  // face), seen orthographically from z = 20 along -z. A pixel-centre ray at (x, y):
  //   |x| > 2 or |y| > 2: misses (Z = +inf);
  //   r^2 = (x-1)^2 + (y-1)^2 >= 2.25: hits the top face, Z = 20 - 2 = 18;
  //   r^2 < 2.25: passes through the bite and hits the sphere's lower cap, Z = 18 + sqrt(2.25 -
  //   r^2).
  std::ofstream(temp_dir() / "cube.off") << cube_off(2);
  fs::path model = temp_dir() / "bite.hf";
  std::ofstream(model) << "bite(x[3], a[1]) {\n  array c[3];\n  c = [1, 1, 2];\n"
                          "  bite = hfMesh(x, \"cube.off\") \\ hfSphere(x, c, 1.5);\n}\n";
  fs::path out = temp_dir() / "bite.exr";
  const int n = 90;
  const double width = 6;
  std::string err;
  ASSERT_EQ(run_hfrt("render '" + model.string() + "' -o '" + out.string() + "' --size " +
                         std::to_string(n) + "x" + std::to_string(n) +
                         " --ortho 6 --eye 0,0,20 --look-at 0,0,0 --aov depth --root auto --stats",
                     &err),
            0)
      << err;
  // The auto mode picks the analytic search: the mesh is a leaf of the skeleton.
  EXPECT_NE(err.find("root search analytic"), std::string::npos) << err;
  EXPECT_NE(err.find("1 mesh/patch leaves"), std::string::npos) << err;
  EXPECT_NE(err.find("surface "), std::string::npos) << err;
  EXPECT_NE(err.find("12 triangles"), std::string::npos) << err;
  EXPECT_NE(err.find("surfaces: 1 loaded, 1 leaves, 0 shared instances"), std::string::npos) << err;
  int w, h, c;
  auto img = read_image(out.string(), &w, &h, &c);
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(w, n);
  ASSERT_EQ(c, 5);
  const double tol = 1e-5 * 4;  // 1e-5 of the box size
  const double grazing = 1e-3;  // pixels this close to a silhouette or crease are not checked
  int checked_top = 0, checked_bite = 0, checked_miss = 0;
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const double x = ((i + 0.5) / w - 0.5) * width, y = (0.5 - (j + 0.5) / h) * width;
      const float z = img.value()[(size_t(j) * w + i) * 5 + 4];
      const double edge = std::min(std::abs(std::abs(x) - 2), std::abs(std::abs(y) - 2));
      const double r2 = (x - 1) * (x - 1) + (y - 1) * (y - 1);
      if (edge < grazing || std::abs(r2 - 2.25) < grazing) continue;
      if (std::abs(x) > 2 || std::abs(y) > 2) {
        EXPECT_TRUE(std::isinf(z) && z > 0) << i << "," << j << " " << z;
        ++checked_miss;
      } else if (r2 >= 2.25) {
        EXPECT_NEAR(z, 18.0, tol) << i << "," << j;
        ++checked_top;
      } else {
        EXPECT_NEAR(z, 18.0 + std::sqrt(2.25 - r2), tol) << i << "," << j;
        ++checked_bite;
      }
    }
  }
  EXPECT_GT(checked_top, 1500);
  EXPECT_GT(checked_bite, 800);
  EXPECT_GT(checked_miss, 2000);
}

TEST(MeshRender, MissingMeshFileIsACompileErrorAtTheCall) {
  fs::path model = temp_dir() / "missing.hf";
  std::ofstream(model) << "m(x[3], a[1]) {\n  m = hfMesh(x, \"no_such.off\");\n}\n";
  std::string err;
  EXPECT_EQ(run_hfrt("render '" + model.string() + "' -o '" + (temp_dir() / "m.png").string() + "'",
                     &err),
            1);
  EXPECT_NE(err.find(model.string() + ":2:7: error: hfMesh: "), std::string::npos) << err;
  EXPECT_NE(err.find("no_such.off: no such file"), std::string::npos) << err;
}

}  // namespace
}  // namespace hfrt::render
