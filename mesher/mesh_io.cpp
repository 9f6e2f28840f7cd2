#include "mesher/mesh_io.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "base/module.h"
#include "mesher/mesh_export_module.h"

namespace hfrt::mesher {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

}  // namespace

std::optional<std::string> mesh_format_for(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".stl") return "stlb";
  if (ext == ".obj") return "objnomtl";
  if (ext == ".ply") return "plyb";
  if (ext == ".glb") return "glb2";
  return std::nullopt;
}

const char* mesh_formats_list() {
  return ".stl, .obj, .ply or .glb";
}

Result<size_t> write_mesh(const std::string& path, const TriMesh& mesh) {
  const std::optional<std::string> format = mesh_format_for(path);
  if (!format) {
    return Error{path + ": unknown mesh format '" + lower_extension(path) + "' (expected " +
                 mesh_formats_list() + ")"};
  }
  // Assimp's messages for a file it cannot open are vague; try it first for errno's reason.
  if (FILE* probe = std::fopen(path.c_str(), "ab")) {
    std::fclose(probe);
  } else {
    return Error{path + ": cannot write: " + std::strerror(errno)};
  }
  auto module = module_table<mesh_export::Module>("meshexport", mesh_export::kEntrySymbol,
                                                  mesh_export::kAbiVersion);
  if (!module.ok())
    return Error{path + ": cannot write: " + module.error().message, module.error().hint};
  std::string why;
  if (!(*module)->write(path, *format, mesh, &why)) return Error{path + ": cannot write: " + why};
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  return size_t(ec ? 0 : size);
}

}  // namespace hfrt::mesher
