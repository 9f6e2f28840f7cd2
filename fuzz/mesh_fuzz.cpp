// Fuzz target: the mesh loaders (geom::load_mesh: the OFF/OBJ line checks, then Assimp for
// OFF, PLY, OBJ, STL). The first byte picks the file extension (0 .off, 1 .ply, 2 .obj,
// 3 .stl; scripts/fuzz.sh prefixes the seeds with theirs), the rest is the file. A mesh that
// loads must satisfy TriangleMesh's invariants and survive the BVH build and every query; an
// OFF text must parse the same in one pass and in parallel chunks.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "base/check.h"
#include "fuzz/geom_queries.h"
#include "geom/mesh.h"
#include "geom/mesh_surface.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hfrt;
  if (size < 1) return 0;
  static const char* const kExt[] = {".off", ".ply", ".obj", ".stl"};
  const std::string path = "/tmp/hfrt_fuzz_mesh_" + std::to_string(getpid()) + kExt[data[0] % 4];
  FILE* f = std::fopen(path.c_str(), "wb");
  HFRT_CHECK(f != nullptr);
  HFRT_CHECK(std::fwrite(data + 1, 1, size - 1, f) == size - 1);
  std::fclose(f);
  if (data[0] % 4 == 0) {
    // Differential: the OFF body in parallel chunks (forced: threshold 0) must give what one
    // pass gives, the same mesh or the same first error.
    const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
    const Result<geom::TriangleMesh> one = geom::parse_off(path, text, {}, SIZE_MAX);
    const Result<geom::TriangleMesh> many = geom::parse_off(path, text, {}, 0);
    HFRT_CHECK(one.ok() == many.ok());
    if (one.ok()) {
      HFRT_CHECK(one->triangles == many->triangles);
      HFRT_CHECK_EQ(one->vertices.size(), many->vertices.size());
      for (size_t i = 0; i < one->vertices.size(); ++i) {
        HFRT_CHECK(std::memcmp(&one->vertices[i], &many->vertices[i], sizeof(Vec3)) == 0);
      }
    } else {
      HFRT_CHECK(one.error().message == many.error().message);
    }
  }
  Result<geom::TriangleMesh> mesh = geom::load_mesh(path);
  std::remove(path.c_str());
  if (!mesh) return 0;
  HFRT_CHECK(!mesh->triangles.empty());
  for (const Vec3& v : mesh->vertices) {
    HFRT_CHECK(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z));
  }
  for (const auto& t : mesh->triangles) {
    for (const uint32_t i : t) HFRT_CHECK_LT(i, mesh->vertices.size());
  }
  if (mesh->triangles.size() > 20000) return 0;  // queries cost; loading is the point
  auto surface = geom::MeshSurface::build(*mesh);
  fuzz::exercise_surface(*surface);
  return 0;
}
