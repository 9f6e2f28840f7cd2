// The POV-Ray mapping of scene settings: absorption, lens, area-light sampling and the
// material blocks (POV-Ray itself renders emitted scenes in tests/tools/scene_cli_test.cpp).

#include "scene/pov_scene.h"

#include <gtest/gtest.h>

#include <cmath>

namespace hfrt::scene {
namespace {

TEST(PovFade, ExponentialFadeEqualsBeerLambert) {
  const render::Vec3 absorb{0.2f, 0.7f, 1.5f};
  const PovFade f = pov_fade(absorb);
  ASSERT_TRUE(f.on);
  // POV-Ray (fade_power >= 1000): exp(-(1 - fade_color) d / fade_distance) per channel.
  const float sigma[3] = {absorb.x, absorb.y, absorb.z};
  const float colour[3] = {f.color.x, f.color.y, f.color.z};
  for (double d : {0.1, 1.0, 3.7}) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(std::exp(-(1 - colour[k]) * d / f.distance), std::exp(-sigma[k] * d), 1e-6);
      EXPECT_GE(colour[k], 0);
      EXPECT_LT(colour[k], 1);
    }
  }
  EXPECT_FALSE(pov_fade({0, 0, 0}).on);
}

TEST(PovLens, ApertureIsFourTimesTheLensRadius) {
  EXPECT_FLOAT_EQ(pov_aperture(0.05f), 0.2f);
}

TEST(PovAreaLight, NearestSquareOfAtLeastTwoByTwo) {
  EXPECT_EQ(pov_area_light_side(1), 2);
  EXPECT_EQ(pov_area_light_side(4), 2);
  EXPECT_EQ(pov_area_light_side(16), 4);
  EXPECT_EQ(pov_area_light_side(32), 6);
  EXPECT_EQ(pov_area_light_side(100), 10);
}

TEST(PovMaterial, DefaultMaterialIsHfrtsFirstHitLook) {
  EXPECT_EQ(pov_material(render::Material{}, ""),
            "texture {\n"
            "  pigment { rgbt <0.78, 0.76, 0.7, 0> }\n"
            "  finish {\n"
            "    ambient 0.12 diffuse 1\n"
            "    specular 0.25 roughness 0.02083333\n"
            "  }\n"
            "}\n");
}

TEST(PovMaterial, PartlyTransmittingMaterialKeepsItsOwnLight) {
  render::Material m;
  m.transmit = 0.5f;
  m.ambient = 0.1f;
  m.diffuse = 0.4f;
  m.specular = 0;
  m.reflect = 0.25f;
  const std::string t = pov_material(m, "");
  // POV-Ray weighs ambient and diffuse by 1 - transmit: written doubled.
  EXPECT_NE(t.find("ambient 0.2 diffuse 0.8\n"), std::string::npos) << t;
  EXPECT_NE(t.find("reflection { 0.25 }"), std::string::npos) << t;
  EXPECT_NE(t.find("interior {\n  ior 1.5\n}\n"), std::string::npos) << t;
  EXPECT_EQ(t.find("specular"), std::string::npos) << t;
}

}  // namespace
}  // namespace hfrt::scene
