#include "mesher/mesh_io.h"

#include <assimp/material.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Exporter.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace hfrt::mesher {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

/// A one-mesh Assimp scene (owned by the aiScene destructor) of `mesh`.
std::unique_ptr<aiScene> make_scene(const TriMesh& mesh) {
  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode();
  scene->mRootNode->mName = "hfrt_mesh";
  scene->mRootNode->mNumMeshes = 1;
  scene->mRootNode->mMeshes = new unsigned[1]{0};
  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial*[1];
  scene->mMaterials[0] = new aiMaterial();
  aiString name("hfrt");
  scene->mMaterials[0]->AddProperty(&name, AI_MATKEY_NAME);
  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh*[1];
  aiMesh* m = new aiMesh();
  scene->mMeshes[0] = m;
  m->mName = "hfrt_mesh";
  m->mMaterialIndex = 0;
  m->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  m->mNumVertices = unsigned(mesh.vertices.size());
  m->mVertices = new aiVector3D[mesh.vertices.size()];
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& v = mesh.vertices[i];
    m->mVertices[i] = aiVector3D(v.x, v.y, v.z);
  }
  if (!mesh.colors.empty()) {
    m->mColors[0] = new aiColor4D[mesh.vertices.size()];
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      const Vec3& c = mesh.colors[i];
      m->mColors[0][i] = aiColor4D(c.x, c.y, c.z, 1.0f);
    }
  }
  m->mNumFaces = unsigned(mesh.triangles.size());
  m->mFaces = new aiFace[mesh.triangles.size()];
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    aiFace& f = m->mFaces[i];
    f.mNumIndices = 3;
    f.mIndices = new unsigned[3]{mesh.triangles[i][0], mesh.triangles[i][1], mesh.triangles[i][2]};
  }
  return scene;
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
  std::unique_ptr<aiScene> scene = make_scene(mesh);
  Assimp::Exporter exporter;
  if (exporter.Export(scene.get(), *format, path) != aiReturn_SUCCESS) {
    return Error{path + ": cannot write: " + exporter.GetErrorString()};
  }
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  return size_t(ec ? 0 : size);
}

}  // namespace hfrt::mesher
