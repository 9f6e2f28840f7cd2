// `hfrt render scene.toml` end to end (issue 23): every kind of bad scene is one located
// message with exit code 1; a good one renders what its closed form says (an emitting sphere of
// known colour and size, seen orthographically); objects that share a file share one
// compilation; command-line options replace the scene's values; the REPL's :scene and :set.

#include <cmath>
#include <string>
#include <vector>

#include "render/image.h"
#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

using testing::CliRun;

class SceneRenderCli : public testing::CliFixture {
 protected:
  SceneRenderCli() : CliFixture("hfrt_scene_render_cli") {}

  /// RGB of pixel (x, y) of an image the test wrote.
  std::vector<float> read(const std::string& name, int* w, int* h) {
    int c = 0;
    auto img = render::read_image((dir_ / name).string(), w, h, &c);
    EXPECT_TRUE(img.ok()) << name;
    EXPECT_GE(c, 3);
    std::vector<float> rgb;
    if (!img.ok()) return rgb;
    for (int i = 0; i < *w * *h; ++i)
      for (int k = 0; k < 3; ++k) rgb.push_back(img.value()[size_t(i) * c + k]);
    return rgb;
  }
};

const char* kSphere =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0, 0, 0];\n"
    "  my_model = hfSphere(x, c, 1);\n"
    "}\n";

// An orthographic view 4 units wide of an emitting sphere of radius 1 (ambient 1, no diffuse
// or highlight): every pixel whose centre sees the sphere has exactly its colour.
const char* kEmitterScene =
    "[camera]\n"
    "eye = [0, 0, 5]\n"
    "look_at = [0, 0, 0]\n"
    "ortho = 4\n"
    "[render]\n"
    "size = [32, 32]\n"
    "background = [0, 0, 0]\n"
    "[material.lamp]\n"
    "color = [0.25, 0.5, 0.75]\n"
    "ambient = 1\n"
    "diffuse = 0\n"
    "specular = 0\n"
    "[[object]]\n"
    "file = \"sphere.hf\"\n"
    "bbox = [-2, -2, -2, 2, 2, 2]\n"
    "material = \"lamp\"\n";

TEST_F(SceneRenderCli, EmittingSphereHasItsColourAndArea) {
  write("sphere.hf", kSphere);
  write("s.toml", kEmitterScene);
  for (const char* root : {"sign", "interval", "analytic"}) {
    CliRun r = hfrt(std::string("render s.toml -o out.exr --root ") + root);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    int w = 0, h = 0;
    std::vector<float> rgb = read("out.exr", &w, &h);
    ASSERT_EQ(w, 32);
    ASSERT_EQ(h, 32);
    int covered = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        // Pixel centres at world (x + 0.5) / 8 - 2: inside the unit disk or not, exactly.
        double wx = (x + 0.5) / 8 - 2, wy = 2 - (y + 0.5) / 8;
        bool inside = wx * wx + wy * wy < 1;
        const float* p = &rgb[size_t(y * w + x) * 3];
        if (inside) {
          covered++;
          EXPECT_NEAR(p[0], 0.25f, 1e-6) << root << " " << x << "," << y;
          EXPECT_NEAR(p[1], 0.5f, 1e-6);
          EXPECT_NEAR(p[2], 0.75f, 1e-6);
        } else {
          EXPECT_EQ(p[0] + p[1] + p[2], 0.0f) << root << " " << x << "," << y;
        }
      }
    EXPECT_GT(covered, 180) << root;  // pi 8^2 = 201 pixels
  }
}

// Rays that start inside a solid find where they leave it also for mesh leaves: a slab given
// as a triangle mesh, with ior 1 and an absorbing inside, in front of a white background,
// transmits exp(-sigma d) of it per pixel, for every root search.
TEST_F(SceneRenderCli, MeshSlabTransmitsBeerLambert) {
  const double d = 0.8;
  // The box [-2, 2] x [-2, 2] x [-0.4, 0.4], 12 outward triangles.
  write("slab.off",
        "OFF\n8 12 0\n"
        "-2 -2 -0.4\n2 -2 -0.4\n2 2 -0.4\n-2 2 -0.4\n"
        "-2 -2 0.4\n2 -2 0.4\n2 2 0.4\n-2 2 0.4\n"
        "3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n"
        "3 2 3 7\n3 2 7 6\n3 1 2 6\n3 1 6 5\n3 0 4 7\n3 0 7 3\n");
  write("slab.hf", "my_model(x[3], a[1]) {\n  my_model = hfMesh(x, \"slab.off\");\n}\n");
  write("m.toml",
        "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\northo = 2\n"
        "[render]\nsize = [8, 8]\nbackground = [1, 1, 1]\n"
        "[material.fog]\ncolor = [1, 1, 1]\nambient = 0\ndiffuse = 0\nspecular = 0\n"
        "transmit = 1\nior = 1\nabsorb = [0.5, 1, 2]\n"
        "[[object]]\nfile = \"slab.hf\"\nbbox = [-3, -3, -1, 3, 3, 1]\nmaterial = \"fog\"\n");
  for (const char* root : {"sign", "interval", "analytic"}) {
    CliRun r = hfrt(std::string("render m.toml -o m.exr --root ") + root);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    int w = 0, h = 0;
    std::vector<float> rgb = read("m.exr", &w, &h);
    ASSERT_EQ(w, 8);
    const float sigma[3] = {0.5f, 1, 2};
    for (int i = 0; i < w * h; ++i)
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(rgb[size_t(i) * 3 + k], std::exp(-sigma[k] * d), 1e-3) << root << " " << i;
  }
}

TEST_F(SceneRenderCli, ObjectsSharingAFileShareOneCompilation) {
  write("sphere.hf", kSphere);
  std::string scene = kEmitterScene;
  scene +=
      "translate = [-1.2, 0, 0]\n"
      "scale = 0.5\n"
      "[[object]]\n"
      "file = \"sphere.hf\"\n"
      "bbox = [-2, -2, -2, 2, 2, 2]\n"
      "material = \"lamp\"\n"
      "translate = [1.2, 0, 0]\n"
      "scale = 0.5\n";
  write("two.toml", scene);
  CliRun r = hfrt("render two.toml -o two.exr --stats");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("2 objects, 1 compilations"), std::string::npos) << r.err;
  int w = 0, h = 0;
  std::vector<float> rgb = read("two.exr", &w, &h);
  auto at = [&](double wx, double wy) {
    int x = int((wx + 2) * 8), y = int((2 - wy) * 8);
    return rgb[size_t(y * w + x) * 3 + 1];
  };
  EXPECT_EQ(at(-1.2, 0), 0.5f);  // each sphere (radius 0.5) where its translate puts it
  EXPECT_EQ(at(1.2, 0), 0.5f);
  EXPECT_EQ(at(0, 0), 0.0f);
  EXPECT_EQ(at(-1.2, 0.6), 0.0f);
}

TEST_F(SceneRenderCli, CommandLineOptionsReplaceTheScenes) {
  write("sphere.hf", kSphere);
  write("s.toml", kEmitterScene);
  CliRun r = hfrt("render s.toml -o small.exr --size 16x8 --background 1,0,0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  int w = 0, h = 0;
  std::vector<float> rgb = read("small.exr", &w, &h);
  EXPECT_EQ(w, 16);
  EXPECT_EQ(h, 8);
  EXPECT_EQ(rgb[0], 1.0f);  // the corner sees the background given on the command line
  r = hfrt("render s.toml -o x.png --bbox 1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--bbox applies to a .hf model"), std::string::npos) << r.err;
}

TEST_F(SceneRenderCli, SyntaxErrorIsLocated) {
  write("bad.toml", "[camera]\neye = [0, 0,\n");
  CliRun r = hfrt("render bad.toml -o x.png");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("bad.toml:", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(": error: "), std::string::npos) << r.err;
}

TEST_F(SceneRenderCli, UnknownMaterialIsLocatedAtTheValue) {
  write("sphere.hf", kSphere);
  write("m.toml", "[[object]]\nfile = \"sphere.hf\"\nmaterial = \"glas\"\n");
  CliRun r = hfrt("render m.toml -o x.png");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("m.toml:3:12: error: unknown material \"glas\"", 0), 0u) << r.err;
}

TEST_F(SceneRenderCli, MissingModelFileIsLocated) {
  write("f.toml", "[[object]]\nfile = \"nope.hf\"\n");
  CliRun r = hfrt("render f.toml -o x.png");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("f.toml:2:8: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
}

TEST_F(SceneRenderCli, ModelThatDoesNotCompileIsLocatedInTheModelAndTheScene) {
  write("broken.hf", "my_model(x[3], a[1]) {\n  my_model = 1 + ;\n}\n");
  write("c.toml", "[render]\nsize = [8, 8]\n\n[[object]]\nfile = \"broken.hf\"\n");
  CliRun r = hfrt("render c.toml -o x.png");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("broken.hf:2:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("c.toml:4:1: note: in the model of this [[object]]"), std::string::npos)
      << r.err;
}

TEST_F(SceneRenderCli, ReplLoadsEditsAndRendersAScene) {
  write("sphere.hf", kSphere);
  write("s.toml", kEmitterScene);
  CliRun r = hfrt("repl",
                  ":scene s.toml\n"
                  ":set material.lamp.color [1, 0, 0]\n"
                  ":scene -o r.exr\n"
                  ":set material.lamp.colour [1, 0, 0]\n");
  EXPECT_NE(r.out.find("s.toml: 1 object"), std::string::npos) << r.out << r.err;
  EXPECT_NE(r.err.find("unknown key 'colour'"), std::string::npos) << r.err;
  int w = 0, h = 0;
  std::vector<float> rgb = read("r.exr", &w, &h);
  ASSERT_EQ(w, 32);
  const float* centre = &rgb[size_t(16 * w + 16) * 3];
  EXPECT_EQ(centre[0], 1.0f);
  EXPECT_EQ(centre[1], 0.0f);
}

}  // namespace
}  // namespace hfrt::tools
