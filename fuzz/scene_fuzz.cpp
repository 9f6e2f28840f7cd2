// Fuzz target: the scene-file reader (scene::parse_scene: TOML through toml++, then every
// validation of scene_file.h). Any bytes; the scene is named as if it lay in examples/scenes/
// so that the seeds' model files resolve. A scene that reads is summarised, moved to a few
// times (keyed numbers), and its objects' sources and boxes taken; a scene that does not has
// a message and a location inside the text.
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/check.h"
#include "scene/scene_file.h"

#ifndef HFRT_FUZZ_SCENE_PATH
#define HFRT_FUZZ_SCENE_PATH "fuzz.toml"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hfrt;
  const std::string text(reinterpret_cast<const char*>(data), size);
  scene::SceneDesc desc;
  scene::SceneError err;
  if (!scene::parse_scene(text, HFRT_FUZZ_SCENE_PATH, &desc, &err)) {
    HFRT_CHECK(!err.message.empty());
    (void)err.render();
    return 0;
  }
  (void)scene::summary(desc);
  for (const double t : {0.0, 0.5, desc.animation.frame_time(desc.animation.frames - 1)}) {
    const scene::SceneDesc at = scene::scene_at(desc, t);
    HFRT_CHECK_EQ(at.objects.size(), desc.objects.size());
  }
  for (const scene::ObjectDesc& object : desc.objects) {
    std::string source, name, error;
    (void)scene::object_source(object, HFRT_FUZZ_SCENE_PATH, &source, &name, &error);
    (void)scene::world_box(object, render::Box{render::Vec3{-1, -1, -1}, render::Vec3{1, 1, 1}});
  }
  return 0;
}
