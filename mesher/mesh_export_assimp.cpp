// The mesh export module (libhfrt_meshexport.so): the only code of mesher/ that sees Assimp.
// mesher/mesh_export_module.h says why it is a module and what the table means.

#include <assimp/material.h>
#include <assimp/scene.h>

#include <assimp/Exporter.hpp>
#include <memory>

#include "mesher/mesh_export_module.h"

namespace hfrt::mesher::mesh_export {
namespace {

/// A one-mesh Assimp scene of `mesh`. Its faces' indices are one block, `indices` (3 per
/// triangle), where Assimp gives each aiFace an array of its own: 1.25M allocations and as
/// many frees for the 512^3 blend, ~20 % of the writing time. The faces point into the
/// block, so ~Scene takes the pointers back before the aiScene is destroyed (~aiFace would
/// delete[] each one).
struct Scene {
  std::unique_ptr<aiScene> scene;
  std::unique_ptr<unsigned[]> indices;

  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;
  explicit Scene(const TriMesh& mesh);
  ~Scene() {
    aiMesh* m = scene->mMeshes[0];
    for (unsigned i = 0; i < m->mNumFaces; ++i) m->mFaces[i].mIndices = nullptr;
  }
};

Scene::Scene(const TriMesh& mesh) : scene(std::make_unique<aiScene>()) {
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
  const size_t nt = mesh.triangles.size();
  indices.reset(new unsigned[3 * nt]);
  m->mNumFaces = unsigned(nt);
  m->mFaces = new aiFace[nt];
  for (size_t i = 0; i < nt; ++i) {
    unsigned* idx = indices.get() + 3 * i;
    for (int k = 0; k < 3; ++k) idx[k] = mesh.triangles[i][k];
    m->mFaces[i].mNumIndices = 3;
    m->mFaces[i].mIndices = idx;
  }
}

bool write(const std::string& path, const std::string& format, const TriMesh& mesh,
           std::string* error) {
  const Scene scene(mesh);
  Assimp::Exporter exporter;
  if (exporter.Export(scene.scene.get(), format, path) != aiReturn_SUCCESS) {
    *error = exporter.GetErrorString();
    return false;
  }
  return true;
}

const Module kModule{kAbiVersion, &write};

}  // namespace
}  // namespace hfrt::mesher::mesh_export

extern "C" __attribute__((visibility("default"))) const hfrt::mesher::mesh_export::Module*
hfrt_mesh_export_module() {
  return &hfrt::mesher::mesh_export::kModule;
}
