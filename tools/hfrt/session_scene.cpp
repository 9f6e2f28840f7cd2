// The REPL's scene commands: `:scene FILE [OUT]`, `:scene -o OUT` and `:set KEY.PATH VALUE`
// (edits of the loaded scene, e.g. `:set material.glass.ior 1.3`). The scene is compiled and
// traced by app::run_scene_job, as `hfrt render scene.toml` does.
#include <cstdio>

#include "app/scene_job.h"
#include "base/file.h"
#include "base/timer.h"
#include "scene/scene_edit.h"
#include "tools/hfrt/session.h"

namespace hfrt::tools {
namespace {

SessionResult scene_failure(std::string err) {
  SessionResult r;
  r.ok = false;
  r.err = std::move(err);
  if (!r.err.empty() && r.err.back() != '\n') r.err += '\n';
  return r;
}

SessionResult scene_success(std::string out) {
  SessionResult r;
  r.out = std::move(out);
  if (!r.out.empty() && r.out.back() != '\n') r.out += '\n';
  return r;
}

}  // namespace

SessionResult Session::cmd_scene(const std::vector<std::string>& args) {
  if (args.size() == 2 && args[0] == "-o") {
    if (!scene_) return scene_failure("hfrt: no scene loaded (:scene FILE.toml first)");
    return render_scene(args[1]);
  }
  if (args.empty() || args.size() > 2) {
    return scene_failure("hfrt: :scene expects FILE.toml [OUT] or -o OUT");
  }
  Result<std::string> text = read_file(args[0]);
  if (!text) return scene_failure("hfrt: " + text.error().message);
  scene::SceneDesc desc;
  scene::SceneError err;
  if (!scene::parse_scene(*text, args[0], &desc, &err)) return scene_failure(err.render());
  scene_path_ = args[0];
  scene_text_ = std::move(*text);
  scene_ = std::move(desc);
  scene_output_.clear();
  if (args.size() == 2) return render_scene(args[1]);
  return scene_success(scene::summary(*scene_));
}

SessionResult Session::cmd_scene_set(const std::vector<std::string>& args) {
  if (!scene_) {
    return scene_failure("hfrt: '" + args[0] +
                         "' is a scene key, and no scene is loaded (:scene FILE.toml first)");
  }
  if (args.size() < 2) return scene_failure("hfrt: :set expects KEY VALUE");
  std::string value;
  for (size_t i = 1; i < args.size(); ++i) value += (i > 1 ? " " : "") + args[i];
  scene::SceneDesc desc;
  scene::SceneError err;
  if (!scene::set_scene_value(&scene_text_, scene_path_, args[0], value, &desc, &err)) {
    return scene_failure(err.render());
  }
  scene_ = std::move(desc);
  if (!scene_output_.empty()) return render_scene(scene_output_);
  return scene_success("");
}

SessionResult Session::render_scene(const std::string& out) {
  const auto t0 = Clock::now();
  app::SceneOverrides ov;
  ov.threads = setup_.options.threads;
  ov.interp_backend = cli_.model.backend == "interp";
  if (!cli_.model.time.empty()) ov.time = setup_.time;  // `:set time T`: the scene at T
  render::TraceResult result;
  result.image = std::move(spare_image_);
  app::SceneJobResult done = app::run_scene_job(*scene_, ov, nullptr, &cancel_, &result);
  for (const std::string& w : done.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  switch (done.status) {
    case app::SceneJobStatus::kOk:
      break;
    case app::SceneJobStatus::kCancelled:
      spare_image_ = std::move(result.image);
      return scene_failure("hfrt: render cancelled");
    case app::SceneJobStatus::kSourceError:
      return scene_failure(done.error);
    case app::SceneJobStatus::kEnvironment:
    case app::SceneJobStatus::kUsageError:
      return scene_failure("hfrt: " + done.error);
  }
  auto written = render::write_image(result.image, out, {}, render::PngCompression::kFast);
  if (!written.ok()) return scene_failure("hfrt: " + written.error().message);
  scene_output_ = out;
  if (last_image_) spare_image_ = std::move(*last_image_);
  last_image_ = std::move(result.image);
  ++renders_;
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s %dx%d, %zu objects, %.1f ms", out.c_str(), done.options.width,
                done.options.height, done.objects.size(), ms_since(t0));
  std::string text = buf;
  if (cli_.stats) text += "\n" + app::format_scene_stats(done, result.stats);
  SessionResult r = scene_success(text);
  r.rendered = true;
  return r;
}

}  // namespace hfrt::tools
