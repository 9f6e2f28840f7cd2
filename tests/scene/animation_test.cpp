// Animated scene files (issue 24): [animation] and keyed numbers read into exactly the values
// the file states, Keys interpolating linearly and holding outside, scene_at() moving every kind
// of keyed number, and each error with its text, line and column.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "scene/scene_file.h"

namespace hfrt::scene {
namespace {

namespace fs = std::filesystem;

class AnimationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hfrt_scene_anim_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    std::ofstream(dir_ / "blob.hf")
        << "blob(x[4], a[1]) { blob = a[1] - x[1]*x[1] - x[2]*x[2]; }\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path() const { return (dir_ / "scene.toml").string(); }

  SceneDesc parse_ok(const std::string& text) {
    SceneDesc desc;
    SceneError err;
    EXPECT_TRUE(parse_scene(text, path(), &desc, &err)) << err.render();
    return desc;
  }
  SceneError error_of(const std::string& text) {
    SceneDesc desc;
    SceneError err;
    EXPECT_FALSE(parse_scene(text, path(), &desc, &err)) << text;
    return err;
  }
  fs::path dir_;
};

const char* const kObject = "\n[[object]]\nfile = \"blob.hf\"\n";

TEST(Keys, LinearBetweenKeysConstantOutside) {
  Keys k;
  k.keys = {{0.0, 0.5}, {1.0, 1.2}, {3.0, 0.2}};
  EXPECT_EQ(k.at(-5), 0.5);
  EXPECT_EQ(k.at(0), 0.5);
  EXPECT_DOUBLE_EQ(k.at(0.5), 0.85);
  EXPECT_DOUBLE_EQ(k.at(1), 1.2);
  EXPECT_DOUBLE_EQ(k.at(2), 0.7);
  EXPECT_EQ(k.at(3), 0.2);
  EXPECT_EQ(k.at(10), 0.2);
  Keys one;
  one.keys = {{2.0, 7.0}};
  EXPECT_EQ(one.at(0), 7.0);
  EXPECT_EQ(one.at(5), 7.0);
}

TEST(Animation, FrameTimesSpanStartToEnd) {
  AnimationDesc a;
  a.frames = 48;
  a.start = 0;
  a.end = 1;
  EXPECT_EQ(a.frame_time(0), 0.0);
  EXPECT_DOUBLE_EQ(a.frame_time(47), 1.0);
  EXPECT_DOUBLE_EQ(a.frame_time(1), 1.0 / 47);
  AnimationDesc still;
  still.start = 0.25;
  EXPECT_EQ(still.frame_time(0), 0.25);
}

TEST_F(AnimationTest, IssueExampleAndEveryKeyableNumber) {
  SceneDesc d = parse_ok(R"toml(
[animation]
frames = 48               # frame i has time start + (end - start) * i / (frames - 1)
start = 0.0
end = 1.0
shutter = 0.0             # > 0: motion blur

[camera]
eye = [0, { keys = [[0, 1], [1, 3]] }, 10]
look_at = [0, 0, 0]
fov = { keys = [[0, 30], [1, 40]] }

[[light]]
kind = "point"
position = [{ keys = [[0, -5], [1, 5]] }, 5, 5]
intensity = { keys = [[0, 1], [1, 0]] }

[material.red]
color = [{ keys = [[0, 1], [1, 0]] }, 0, 0]
reflect = { keys = [[0, 0], [1, 0.5]] }

[[object]]
file = "blob.hf"
params = [{ keys = [[0.0, 0.5], [1.0, 1.2]] }]
translate = [{ keys = [[0, -2], [1, 2]] }, 0, 0]
rotate = [0, { keys = [[0, 0], [1, 90]] }, 0]
scale = { keys = [[0, 1], [1, 2]] }
material = "red"

[[object]]
file = "blob.hf"
params = [0.7]
)toml");
  EXPECT_TRUE(d.animation.given);
  EXPECT_EQ(d.animation.frames, 48);
  EXPECT_EQ(d.animation.start, 0.0);
  EXPECT_EQ(d.animation.end, 1.0);
  EXPECT_EQ(d.animation.shutter, 0.0);
  EXPECT_EQ(d.keyed.size(), 10u);
  ASSERT_EQ(d.keyed_params.size(), 2u);
  EXPECT_TRUE(d.keyed_params[0]);
  EXPECT_FALSE(d.keyed_params[1]);
  // The values in the description are those at time 0.
  EXPECT_EQ(d.objects[0].params[0], 0.5);
  EXPECT_EQ(d.objects[0].translate.x, -2.0f);
  // Half way.
  SceneDesc h = scene_at(d, 0.5);
  EXPECT_DOUBLE_EQ(h.objects[0].params[0], 0.85);
  EXPECT_EQ(h.objects[0].translate.x, 0.0f);
  EXPECT_EQ(h.objects[0].rotate_deg.y, 45.0f);
  EXPECT_EQ(h.objects[0].scale, 1.5f);
  EXPECT_EQ(h.objects[1].params[0], 0.7);
  EXPECT_EQ(h.camera.request.eye->y, 2.0f);
  EXPECT_EQ(*h.camera.request.fov_deg, 35.0f);
  EXPECT_EQ(h.lights[0].v.x, 0.0f);
  EXPECT_EQ(h.lights[0].intensity, 0.5f);
  EXPECT_EQ(h.materials["red"].color.x, 0.5f);
  EXPECT_EQ(h.materials["red"].reflect, 0.25f);
  // After the last key: held.
  SceneDesc late = scene_at(d, 7);
  EXPECT_EQ(late.objects[0].translate.x, 2.0f);
  EXPECT_EQ(late.objects[0].params[0], 1.2);
  // scene_at keeps the keys: the result moves again.
  EXPECT_EQ(scene_at(late, 0).objects[0].translate.x, -2.0f);
  EXPECT_NE(summary(d).find("48 frames (time 0 to 1), 10 keyed numbers"), std::string::npos)
      << summary(d);
}

TEST_F(AnimationTest, KeysMustBeIncreasingPairs) {
  SceneError e =
      error_of(std::string(kObject) + "translate = [{ keys = [[0, 1], [0, 2]] }, 0, 0]\n");
  EXPECT_EQ(e.message,
            "[[object]] translate[0] keys[1] time must be after the previous key's (0), not 0");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 33);
  EXPECT_NE(e.hint.find("keys = [[time, value], ...]"), std::string::npos);

  e = error_of(std::string(kObject) + "scale = { keys = [[0, 1], [1]] }\n");
  EXPECT_EQ(e.message, "[[object]] scale keys[1] must be a [time, value] pair, not an array of 1");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 27);

  e = error_of(std::string(kObject) + "scale = { keys = [] }\n");
  EXPECT_EQ(e.message,
            "[[object]] scale keys must be a non-empty array of [time, value] pairs, not an "
            "empty array");

  e = error_of(std::string(kObject) + "scale = { key = [[0, 1]] }\n");
  EXPECT_EQ(e.message, "unknown key 'key' in the keys of [[object]] scale");
  EXPECT_EQ(e.hint, "did you mean 'keys'? a keyed number has: keys");

  e = error_of(std::string(kObject) + "scale = { keys = [[0, \"big\"]] }\n");
  EXPECT_EQ(e.message, "[[object]] scale keys[0] value must be a number, not a string");
}

TEST_F(AnimationTest, EveryKeyValueIsRangeChecked) {
  SceneError e = error_of(std::string(kObject) + "scale = { keys = [[0, 1], [1, -2]] }\n");
  EXPECT_EQ(e.message, "[[object]] scale must be > 0, not -2");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 31);

  e = error_of("[material.m]\ncolor = [0, { keys = [[0, 0.5], [2, -1]] }, 0]\n" +
               std::string(kObject));
  EXPECT_EQ(e.message, "[material.m] color[1] must be >= 0, not -1");
  EXPECT_EQ(e.pos.line, 2);
}

TEST_F(AnimationTest, NumbersThatCannotBeKeyed) {
  SceneError e = error_of(std::string("[render]\nspp = { keys = [[0, 1]] }\n") + kObject);
  EXPECT_EQ(e.message, "[render] spp must be an integer, not a table");
  e = error_of(std::string("[camera]\naperture = { keys = [[0, 1]] }\n") + kObject);
  EXPECT_EQ(e.message, "[camera] aperture cannot be keyed: it must be a number");
  EXPECT_EQ(e.pos.line, 2);
  EXPECT_EQ(e.pos.column, 12);
  EXPECT_NE(e.hint.find("keys are for an object's params, translate, rotate and scale"),
            std::string::npos);
  e = error_of(std::string(kObject) + "bbox = [{ keys = [[0, 1]] }, 0, 0, 1, 1, 1]\n");
  EXPECT_EQ(e.message, "[[object]] bbox[0] cannot be keyed: it must be a number");
}

TEST_F(AnimationTest, AnimationTableErrors) {
  SceneError e = error_of(std::string("[animation]\nframes = 10\n") + kObject);
  EXPECT_EQ(e.message, "[animation] has 10 frames but no end");
  EXPECT_EQ(e.pos.line, 1);
  e = error_of(std::string("[animation]\nframes = 10\nstart = 1\nend = 0.5\n") + kObject);
  EXPECT_EQ(e.message, "[animation] end must be after start (1), not 0.5");
  EXPECT_EQ(e.pos.line, 4);
  EXPECT_EQ(e.pos.column, 7);
  e = error_of(std::string("[animation]\nframes = 0\n") + kObject);
  EXPECT_EQ(e.message, "[animation] frames must be at least 1, not 0");
  e = error_of(std::string("[animation]\nframes = 2\nend = 1\nshutter = -0.1\n") + kObject);
  EXPECT_EQ(e.message, "[animation] shutter must be >= 0, not -0.1");
  e = error_of(std::string("[animation]\nframe = 2\n") + kObject);
  EXPECT_EQ(e.message, "unknown key 'frame' in [animation]");
  EXPECT_EQ(e.hint, "did you mean 'frames'? [animation] has: frames, start, end, shutter");
  // One frame needs no end.
  SceneDesc d = parse_ok(std::string("[animation]\nstart = 0.5\n") + kObject);
  EXPECT_EQ(d.animation.frames, 1);
  EXPECT_EQ(d.animation.frame_time(0), 0.5);
}

}  // namespace
}  // namespace hfrt::scene
