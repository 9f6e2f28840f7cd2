// Scene files: the issue's example read into exactly the values it states, defaults, path
// resolution, and every kind of error with its text, line and column.

#include "scene/scene_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace hfrt::scene {
namespace {

namespace fs = std::filesystem;

class SceneFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hfrt_scene_file_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "models");
    write("blob.hf", "blob(x[3], a[1]) { blob = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
    write("models/floor.hf", "floor(x[3], a[1]) { floor = 0.1 - x[2]*x[2]; }\n");
    write("wood.png", "not really a png; the reader only checks that it exists\n");
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name, std::ios::binary) << text;
  }
  std::string path() const { return (dir_ / "scene.toml").string(); }

  /// Parses `text` (named dir/scene.toml) and expects it to fail; returns the error.
  SceneError error_of(const std::string& text) {
    SceneDesc desc;
    SceneError err;
    EXPECT_FALSE(parse_scene(text, path(), &desc, &err)) << text;
    EXPECT_EQ(err.pos.file, path());
    return err;
  }
  /// Parses `text` and expects success.
  SceneDesc parse_ok(const std::string& text) {
    SceneDesc desc;
    SceneError err;
    EXPECT_TRUE(parse_scene(text, path(), &desc, &err)) << err.render();
    return desc;
  }

  fs::path dir_;
};

// A valid object to append to scenes that test something else.
const char* const kObject = "\n[[object]]\nfile = \"blob.hf\"\n";

/// The issue's example, verbatim (comments and all).
const char* const kIssueExample = R"toml([camera]
eye = [3.2, 2.4, -4.0]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov = 40                  # vertical degrees; or  ortho = 10  (view width, world units)
aperture = 0.0            # thin-lens radius; 0: pinhole
focus_distance = 5.0      # along the view direction; default: |look_at - eye|

[render]
size = [512, 512]
spp = 1                   # samples per pixel
adaptive = false          # true: spp is the maximum; pixels whose first samples agree stop early
max_depth = 5             # reflection/refraction bounces
background = [0.1, 0.1, 0.12]   # linear RGB seen by every ray that leaves the scene,
                                # also through glass and in mirrors
root = "auto"             # as --root

[[light]]
kind = "point"            # "point" | "directional" | "sphere" (an area light: soft shadows)
position = [10, 15, -10]  # "directional" has  direction = [...]  (towards the light) instead
radius = 0.5              # "sphere" only
color = [1, 1, 1]
intensity = 1.0
samples = 16              # "sphere" only: shadow rays per shading point

[material.glass]
color = [1, 1, 1]         # base colour; a model that computes s[1..3] colours its points itself
ambient = 0.1             # ambient term, times color
diffuse = 0.0             # Lambert, times color
specular = 0.0            # Blinn-Phong highlight
shininess = 48
reflect = 0.0             # mirror reflection weight
transmit = 1.0            # refraction weight
ior = 1.5
fresnel = true            # weigh reflect/transmit by the exact dielectric Fresnel equations
absorb = [0.0, 0.0, 0.0]  # Beer-Lambert coefficient per unit length inside the solid
roughness = 0.0           # > 0: glossy reflection and refraction, sampled

[[object]]
file = "blob.hf"          # relative to the scene file; or  source = """ ...HyperFun text... """
name = "my_model"         # optional: which object of the file
params = [0.5]            # optional: a[1], a[2], ...
bbox = [-1.6, -1.6, -1.6, 1.6, 1.6, 1.6]
material = "glass"        # default: the default material (today's look)
translate = [0, 0, 0]     # optional placement: scale, then rotate (degrees about x, y, z,
rotate = [0, 0, 0]        #   in that order), then translate; the same model placed twice
scale = 1.0               #   is one compilation, two instances
)toml";

void expect_vec(render::Vec3 v, float x, float y, float z) {
  EXPECT_FLOAT_EQ(v.x, x);
  EXPECT_FLOAT_EQ(v.y, y);
  EXPECT_FLOAT_EQ(v.z, z);
}

TEST_F(SceneFileTest, IssueExampleReadsExactly) {
  SceneDesc s = parse_ok(kIssueExample);
  EXPECT_EQ(s.path, path());
  ASSERT_TRUE(s.has_camera);
  const CameraDesc& c = s.camera;
  ASSERT_TRUE(c.request.eye && c.request.look_at && c.request.up && c.request.fov_deg);
  expect_vec(*c.request.eye, 3.2f, 2.4f, -4.0f);
  expect_vec(*c.request.look_at, 0, 0, 0);
  expect_vec(*c.request.up, 0, 1, 0);
  EXPECT_FLOAT_EQ(*c.request.fov_deg, 40);
  EXPECT_FALSE(c.request.ortho_width);
  EXPECT_FLOAT_EQ(c.aperture, 0);
  ASSERT_TRUE(c.focus_distance);
  EXPECT_FLOAT_EQ(*c.focus_distance, 5);

  const RenderDesc& r = s.render;
  ASSERT_TRUE(r.size && r.spp && r.adaptive && r.max_depth && r.background && r.root);
  EXPECT_EQ((*r.size)[0], 512);
  EXPECT_EQ((*r.size)[1], 512);
  EXPECT_EQ(*r.spp, 1);
  EXPECT_FALSE(*r.adaptive);
  EXPECT_EQ(*r.max_depth, 5);
  expect_vec(*r.background, 0.1f, 0.1f, 0.12f);
  EXPECT_EQ(*r.root, "auto");

  ASSERT_EQ(s.lights.size(), 1u);
  const render::Light& l = s.lights[0];
  EXPECT_EQ(l.kind, render::Light::Kind::kPoint);
  expect_vec(l.v, 10, 15, -10);
  expect_vec(l.color, 1, 1, 1);
  EXPECT_FLOAT_EQ(l.intensity, 1);
  EXPECT_FLOAT_EQ(l.radius, 0.5f);  // kept, though only sphere lights use it
  EXPECT_EQ(l.samples, 16);

  ASSERT_EQ(s.materials.size(), 1u);
  ASSERT_TRUE(s.materials.count("glass"));
  const render::Material& m = s.materials.at("glass");
  expect_vec(m.color, 1, 1, 1);
  EXPECT_FLOAT_EQ(m.ambient, 0.1f);
  EXPECT_FLOAT_EQ(m.diffuse, 0);
  EXPECT_FLOAT_EQ(m.specular, 0);
  EXPECT_FLOAT_EQ(m.shininess, 48);
  EXPECT_FLOAT_EQ(m.reflect, 0);
  EXPECT_FLOAT_EQ(m.transmit, 1);
  EXPECT_FLOAT_EQ(m.ior, 1.5f);
  EXPECT_TRUE(m.fresnel);
  expect_vec(m.absorb, 0, 0, 0);
  EXPECT_FLOAT_EQ(m.roughness, 0);
  EXPECT_EQ(m.texture, "");

  ASSERT_EQ(s.objects.size(), 1u);
  const ObjectDesc& o = s.objects[0];
  EXPECT_EQ(o.file, (dir_ / "blob.hf").string());
  EXPECT_EQ(o.source, "");
  ASSERT_TRUE(o.name);
  EXPECT_EQ(*o.name, "my_model");
  ASSERT_EQ(o.params.size(), 1u);
  EXPECT_DOUBLE_EQ(o.params[0], 0.5);
  ASSERT_TRUE(o.bbox);
  expect_vec(o.bbox->lo, -1.6f, -1.6f, -1.6f);
  expect_vec(o.bbox->hi, 1.6f, 1.6f, 1.6f);
  EXPECT_EQ(o.material, "glass");
  expect_vec(o.translate, 0, 0, 0);
  expect_vec(o.rotate_deg, 0, 0, 0);
  EXPECT_FLOAT_EQ(o.scale, 1);
  EXPECT_EQ(o.pos.line, 39);
  EXPECT_EQ(o.pos.column, 1);
}

TEST_F(SceneFileTest, SphereAndDirectionalLightsTexturesAndPlacements) {
  SceneDesc s = parse_ok(R"toml(
[camera]
ortho = 10
aperture = 0.25

[[light]]
kind = "sphere"
position = [1, 2, 3]
radius = 0.5
samples = 32
color = [1, 0.5, 0.25]
intensity = 2

[[light]]
kind = "directional"
direction = [0, 1, 0]

[material.wood]
texture = "wood.png"
mapping = "triplanar"
absorb = [0.5, 1, 2]
roughness = 0.2

[material.mirror]
reflect = 1

[[object]]
file = "models/floor.hf"
material = "mirror"
translate = [1, -2, 3]
rotate = [90, 0, -45]
scale = 2.5

[[object]]
source = """
ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }
"""
material = "wood"

[[object]]
file = "blob.hf"
)toml");
  EXPECT_FALSE(s.camera.request.fov_deg);
  ASSERT_TRUE(s.camera.request.ortho_width);
  EXPECT_FLOAT_EQ(*s.camera.request.ortho_width, 10);
  EXPECT_FLOAT_EQ(s.camera.aperture, 0.25f);
  EXPECT_FALSE(s.camera.focus_distance);
  EXPECT_FALSE(s.render.size);
  EXPECT_FALSE(s.render.spp);

  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.lights[0].kind, render::Light::Kind::kSphere);
  expect_vec(s.lights[0].v, 1, 2, 3);
  EXPECT_FLOAT_EQ(s.lights[0].radius, 0.5f);
  EXPECT_EQ(s.lights[0].samples, 32);
  expect_vec(s.lights[0].color, 1, 0.5f, 0.25f);
  EXPECT_FLOAT_EQ(s.lights[0].intensity, 2);
  EXPECT_EQ(s.lights[1].kind, render::Light::Kind::kDirectional);
  expect_vec(s.lights[1].v, 0, 1, 0);
  EXPECT_FLOAT_EQ(s.lights[1].intensity, 1);

  // Keys not given keep the default material's values.
  const render::Material def;
  const render::Material& wood = s.materials.at("wood");
  EXPECT_EQ(wood.texture, fs::absolute(dir_ / "wood.png").lexically_normal().string());
  EXPECT_EQ(wood.mapping, render::TextureMapping::kTriplanar);
  expect_vec(wood.absorb, 0.5f, 1, 2);
  EXPECT_FLOAT_EQ(wood.roughness, 0.2f);
  expect_vec(wood.color, def.color.x, def.color.y, def.color.z);
  EXPECT_FLOAT_EQ(wood.diffuse, def.diffuse);
  EXPECT_FLOAT_EQ(wood.ior, def.ior);
  EXPECT_FLOAT_EQ(s.materials.at("mirror").reflect, 1);

  ASSERT_EQ(s.objects.size(), 3u);
  EXPECT_EQ(s.objects[0].file, (dir_ / "models" / "floor.hf").string());
  EXPECT_EQ(s.objects[0].material, "mirror");
  expect_vec(s.objects[0].translate, 1, -2, 3);
  expect_vec(s.objects[0].rotate_deg, 90, 0, -45);
  EXPECT_FLOAT_EQ(s.objects[0].scale, 2.5f);
  EXPECT_FALSE(s.objects[0].bbox);
  EXPECT_FALSE(s.objects[0].name);
  EXPECT_EQ(s.objects[1].file, "");
  EXPECT_EQ(s.objects[1].source,
            "ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
  EXPECT_EQ(s.objects[1].pos.line, 34);
  // The text starts on the line after `source = """`.
  EXPECT_EQ(s.objects[1].source_pos.line, 36);
  EXPECT_EQ(s.objects[1].source_pos.column, 1);
  EXPECT_EQ(s.objects[2].material, "");
  EXPECT_EQ(s.objects[2].scale, 1);

  EXPECT_EQ(summary(s), path() +
                            ": 3 objects, 2 lights, 2 materials; orthographic camera with depth of "
                            "field");
}

TEST_F(SceneFileTest, SingleLineSourceStartsAfterItsQuote) {
  SceneDesc s = parse_ok("[[object]]\nsource   = 'b(x[3], a[1]) { b = 1; }'\n");
  EXPECT_EQ(s.objects[0].source, "b(x[3], a[1]) { b = 1; }");
  EXPECT_EQ(s.objects[0].source_pos.line, 2);
  EXPECT_EQ(s.objects[0].source_pos.column, 13);
}

TEST(ObjectPlacement, ScaleThenRotateXYZThenTranslate) {
  ObjectDesc o;
  o.rotate_deg = {0, 0, 90};
  render::Vec3 p = object_to_world(o, {1, 0, 0});  // x turns towards y about z
  EXPECT_NEAR(p.x, 0, 1e-6);
  EXPECT_NEAR(p.y, 1, 1e-6);
  o.rotate_deg = {90, 0, 0};
  p = object_to_world(o, {0, 1, 0});  // y towards z about x
  EXPECT_NEAR(p.y, 0, 1e-6);
  EXPECT_NEAR(p.z, 1, 1e-6);
  o.rotate_deg = {0, 90, 0};
  p = object_to_world(o, {0, 0, 1});  // z towards x about y
  EXPECT_NEAR(p.x, 1, 1e-6);
  EXPECT_NEAR(p.z, 0, 1e-6);
  // x first, then y: (0, 1, 0) -> (0, 0, 1) -> (1, 0, 0); then scale 2 and translate.
  o.rotate_deg = {90, 90, 0};
  o.scale = 2;
  o.translate = {10, 20, 30};
  p = object_to_world(o, {0, 1, 0});
  EXPECT_NEAR(p.x, 12, 1e-5);
  EXPECT_NEAR(p.y, 20, 1e-5);
  EXPECT_NEAR(p.z, 30, 1e-5);
  render::Box b = world_box(o, render::Box({-1, -1, -1}, {1, 1, 1}));
  expect_vec(b.lo, 8, 18, 28);
  expect_vec(b.hi, 12, 22, 32);
}

TEST_F(SceneFileTest, ReadsFromDiskAndResolvesAgainstTheScenesFolder) {
  write("scene.toml",
        "[render]\nsize = [64, 32]\nspp = 4\nmax_depth = 3\n\n[[object]]\n"
        "file = \"models/floor.hf\"\n");
  SceneDesc s;
  SceneError err;
  ASSERT_TRUE(read_scene_file(path(), &s, &err)) << err.render();
  EXPECT_EQ(s.objects[0].file, (dir_ / "models/floor.hf").string());
  EXPECT_EQ(summary(s), path() +
                            ": 1 object, the default lights, 0 materials; 64x32, 4 spp, "
                            "depth 3");
}

TEST_F(SceneFileTest, MissingSceneFile) {
  SceneDesc s;
  SceneError err;
  EXPECT_FALSE(read_scene_file((dir_ / "nope.toml").string(), &s, &err));
  EXPECT_EQ(err.pos.file, (dir_ / "nope.toml").string());
  EXPECT_EQ(err.pos.line, 0);
  EXPECT_NE(err.message.find("nope.toml"), std::string::npos) << err.message;
}

// --- errors --------------------------------------------------------------------------------

TEST_F(SceneFileTest, TomlSyntaxError) {
  SceneError e = error_of("[camera]\neye = [1, 2, 3\nfov = 40\n");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 1);
  EXPECT_EQ(e.message.rfind("invalid TOML: ", 0), 0u) << e.message;
}

TEST_F(SceneFileTest, DuplicateKeyIsASyntaxError) {
  SceneError e = error_of("[render]\nspp = 4\nspp = 8\n");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.message.rfind("invalid TOML: ", 0), 0u) << e.message;
  EXPECT_NE(e.message.find("spp"), std::string::npos) << e.message;
}

TEST_F(SceneFileTest, UnknownKeyWithNearMiss) {
  SceneError e = error_of(std::string("[camera]\nfov = 30\nlook_ta = [0, 0, 0]\n") + kObject);
  EXPECT_EQ(e.message, "unknown key 'look_ta' in [camera]");
  EXPECT_EQ(e.hint,
            "did you mean 'look_at'? [camera] has: eye, look_at, up, fov, ortho, aperture, "
            "focus_distance");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 1);
  EXPECT_EQ(e.render(),
            path() +
                ":3:1: error: unknown key 'look_ta' in [camera]\n"
                " look_ta = [0, 0, 0]\n"
                " ^~~~~~~\n"
                "hint: did you mean 'look_at'? [camera] has: eye, look_at, up, fov, ortho, "
                "aperture, focus_distance\n");
}

TEST_F(SceneFileTest, UnknownKeyWithoutNearMissListsTheKeys) {
  SceneError e = error_of(std::string(kObject) + "colour_space = 3\n");
  EXPECT_EQ(e.message, "unknown key 'colour_space' in [[object]]");
  EXPECT_EQ(e.hint,
            "[[object]] has: file, source, name, params, bbox, material, translate, rotate, scale");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 1);
}

TEST_F(SceneFileTest, UnknownTopLevelTable) {
  SceneError e = error_of(std::string("[camra]\nfov = 30\n") + kObject);
  EXPECT_EQ(e.message, "unknown key 'camra' at the top level");
  EXPECT_EQ(e.hint,
            "did you mean 'camera'? the scene file has: camera, render, light, material, object, "
            "animation");
  EXPECT_EQ(e.pos.line, 1);
  EXPECT_EQ(e.pos.column, 2);
}

TEST_F(SceneFileTest, UnknownMaterialKeyIsNamedWithItsTable) {
  SceneError e = error_of(std::string("[material.glass]\nior = 1.5\nreflection = 0.2\n") + kObject);
  EXPECT_EQ(e.message, "unknown key 'reflection' in [material.glass]");
  EXPECT_EQ(e.hint.rfind("did you mean 'reflect'? [material.glass] has: color, ambient,", 0), 0u)
      << e.hint;
  EXPECT_EQ(e.pos.line, 3);
}

TEST_F(SceneFileTest, WrongTypes) {
  SceneError e = error_of(std::string("[camera]\nfov = \"wide\"\n") + kObject);
  EXPECT_EQ(e.message, "[camera] fov must be a number, not a string");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 7);

  e = error_of(std::string("[render]\nspp = 1.5\n") + kObject);
  EXPECT_EQ(e.message, "[render] spp must be an integer, not a float");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 7);

  e = error_of(std::string("[camera]\neye = [1, 2]\n") + kObject);
  EXPECT_EQ(e.message, "[camera] eye must be an array of 3 numbers, not 2");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 7);

  e = error_of(std::string("[camera]\neye = [1, \"2\", 3]\n") + kObject);
  EXPECT_EQ(e.message, "[camera] eye[1] must be a number, not a string");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 11);

  e = error_of(std::string("[render]\nadaptive = 1\n") + kObject);
  EXPECT_EQ(e.message, "[render] adaptive must be true or false, not an integer");

  e = error_of(std::string("camera = 3\n") + kObject);
  EXPECT_EQ(e.message, "'camera' must be a table ([camera]), not an integer");
  EXPECT_EQ(e.pos.line, 1);
  EXPECT_EQ(e.pos.column, 10);

  e = error_of("[object]\nfile = \"blob.hf\"\n");
  EXPECT_EQ(e.message,
            "'object' must be an array of tables ([[object]]), not a single table "
            "([object])");
  EXPECT_EQ(e.pos.line, 1);

  e = error_of(std::string("[material]\nior = 1.5\n") + kObject);
  EXPECT_EQ(e.message,
            "'ior' in [material] must be a material table ([material.ior]), not a float");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 1);

  e = error_of(std::string("[camera]\nfov = inf\n") + kObject);
  EXPECT_EQ(e.message, "[camera] fov must be a finite number");
}

TEST_F(SceneFileTest, IntegersAreAcceptedForFloats) {
  SceneDesc s =
      parse_ok(std::string("[camera]\nfov = 40\neye = [1, 2, 3]\n") + kObject + "scale = 2\n");
  EXPECT_FLOAT_EQ(*s.camera.request.fov_deg, 40);
  EXPECT_FLOAT_EQ(s.objects[0].scale, 2);
}

TEST_F(SceneFileTest, OutOfRange) {
  struct Case {
    std::string text;
    std::string message;
    int line, column;
  };
  const Case cases[] = {
      {"[render]\nspp = -4\n", "[render] spp must be at least 1, not -4", 2, 7},
      {"[render]\nmax_depth = -1\n", "[render] max_depth must be at least 0, not -1", 2, 13},
      {"[render]\nsize = [512, 0]\n", "[render] size[1] must be at least 1, not 0", 2, 14},
      {"[render]\nsize = [512]\n",
       "[render] size must be an array of 2 integers (width, height), not 1", 2, 8},
      {"[render]\nbackground = [0.1, -0.2, 0]\n", "[render] background[1] must be >= 0, not -0.2",
       2, 20},
      {"[camera]\nfov = 180\n", "[camera] fov must be in (0, 180) degrees, not 180", 2, 7},
      {"[camera]\nfov = 0\n", "[camera] fov must be in (0, 180) degrees, not 0", 2, 7},
      {"[camera]\northo = -2\n", "[camera] ortho must be > 0, not -2", 2, 9},
      {"[camera]\naperture = -0.1\n", "[camera] aperture must be >= 0, not -0.1", 2, 12},
      {"[camera]\nfocus_distance = 0\n", "[camera] focus_distance must be > 0, not 0", 2, 18},
      {"[camera]\nup = [0, 0, 0]\n", "[camera] up must not be zero", 2, 6},
      {"[material.glass]\nior = 0\n", "[material.glass] ior must be > 0, not 0", 2, 7},
      {"[material.glass]\nior = -1.5\n", "[material.glass] ior must be > 0, not -1.5", 2, 7},
      {"[material.glass]\ntransmit = 1.2\n", "[material.glass] transmit must be in [0, 1], not 1.2",
       2, 12},
      {"[material.glass]\ncolor = [1, 1, -1]\n", "[material.glass] color[2] must be >= 0, not -1",
       2, 16},
      {"[material.glass]\nabsorb = [-0.5, 0, 0]\n",
       "[material.glass] absorb[0] must be >= 0, not -0.5", 2, 11},
      {"[material.glass]\nshininess = 0\n", "[material.glass] shininess must be > 0, not 0", 2, 13},
      {"[material.glass]\nroughness = 2\n", "[material.glass] roughness must be in [0, 1], not 2",
       2, 13},
      {"[[light]]\nkind = \"sphere\"\nposition = [0, 5, 0]\nradius = 0\n",
       "[[light]] radius must be > 0 for a sphere light, not 0", 4, 10},
      {"[[light]]\nposition = [0, 5, 0]\nradius = -1\n", "[[light]] radius must be >= 0, not -1", 3,
       10},
      {"[[light]]\nkind = \"sphere\"\nposition = [0, 5, 0]\nradius = 1\nsamples = 0\n",
       "[[light]] samples must be at least 1, not 0", 5, 11},
      {"[[light]]\nposition = [0, 5, 0]\nintensity = -1\n",
       "[[light]] intensity must be >= 0, not -1", 3, 13},
      {"[[light]]\nposition = [0, 5, 0]\ncolor = [-1, 1, 1]\n",
       "[[light]] color[0] must be >= 0, not -1", 3, 10},
      {"[[light]]\nkind = \"directional\"\ndirection = [0, 0, 0]\n",
       "[[light]] direction must not be zero", 3, 13},
  };
  for (const Case& c : cases) {
    SceneError e = error_of(c.text + kObject);
    EXPECT_EQ(e.message, c.message) << c.text;
    EXPECT_EQ(e.pos.line, c.line) << c.text;
    EXPECT_EQ(e.pos.column, c.column) << c.text;
  }
  SceneError e = error_of(std::string(kObject) + "scale = 0\n");
  EXPECT_EQ(e.message, "[[object]] scale must be > 0, not 0");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 9);
}

TEST_F(SceneFileTest, BboxLowMustBeBelowHigh) {
  SceneError e = error_of(std::string(kObject) + "bbox = [-1, 2, -1, 1, -2, 1]\n");
  EXPECT_EQ(e.message, "[[object]] bbox must have lo < hi on every axis; on y it is 2 >= -2");
  EXPECT_EQ(e.hint, "bbox = [x0, y0, z0, x1, y1, z1]: the low corner, then the high one");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 8);
  e = error_of(std::string(kObject) + "bbox = [-1, -1, -1, 1, 1]\n");
  EXPECT_EQ(e.message, "[[object]] bbox must be an array of 6 numbers, not 5");
}

TEST_F(SceneFileTest, BothFovAndOrtho) {
  SceneError e = error_of(std::string("[camera]\nfov = 40\northo = 10\n") + kObject);
  EXPECT_EQ(e.message, "[camera] has both fov and ortho");
  EXPECT_EQ(e.hint,
            "fov (vertical degrees) makes a perspective camera, ortho (view width) an "
            "orthographic one: give one of them");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 9);
}

TEST_F(SceneFileTest, EyeEqualsLookAt) {
  SceneError e =
      error_of(std::string("[camera]\neye = [1, 2, 3]\nlook_at = [1, 2, 3]\n") + kObject);
  EXPECT_EQ(e.message, "[camera] look_at is the eye position");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 11);
}

TEST_F(SceneFileTest, ObjectNeedsFileXorSource) {
  SceneError e = error_of("[render]\nspp = 2\n\n[[object]]\nmaterial = \"\"\n");
  EXPECT_EQ(e.message, "[[object]] needs a file or a source");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 1);

  e = error_of("[[object]]\nfile = \"blob.hf\"\nsource = \"b(x[3], a[1]) { b = 1; }\"\n");
  EXPECT_EQ(e.message, "[[object]] has both file and source");
  EXPECT_EQ(e.hint,
            "an object is either a model file (file = \"blob.hf\") or inline HyperFun text "
            "(source = \"\"\"...\"\"\"): give one");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 10);
}

TEST_F(SceneFileTest, SceneWithoutObjects) {
  SceneError e = error_of("[render]\nspp = 2\n");
  EXPECT_EQ(e.message, "the scene has no objects");
  EXPECT_EQ(e.pos.line, 0);
  EXPECT_EQ(e.render(), path() +
                            ": error: the scene has no objects\n"
                            "hint: add an [[object]] table with file = \"model.hf\" (or source "
                            "= \"...\")\n");
}

TEST_F(SceneFileTest, LightsNeedTheirKeys) {
  SceneError e = error_of(std::string("[[light]]\ncolor = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.message, "a point light needs a position");
  EXPECT_EQ(e.pos.line, 1);
  EXPECT_EQ(e.pos.column, 1);

  e = error_of(std::string("[[light]]\nkind = \"directional\"\nposition = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.message,
            "[[light]] position is for point and sphere lights only (this light is "
            "\"directional\")");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 1);

  e = error_of(std::string("[[light]]\nkind = \"directional\"\n") + kObject);
  EXPECT_EQ(e.message, "a directional light needs a direction");
  EXPECT_EQ(e.pos.line, 1);

  e = error_of(std::string("[[light]]\nkind = \"sphere\"\nposition = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.message, "a sphere light needs a radius");

  e = error_of(std::string("[[light]]\nkind = \"point\"\ndirection = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.message,
            "[[light]] direction is for directional lights only (this light is "
            "\"point\")");
  EXPECT_EQ(e.pos.line, 3);
  EXPECT_EQ(e.pos.column, 1);

  e = error_of(std::string("[[light]]\nkind = \"spot\"\nposition = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.message, "unknown [[light]] kind \"spot\"");
  EXPECT_EQ(e.hint, "[[light]] kind is one of \"point\", \"directional\" or \"sphere\"");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 8);

  e = error_of(std::string("[[light]]\nkind = \"pont\"\nposition = [1, 1, 1]\n") + kObject);
  EXPECT_EQ(e.hint,
            "did you mean \"point\"? [[light]] kind is one of \"point\", \"directional\" or "
            "\"sphere\"");
}

TEST_F(SceneFileTest, UnknownChoices) {
  SceneError e = error_of(std::string("[render]\nroot = \"bisect\"\n") + kObject);
  EXPECT_EQ(e.message, "unknown [render] root \"bisect\"");
  EXPECT_EQ(e.hint, "[render] root is one of \"auto\", \"sign\", \"interval\" or \"analytic\"");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 8);

  e = error_of(std::string("[material.m]\nmapping = \"spherica\"\n") + kObject);
  EXPECT_EQ(e.message, "unknown [material.m] mapping \"spherica\"");
  EXPECT_EQ(e.hint,
            "did you mean \"spherical\"? [material.m] mapping is one of \"planar\", "
            "\"spherical\", \"cylindrical\", \"triplanar\" or \"uv\"");
}

TEST_F(SceneFileTest, UnknownMaterialIsLocatedAtTheValue) {
  SceneError e = error_of(
      "[material.glass]\nior = 1.5\n\n[material.mirror]\nreflect = 1\n\n[[object]]\n"
      "file = \"blob.hf\"\nmaterial = \"glas\"\n");
  EXPECT_EQ(e.message, "unknown material \"glas\"");
  EXPECT_EQ(e.hint, "did you mean \"glass\"? the scene defines \"glass\" or \"mirror\"");
  EXPECT_EQ(e.pos.line, 9);
  EXPECT_EQ(e.pos.column, 12);
  EXPECT_EQ(e.length, 6);

  e = error_of(std::string(kObject) + "material = \"glass\"\n");
  EXPECT_EQ(e.message, "unknown material \"glass\"");
  EXPECT_EQ(e.hint,
            "the scene defines no materials: add a [material.glass] table, or leave material "
            "out for the default look");
}

TEST_F(SceneFileTest, MissingModelAndTextureFiles) {
  SceneError e = error_of("[[object]]\nfile = \"nothere.hf\"\n");
  EXPECT_EQ(e.message, "model file 'nothere.hf' does not exist");
  EXPECT_EQ(e.hint, "looked for " + (dir_ / "nothere.hf").string() +
                        " (relative names are taken from the scene file's folder)");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 8);

  e = error_of("[[object]]\nfile = \"models\"\n");
  EXPECT_EQ(e.message, "model file 'models' is not a file");

  e = error_of(std::string("[material.wood]\ntexture = \"oak.png\"\n") + kObject);
  EXPECT_EQ(e.message, "texture file 'oak.png' does not exist");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 11);
}

TEST_F(SceneFileTest, RenderShowsTheLineAndCaret) {
  SceneError e = error_of(std::string("[render]\nspp     = -4   # typo\n") + kObject);
  EXPECT_EQ(e.render(), path() +
                            ":2:11: error: [render] spp must be at least 1, not -4\n"
                            " spp     = -4   # typo\n"
                            "           ^~\n");
}

}  // namespace
}  // namespace hfrt::scene
