// Mesh loading: every format through Assimp, polygons triangulated, degenerate triangles
// skipped and counted, and every kind of bad input reported with the file (and line).

#include "geom/mesh.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "geom/bezier.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("hfrt_geom_mesh_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  std::string error_of(const std::string& name, const std::string& text) {
    Result<TriangleMesh> m = load_mesh(write(name, text));
    EXPECT_FALSE(m.ok()) << name;
    return m.ok() ? std::string() : m.error().message;
  }
  std::filesystem::path dir_;
};

const char* kTetraOff =
    "OFF\n# a tetrahedron\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

TEST_F(MeshFiles, LoadsOffWithTriangles) {
  Result<TriangleMesh> m = load_mesh(write("t.off", kTetraOff));
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->vertices.size(), 4u);
  EXPECT_EQ(m->triangles.size(), 4u);
  EXPECT_EQ(m->degenerate_skipped, 0u);
  EXPECT_EQ(m->bounds().hi.x, 1.0f);
}

TEST_F(MeshFiles, TriangulatesObjQuadsAndJoinsVertices) {
  Result<TriangleMesh> m = load_mesh(
      write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n"));
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->triangles.size(), 3u);  // the quad becomes two triangles
  double area = 0;
  for (size_t t = 0; t < m->triangles.size(); ++t)
    area +=
        0.5 * length(cross(m->corner(t, 1) - m->corner(t, 0), m->corner(t, 2) - m->corner(t, 0)));
  EXPECT_NEAR(area, 1.5, 1e-6);
}

TEST_F(MeshFiles, LoadsAsciiPlyAndStl) {
  Result<TriangleMesh> ply = load_mesh(
      write("t.ply",
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"));
  ASSERT_TRUE(ply.ok()) << ply.error().message;
  EXPECT_EQ(ply->triangles.size(), 2u);
  Result<TriangleMesh> stl = load_mesh(
      write("t.stl",
            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
            "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\n"
            "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n"));
  ASSERT_TRUE(stl.ok()) << stl.error().message;
  EXPECT_EQ(stl->triangles.size(), 2u);
  EXPECT_EQ(stl->vertices.size(), 4u);  // identical STL corners are joined
}

TEST_F(MeshFiles, LoadsTheArmadillo) {
  const TriangleMesh& m = testing::armadillo();
  EXPECT_EQ(m.triangles.size() + m.degenerate_skipped, 52000u);
  EXPECT_EQ(m.vertices.size(), 26002u);
}

TEST_F(MeshFiles, SkipsAndCountsDegenerateTriangles) {
  Result<TriangleMesh> m =
      load_mesh(write("d.off",
                      "OFF\n5 4 0\n0 0 0\n1 0 0\n0 1 0\n2 0 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 1 4\n"
                      "3 2 2 4\n"));
  ASSERT_TRUE(m.ok()) << m.error().message;
  // (0,1,3) is collinear; (2,2,4) repeats a vertex.
  EXPECT_EQ(m->triangles.size(), 2u);
  EXPECT_EQ(m->degenerate_skipped, 2u);
}

TEST_F(MeshFiles, MissingFileNamesThePath) {
  Result<TriangleMesh> m = load_mesh((dir_ / "nope.off").string());
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("nope.off"), std::string::npos) << m.error().message;
  EXPECT_NE(m.error().message.find("no such file"), std::string::npos) << m.error().message;
}

TEST_F(MeshFiles, MalformedNumberHasItsLine) {
  const std::string e = error_of("bad.off", "OFF\n3 1 0\n0 0 0\n1 zz 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(e.find("bad.off:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("zz"), std::string::npos) << e;
  const std::string o = error_of("bad.obj", "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(o.find("bad.obj:2:"), std::string::npos) << o;
}

TEST_F(MeshFiles, OutOfRangeIndexHasItsLine) {
  const std::string e = error_of("oor.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
  EXPECT_NE(e.find("oor.off:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  const std::string o = error_of("oor.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 7\n");
  EXPECT_NE(o.find("oor.obj:5:"), std::string::npos) << o;
  EXPECT_NE(o.find("out of range"), std::string::npos) << o;
}

TEST_F(MeshFiles, NonFiniteCoordinateHasItsLine) {
  const std::string e = error_of("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(e.find("nan.off:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
  const std::string big = error_of("big.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(big.find("big.obj:2:"), std::string::npos) << big;
}

TEST_F(MeshFiles, EmptyAndTruncatedMeshes) {
  EXPECT_NE(error_of("e.off", "OFF\n0 0 0\n").find("empty mesh"), std::string::npos);
  EXPECT_NE(error_of("z.off", "").find("empty file"), std::string::npos);
  const std::string t = error_of("t.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_NE(t.find("1 of 2 faces"), std::string::npos) << t;
  const std::string d = error_of("deg.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n");
  EXPECT_NE(d.find("degenerate"), std::string::npos) << d;
  const std::string h = error_of("h.off", "hello world\n");
  EXPECT_NE(h.find("h.off:1:"), std::string::npos) << h;
}

TEST_F(MeshFiles, UnknownFormatAndAssimpErrorsNameTheFile) {
  EXPECT_NE(error_of("x.xyz", "1 2 3\n").find("unknown mesh format"), std::string::npos);
  const std::string p = error_of("b.ply", "ply\nformat ascii 1.0\nelement vertex 2\nend\n");
  EXPECT_NE(p.find("b.ply"), std::string::npos) << p;
}

TEST(InlineMesh, OneBasedIndices) {
  const double v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double t[] = {1, 3, 2, 1, 2, 4, 1, 4, 3, 2, 3, 4};
  Result<TriangleMesh> m = mesh_from_arrays(v, t);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->triangles.size(), 4u);
  EXPECT_EQ(m->triangles[0][0], 0u);
  EXPECT_EQ(m->triangles[0][1], 2u);
}

TEST(InlineMesh, Errors) {
  const double v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const double bad_t[] = {1, 2, 4};
  Result<TriangleMesh> a = mesh_from_arrays(v, bad_t, "hfTriangles at m.hf:3:5");
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message.find("m.hf:3:5"), std::string::npos);
  EXPECT_NE(a.error().message.find("1..3"), std::string::npos) << a.error().message;
  const double zero_t[] = {0, 1, 2};
  EXPECT_FALSE(mesh_from_arrays(v, zero_t).ok());
  const double frac_t[] = {1, 2.5, 3};
  EXPECT_FALSE(mesh_from_arrays(v, frac_t).ok());
  const double short_v[] = {0, 0, 0, 1};
  const double t[] = {1, 2, 3};
  EXPECT_NE(mesh_from_arrays(short_v, t).error().message.find("multiple of 3"), std::string::npos);
  const double nan_v[] = {0, 0, 0, 1, std::nan(""), 0, 0, 1, 0};
  EXPECT_NE(mesh_from_arrays(nan_v, t).error().message.find("vertex 2"), std::string::npos);
  EXPECT_NE(mesh_from_arrays(v, {}).error().message.find("empty mesh"), std::string::npos);
}

// A binary PLY body (little endian): the tetrahedron's 4 float vertices and 4 triangles with
// a uchar count and int indices, after a header that declares `vertices` vertices.
std::string binary_tetra_ply(int vertices) {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex " +
                  std::to_string(vertices) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face 4\n"
                  "property list uchar int vertex_indices\nend_header\n";
  auto put = [&](const void* p, size_t n) { s.append(static_cast<const char*>(p), n); };
  const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  put(v, sizeof v);
  const int32_t t[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& f : t) {
    const uint8_t three = 3;
    put(&three, 1);
    put(f, sizeof f);
  }
  return s;
}

TEST_F(MeshFiles, LoadsBinaryPly) {
  Result<TriangleMesh> m = load_mesh(write("b.ply", binary_tetra_ply(4)));
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->vertices.size(), 4u);
  EXPECT_EQ(m->triangles.size(), 4u);
}

// Found by fuzz/mesh_fuzz.cpp: a binary PLY whose header declares more vertices than its body
// holds made Assimp read past the end and crash on the garbage indices (SEGV in its
// post-processing). It is a located error now.
TEST_F(MeshFiles, TruncatedBinaryPlyIsAnError) {
  const std::string e = error_of("short.ply", binary_tetra_ply(8));
  EXPECT_NE(e.find("short.ply: truncated binary PLY: face"), std::string::npos) << e;
  EXPECT_NE(error_of("cut.ply", binary_tetra_ply(4).substr(0, 200)).find("truncated binary PLY"),
            std::string::npos);
  // A face without vertices made Assimp abort (TriangulateProcess.cpp: numOut !=
  // pMesh->mNumFaces), as did an unknown header line that shifted its reading of the body.
  std::string zero = binary_tetra_ply(4);
  const size_t first_face = zero.find("end_header\n") + 11 + 48;
  ASSERT_EQ(zero[first_face], 3);
  std::string oor = zero;
  zero.erase(first_face + 1, 12);
  zero[first_face] = 0;
  const std::string z = error_of("z.ply", zero);
  EXPECT_NE(z.find("z.ply: binary PLY: face 1 of 4 has no vertices"), std::string::npos) << z;
  oor[first_face + 1] = 4;  // the first index of the first face: 4 of vertices 0..3
  const std::string r = error_of("r.ply", oor);
  EXPECT_NE(r.find("r.ply: binary PLY: face 1 of 4 has a vertex index out of range"),
            std::string::npos)
      << r;
  std::string plus = binary_tetra_ply(4);
  plus.replace(plus.find("property float z"), 0, "+");
  const std::string u = error_of("u.ply", plus);
  EXPECT_NE(u.find("u.ply:6: unknown PLY header line '+property float z'"), std::string::npos) << u;
  const std::string p = error_of("p.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n");
  EXPECT_NE(p.find("p.ply:3: PLY property before any element"), std::string::npos) << p;
}

// Found by fuzz/mesh_fuzz.cpp: ASCII PLY bodies with garbage in a line made Assimp abort on
// an internal assertion (TriangulateProcess.cpp: numOut != pMesh->mNumFaces) or leak. The
// body is checked line by line first, like OFF and OBJ files.
TEST_F(MeshFiles, MalformedAsciiPlyBodyHasItsLine) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string v = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  const std::string garbage = error_of("g.ply", header + v + "3 0 2 1\n3 0\xe0\xce\xdf\xd6\n");
  EXPECT_NE(garbage.find("g.ply:15: list of 3 values is cut short in face 2 of 4"),
            std::string::npos)
      << garbage;
  const std::string word = error_of("w.ply", header + "0 0 0\n1 0 $mat.twoside0\n");
  EXPECT_NE(word.find("w.ply:11: malformed or missing number in vertex 2 of 4"), std::string::npos)
      << word;
  const std::string range = error_of("r.ply", header + v + "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 4\n");
  EXPECT_NE(range.find("r.ply:17: vertex index 4 out of range"), std::string::npos) << range;
  const std::string missing = error_of("m.ply", header + v + "3 0 2 1\n");
  EXPECT_NE(missing.find("truncated PLY: face 2 of 4 is missing"), std::string::npos) << missing;
  const std::string zero = error_of("z.ply", header + v + "0\n");
  EXPECT_NE(zero.find("z.ply:14: face 1 of 4 has no vertices"), std::string::npos) << zero;
  const std::string extra = error_of("x.ply", header + "0 0 0 7\n");
  EXPECT_NE(extra.find("x.ply:10: extra values in vertex 1 of 4"), std::string::npos) << extra;
  Result<TriangleMesh> ok =
      load_mesh(write("ok.ply", header + v + "3 0 2 1\n\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"));
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->triangles.size(), 4u);
}

// OFF numbers go through std::from_chars first and strtod / strtoll for what only those
// accept: a leading '+', hexadecimal floats, tabs and carriage returns between tokens. Every
// form strtod read before still reads, to the same value.
TEST_F(MeshFiles, OffNumbersInEveryFormStrtodAccepts) {
  Result<TriangleMesh> m = load_mesh(
      write("forms.off", "OFF\r\n3\t1 0\r\n+1.5 0x1p-2 -0\n1e-1 .5 7.\n0 1 0\n+3 0 +1 2\n"));
  ASSERT_TRUE(m.ok()) << m.error().message;
  ASSERT_EQ(m->vertices.size(), 3u);
  EXPECT_EQ(m->vertices[0].x, 1.5f);
  EXPECT_EQ(m->vertices[0].y, 0.25f);
  EXPECT_EQ(m->vertices[0].z, 0.0f);
  EXPECT_EQ(m->vertices[1].x, static_cast<float>(0.1));
  EXPECT_EQ(m->vertices[1].y, 0.5f);
  EXPECT_EQ(m->vertices[1].z, 7.0f);
  ASSERT_EQ(m->triangles.size(), 1u);
  // Still malformed: a sign alone, a trailing letter, a coordinate beyond double.
  EXPECT_NE(error_of("sign.off", "OFF\n3 1 0\n+ 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").find("sign.off:3:"),
            std::string::npos);
  EXPECT_NE(error_of("tail.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1x 0\n3 0 1 2\n")
                .find("tail.off:5: malformed coordinate '1x'"),
            std::string::npos);
  EXPECT_NE(error_of("huge.off", "OFF\n3 1 0\n0 0 0\n1e400 0 0\n0 1 0\n3 0 1 2\n")
                .find("huge.off:4: non-finite coordinate"),
            std::string::npos);
}

// Found by fuzz/mesh_fuzz.cpp: a face size beyond long long's range (strtoll saturated it to
// LLONG_MAX) overflowed the size check (1 + n, undefined behaviour) and the index loop then read
// past the line's tokens. Out-of-range integers are malformed now.
TEST_F(MeshFiles, HugeOffFaceSizeIsMalformed) {
  const std::string e = error_of(
      "huge.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + std::string(60, '4') + " 0 1 3\n");
  EXPECT_NE(e.find("huge.off:7: malformed face size '444"), std::string::npos) << e;
  const std::string i =
      error_of("idx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99999999999999999999\n");
  EXPECT_NE(i.find("idx.off:6: malformed vertex index"), std::string::npos) << i;
}

}  // namespace
}  // namespace hfrt::geom

namespace hfrt::geom {
namespace {

// ---- limits (base/limits.h): endless and huge inputs cost nothing to refuse -----------------

TEST_F(MeshFiles, DevZeroIsRefusedBeforeReading) {
  Result<TriangleMesh> m = load_mesh("/dev/zero");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().message,
            "/dev/zero: is not a regular file (a device, a pipe or a socket, which may never end)");
  Result<PatchSet> p = load_bpt("/dev/zero");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().message,
            "/dev/zero: is not a regular file (a device, a pipe or a socket, which may never end)");
}

TEST_F(MeshFiles, FileOverTheByteLimitIsRefusedWithTheOption) {
  const std::string path = write("limit.off", kTetraOff);
  Limits limits;
  ASSERT_TRUE(load_mesh(path, limits).ok());
  limits.max_mesh_bytes = 16;
  Result<TriangleMesh> m = load_mesh(path, limits);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().message, path + ": is " + std::to_string(std::string(kTetraOff).size()) +
                                   " bytes, more than the limit of 16 bytes");
  EXPECT_NE(m.error().hint.find("--max-mesh-bytes N"), std::string::npos);
}

TEST_F(MeshFiles, TriangleCountHasALimit) {
  const std::string path = write("count.off", kTetraOff);
  Limits limits;
  limits.max_mesh_triangles = 4;
  ASSERT_TRUE(load_mesh(path, limits).ok());
  limits.max_mesh_triangles = 3;
  Result<TriangleMesh> m = load_mesh(path, limits);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().message, path + ": 4 triangles, more than the limit of 3");
  EXPECT_NE(m.error().hint.find("--max-mesh-triangles N"), std::string::npos);
}

}  // namespace
}  // namespace hfrt::geom

namespace hfrt::geom {
namespace {

/// An OFF text of a strip of quads (as fans) with comments, blank lines, extra columns and
/// CRLF line ends sprinkled in; `bad_line` (1-based, 0 for none) is replaced by `bad`.
std::string strip_off(int quads, int bad_line = 0, const std::string& bad = "") {
  std::vector<std::string> lines = {
      "OFF", "# a strip", std::to_string(2 * (quads + 1)) + " " + std::to_string(quads) + " 0"};
  for (int i = 0; i <= quads; ++i) {
    lines.push_back(std::to_string(i) + " 0 0" + (i % 7 == 0 ? "  # bottom" : ""));
    lines.push_back(std::to_string(i) + ".5 1 " + std::to_string(i % 3) + (i % 5 ? "" : "\r"));
    if (i % 11 == 0) lines.push_back("");
  }
  for (int i = 0; i < quads; ++i) {
    lines.push_back("4 " + std::to_string(2 * i) + " " + std::to_string(2 * i + 2) + " " +
                    std::to_string(2 * i + 3) + " " + std::to_string(2 * i + 1) +
                    (i % 13 ? "" : " 255 0 0"));
    if (i % 17 == 0) lines.push_back("   # spacer");
  }
  std::string text;
  for (size_t k = 0; k < lines.size(); ++k) {
    text += (int(k) + 1 == bad_line ? bad : lines[k]) + "\n";
  }
  return text;
}

// The parallel parse of a large body (forced here by a threshold of 0 bytes: chunks of ~256
// KiB, the same on any thread count) gives the mesh of one pass, and the same first error.
TEST(OffParse, ChunkedParseEqualsOnePass) {
  const std::string text = strip_off(40000);  // ~1.6 MB: 6 chunks
  ASSERT_GT(text.size(), size_t(1) << 20);
  const Result<TriangleMesh> one = parse_off("strip.off", text, {}, SIZE_MAX);
  const Result<TriangleMesh> many = parse_off("strip.off", text, {}, 0);
  ASSERT_TRUE(one.ok()) << one.error().message;
  ASSERT_TRUE(many.ok()) << many.error().message;
  ASSERT_EQ(one->vertices.size(), 80002u);
  ASSERT_EQ(one->triangles.size(), 80000u);
  ASSERT_EQ(many->vertices.size(), one->vertices.size());
  ASSERT_EQ(many->triangles.size(), one->triangles.size());
  for (size_t i = 0; i < one->vertices.size(); ++i) {
    ASSERT_EQ(many->vertices[i].x, one->vertices[i].x) << i;
    ASSERT_EQ(many->vertices[i].y, one->vertices[i].y) << i;
    ASSERT_EQ(many->vertices[i].z, one->vertices[i].z) << i;
  }
  for (size_t i = 0; i < one->triangles.size(); ++i)
    ASSERT_EQ(many->triangles[i], one->triangles[i]);
  // A fan of the quad 0 2 3 1: (0, 2, 3), (0, 3, 1).
  EXPECT_EQ(one->triangles[0], (std::array<uint32_t, 3>{0, 2, 3}));
  EXPECT_EQ(one->triangles[1], (std::array<uint32_t, 3>{0, 3, 1}));
}

TEST(OffParse, ChunkedParseReportsTheFirstErrorAtItsLine) {
  const int quads = 40000;
  const std::string base = strip_off(quads);
  const int nlines = int(std::count(base.begin(), base.end(), '\n'));
  struct Case {
    int line;
    std::string bad, expect;
  };
  const std::vector<Case> cases = {
      {nlines / 3, "1 2 x3", "malformed coordinate 'x3'"},
      {nlines - 5, "4 1 2 3 99999999", "vertex index 99999999 out of range"},
      {nlines - 1, "3 1 2", "a face of 3 vertices lists fewer indices"},
  };
  for (const Case& c : cases) {
    const std::string text = strip_off(quads, c.line, c.bad);
    const Result<TriangleMesh> one = parse_off("strip.off", text, {}, SIZE_MAX);
    const Result<TriangleMesh> many = parse_off("strip.off", text, {}, 0);
    ASSERT_FALSE(one.ok()) << c.bad;
    ASSERT_FALSE(many.ok()) << c.bad;
    EXPECT_EQ(many.error().message, one.error().message);
    EXPECT_NE(one.error().message.find("strip.off:" + std::to_string(c.line) + ": "),
              std::string::npos)
        << one.error().message;
    EXPECT_NE(one.error().message.find(c.expect), std::string::npos) << one.error().message;
  }
  // Two errors: the earlier one is reported, though the later one's chunk is parsed too.
  std::string two = strip_off(quads, nlines - 3, "4 0 1 2 x");
  two.replace(two.find("\n5 0 0\n"), 7, "\n5 0 y\n");
  const Result<TriangleMesh> one = parse_off("strip.off", two, {}, SIZE_MAX);
  const Result<TriangleMesh> many = parse_off("strip.off", two, {}, 0);
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(many.error().message, one.error().message);
  EXPECT_NE(one.error().message.find("malformed coordinate 'y'"), std::string::npos);
  // The file ends early: the count and the last line, as one pass says.
  const std::string cut = base.substr(0, base.rfind('\n', base.size() / 2) + 1);
  const Result<TriangleMesh> a = parse_off("strip.off", cut, {}, SIZE_MAX);
  const Result<TriangleMesh> b = parse_off("strip.off", cut, {}, 0);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(b.error().message, a.error().message);
  EXPECT_NE(a.error().message.find("file ends after"), std::string::npos);
  // Over the triangle limit.
  Limits small;
  small.max_mesh_triangles = 1000;
  const Result<TriangleMesh> c = parse_off("strip.off", base, small, SIZE_MAX);
  const Result<TriangleMesh> d = parse_off("strip.off", base, small, 0);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(d.error().message, c.error().message);
  EXPECT_NE(c.error().message.find("80000 triangles, more than the limit of 1000"),
            std::string::npos)
      << c.error().message;
}

}  // namespace
}  // namespace hfrt::geom
