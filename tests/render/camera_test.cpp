#include "render/camera.h"

#include <gtest/gtest.h>

#include <random>

namespace hfrt::render {
namespace {

TEST(Camera, PerspectiveCentreRayLooksAtTarget) {
  Camera cam;
  cam.eye = {1, 2, 3};
  cam.look_at = {4, -2, 3};
  CameraFrame frame(cam, 64, 32);
  Ray r = frame.ray(32, 16);
  Vec3 dir = normalize(r.d);
  EXPECT_NEAR(dir.x, 0.6f, 1e-6);
  EXPECT_NEAR(dir.y, -0.8f, 1e-6);
  EXPECT_NEAR(dir.z, 0.0f, 1e-6);
  // t is the camera depth: the centre ray has a unit direction.
  EXPECT_NEAR(length(r.d), 1.0f, 1e-6);
}

TEST(Camera, PerspectiveFieldOfView) {
  Camera cam;
  cam.eye = {0, 0, 10};
  cam.look_at = {0, 0, 0};
  cam.fov_deg = 90;
  CameraFrame frame(cam, 100, 100);
  // The top edge of the image is 45 degrees above the view direction.
  Ray top = frame.ray(50, 0);
  EXPECT_NEAR(top.d.y / -top.d.z, 1.0f, 1e-6);
  Ray left = frame.ray(0, 50);
  EXPECT_NEAR(left.d.x / -left.d.z, -1.0f, 1e-6);
}

TEST(Camera, OrthographicRaysAreParallel) {
  Camera cam;
  cam.kind = Camera::Kind::kOrthographic;
  cam.eye = {0, 0, 10};
  cam.look_at = {0, 0, 0};
  cam.ortho_width = 8;
  CameraFrame frame(cam, 200, 100);
  Ray a = frame.ray(0, 0), b = frame.ray(200, 100);
  EXPECT_FLOAT_EQ(a.d.z, -1);
  EXPECT_FLOAT_EQ(b.d.z, -1);
  EXPECT_FLOAT_EQ(a.o.x, -4);
  EXPECT_FLOAT_EQ(a.o.y, 2);
  EXPECT_FLOAT_EQ(b.o.x, 4);
  EXPECT_FLOAT_EQ(b.o.y, -2);
}

TEST(Camera, SlabBoxEnclosesEveryRayPoint) {
  for (auto kind : {Camera::Kind::kPerspective, Camera::Kind::kOrthographic}) {
    Camera cam;
    cam.kind = kind;
    cam.eye = {7, 5, 9};
    cam.look_at = {0.5f, -0.2f, 0.1f};
    cam.up = {0, 1, 0.2f};
    cam.ortho_width = 12;
    CameraFrame frame(cam, 320, 240);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0, 1);
    for (int trial = 0; trial < 2000; ++trial) {
      float px0 = 300 * u(rng), py0 = 220 * u(rng), t0 = 20 * u(rng);
      float px1 = px0 + 16, py1 = py0 + 16, t1 = t0 + 5 * u(rng);
      Box b = frame.slab_box(px0, py0, px1, py1, t0, t1);
      for (int k = 0; k < 20; ++k) {
        Ray r = frame.ray(px0 + 16 * u(rng), py0 + 16 * u(rng));
        float t = t0 + (t1 - t0) * u(rng);
        Vec3 p = r.o + r.d * t;
        ASSERT_TRUE(b.contains(p)) << "trial " << trial;
      }
    }
  }
}

TEST(Camera, IntersectBox) {
  Box box{{-1, -1, -1}, {1, 1, 1}};
  float t0, t1;
  int axis;
  ASSERT_TRUE(intersect_box({{0, 0, 5}, {0, 0, -1}}, box, &t0, &t1, &axis));
  EXPECT_FLOAT_EQ(t0, 4);
  EXPECT_FLOAT_EQ(t1, 6);
  EXPECT_EQ(axis, 2);
  EXPECT_FALSE(intersect_box({{3, 0, 5}, {0, 0, -1}}, box, &t0, &t1, &axis));
  ASSERT_TRUE(intersect_box({{-5, 0.5f, 0}, {2, 0, 0}}, box, &t0, &t1, &axis));
  EXPECT_FLOAT_EQ(t0, 2);
  EXPECT_FLOAT_EQ(t1, 3);
  EXPECT_EQ(axis, 0);
}

TEST(Camera, DepthRangeOfBox) {
  Camera cam;
  cam.eye = {0, 0, 20};
  cam.look_at = {0, 0, 0};
  CameraFrame frame(cam, 10, 10);
  float lo, hi;
  frame.depth_range(Box{{-10, -10, -10}, {10, 10, 10}}, &lo, &hi);
  EXPECT_FLOAT_EQ(lo, 10);
  EXPECT_FLOAT_EQ(hi, 30);
}

}  // namespace
}  // namespace hfrt::render
