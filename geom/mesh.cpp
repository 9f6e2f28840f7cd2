#include "geom/mesh.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>

#include "base/file.h"
#include "base/module.h"
#include "base/parallel.h"
#include "geom/mesh_import_module.h"

namespace hfrt::geom {

Box TriangleMesh::bounds() const {
  Box b;
  for (Vec3 v : vertices) b.extend(v);
  return b;
}

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

Error located(const std::string& path, size_t line, const std::string& what) {
  return Error{path + ":" + std::to_string(line) + ": " + what};
}

// Splits a line into whitespace-separated tokens, dropping a trailing '#' comment.
std::vector<std::string> tokens_of(const std::string& line) {
  std::vector<std::string> out;
  std::string s = line.substr(0, line.find('#'));
  std::istringstream is(s);
  std::string tok;
  while (is >> tok) out.push_back(tok);
  return out;
}

// A whole token [s, s + len) as a real (strtod accepts "nan" and "inf": the caller checks
// finiteness). Parsed where it stands: the token must be followed by a character strtod stops
// at (whitespace, '#', the string's terminating NUL), as a token of a line always is.
std::optional<double> parse_real(const char* s, size_t len) {
  // std::from_chars first (3-5x faster than strtod: no locale, no errno); strtod for what it
  // alone accepts (a leading '+', hexadecimal). Both round correctly, so the value is the same.
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s, s + len, v);
  if (ec == std::errc() && ptr == s + len) return v;
  char* end = nullptr;
  v = std::strtod(s, &end);
  if (end == s || end != s + len) return std::nullopt;
  return v;
}
std::optional<double> parse_real(const std::string& tok) {
  return parse_real(tok.c_str(), tok.size());
}

// A whole token as an integer; out of long long's range is malformed too (strtoll would
// saturate, and a count of LLONG_MAX overflowed the checks below: found by fuzz/mesh_fuzz.cpp).
std::optional<long long> parse_int(const char* s, size_t len) {
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s, s + len, v);  // as parse_real: the fast path
  if (ec == std::errc() && ptr == s + len) return v;
  if (ec == std::errc::result_out_of_range) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  v = std::strtoll(s, &end, 10);
  if (end == s || end != s + len || errno == ERANGE) return std::nullopt;
  return v;
}
std::optional<long long> parse_int(const std::string& tok) {
  return parse_int(tok.c_str(), tok.size());
}

// std::isspace of the "C" locale, inline: a call per character was a tenth of the load.
inline bool off_space(char ch) {
  return ch == ' ' || (ch >= '\t' && ch <= '\r');
}

/// The next line of an OFF text at *p (*p is moved past it; the last line may lack its '\n'):
/// the whole line, and in `tok` its tokens before any '#' comment (pointers into the text, so
/// that numbers are parsed where they stand).
std::string_view next_off_line(const char** p, const char* end,
                               std::vector<std::string_view>* tok) {
  const char* eol = static_cast<const char*>(std::memchr(*p, '\n', size_t(end - *p)));
  if (!eol) eol = end;
  const char* hash = static_cast<const char*>(std::memchr(*p, '#', size_t(eol - *p)));
  const char* stop = hash ? hash : eol;
  tok->clear();
  for (const char* q = *p; q < stop;) {
    while (q < stop && off_space(*q)) ++q;
    if (q == stop) break;
    const char* t = q;
    while (q < stop && !off_space(*q)) ++q;
    tok->emplace_back(t, size_t(q - t));
  }
  const std::string_view line(*p, size_t(eol - *p));
  *p = eol + 1;
  return line;
}

/// The lines of an OFF body [begin, end) parsed from content line `first_content` on (a content
/// line has a token before any '#'; content line c < nv is a vertex, then nf faces; the rest is
/// not read). `first_line` is the file line number of the first line. Stops at the first error.
struct OffBody {
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  uint64_t triangle_count = 0;  ///< fan triangles, also those over the limit (not kept)
  long long content = 0;        ///< content lines read (up to the last vertex or face needed)
  size_t lines = 0;             ///< lines read
  std::optional<Error> error;
};

void parse_off_body(const std::string& path, const char* p, const char* end, size_t first_line,
                    long long first_content, long long nv, long long nf, uint64_t max,
                    OffBody* out) {
  std::vector<std::string_view> tok;
  auto token = [&](size_t k) { return std::string(tok[k]); };
  size_t lineno = first_line - 1;
  long long c = first_content;
  while (p < end && c < nv + nf) {
    ++lineno;
    ++out->lines;
    next_off_line(&p, end, &tok);
    if (tok.empty()) continue;
    ++out->content;
    if (c++ < nv) {
      if (tok.size() < 3) {
        out->error = located(path, lineno, "a vertex needs 3 coordinates");
        return;
      }
      Vec3 v;
      for (int k = 0; k < 3; ++k) {
        const std::optional<double> x = parse_real(tok[k].data(), tok[k].size());
        if (!x) {
          out->error = located(path, lineno, "malformed coordinate '" + token(k) + "'");
          return;
        }
        if (!std::isfinite(*x) || !std::isfinite(static_cast<float>(*x))) {
          out->error = located(path, lineno, "non-finite coordinate '" + token(k) + "'");
          return;
        }
        v[k] = static_cast<float>(*x);
      }
      out->vertices.push_back(v);
      continue;
    }
    auto n = parse_int(tok[0].data(), tok[0].size());
    if (!n || *n < 1) {
      out->error = located(path, lineno, "malformed face size '" + token(0) + "'");
      return;
    }
    if (*n > static_cast<long long>(tok.size()) - 1) {
      out->error = located(path, lineno, "a face of " + token(0) + " vertices lists fewer indices");
      return;
    }
    uint32_t idx[3] = {0, 0, 0};
    for (long long k = 1; k <= *n; ++k) {
      const std::optional<long long> index = parse_int(tok[k].data(), tok[k].size());
      if (!index) {
        out->error = located(path, lineno, "malformed vertex index '" + token(k) + "'");
        return;
      }
      const long long i = *index;
      if (i < 0 || i >= nv) {
        out->error =
            located(path, lineno,
                    "vertex index " + token(k) + " out of range 0.." + std::to_string(nv - 1));
        return;
      }
      // A fan: (v0, v[k-1], v[k]) for k >= 3.
      if (k == 1) {
        idx[0] = uint32_t(i);
      } else if (k == 2) {
        idx[2] = uint32_t(i);
      } else {
        idx[1] = idx[2];
        idx[2] = uint32_t(i);
        // Over the limit, the rest is only counted (for the message), not kept.
        if (++out->triangle_count <= max) out->triangles.push_back({idx[0], idx[1], idx[2]});
      }
    }
  }
}

}  // namespace

// A text OFF file, read here rather than by Assimp (which reports malformed numbers without a
// line, accepts out-of-range indices, and took 0.12-0.15 s for the 52000-triangle armadillo
// against 0.028 s here): every error is located. The lines are scanned in place, numbers
// parsed where they stand (parse_real, parse_int; a token ends at whitespace or '#'). Polygons
// become fans (v0, vk, vk+1), as Assimp's triangulation of a convex polygon; faces of one or two
// vertices (points and lines) are dropped, as the Assimp path drops them. COFF/NOFF/... headers and
// extra columns (colours, normals) are accepted and ignored.
Result<TriangleMesh> parse_off(const std::string& path, const std::string& text,
                               const Limits& limits, size_t parallel_min_bytes) {
  TriangleMesh mesh;
  mesh.source = path;
  const uint64_t max = static_cast<uint64_t>(limits.max_mesh_triangles);
  const char* p = text.c_str();
  const char* const end = p + text.size();
  size_t lineno = 0;
  // The header and the counts.
  bool have_header = false;
  long long nv = -1, nf = 0;
  std::vector<std::string_view> tok;
  while (p < end && nv < 0) {
    ++lineno;
    const std::string_view line = next_off_line(&p, end, &tok);
    if (tok.empty()) continue;
    size_t first = 0;
    if (!have_header) {
      const std::string h(tok[0]);
      if (h.size() < 3 || h.substr(h.size() - 3) != "OFF")
        return located(path, lineno, "expected the OFF header, found '" + h + "'");
      have_header = true;
      if (tok.size() == 1) continue;
      first = 1;
    }
    if (tok.size() - first < 2) return located(path, lineno, "expected '#vertices #faces #edges'");
    auto a = parse_int(tok[first].data(), tok[first].size()),
         b = parse_int(tok[first + 1].data(), tok[first + 1].size());
    if (!a || !b || *a < 0 || *b < 0)
      return located(path, lineno, "malformed vertex/face counts '" + std::string(line) + "'");
    nv = *a;
    nf = *b;
    if (nf == 0) return located(path, lineno, "empty mesh (the header declares no faces)");
  }
  if (!have_header) return Error{path + ": empty file (no OFF header)"};
  if (nv < 0) return located(path, lineno, "missing vertex/face counts");
  // The body: in parallel chunks of whole lines for a large file, each parsed from its first
  // content line's index (counted in a first pass); the first error in file order wins, as
  // in one pass.
  const char* body = std::min(p, end);
  const size_t bytes = size_t(end - body);
  // Chunks of ~256 KiB (at least 2, at most 64), fixed by the size alone: the same chunks on
  // any number of threads.
  const size_t nchunks = bytes >= parallel_min_bytes ? std::clamp<size_t>(bytes >> 18, 2, 64) : 1;
  std::vector<const char*> cut(nchunks + 1, end);
  cut[0] = body;
  for (size_t k = 1; k < nchunks; ++k) {
    const char* at = body + bytes / nchunks * k;
    const char* nl = static_cast<const char*>(std::memchr(at, '\n', size_t(end - at)));
    cut[k] = std::max(cut[k - 1], nl ? nl + 1 : end);
  }
  std::vector<size_t> first_line(nchunks + 1, lineno + 1);
  std::vector<long long> first_content(nchunks + 1, 0);
  if (nchunks > 1) {
    std::vector<size_t> lines(nchunks, 0);
    std::vector<long long> content(nchunks, 0);
    par::parallel_for(nchunks, 1, [&](size_t k, size_t) {
      for (const char* q = cut[k]; q < cut[k + 1];) {
        const char* eol = static_cast<const char*>(std::memchr(q, '\n', size_t(cut[k + 1] - q)));
        if (!eol) eol = cut[k + 1];
        ++lines[k];
        for (const char* r = q; r < eol && *r != '#'; ++r) {
          if (!off_space(*r)) {
            ++content[k];
            break;
          }
        }
        q = eol + 1;
      }
    });
    for (size_t k = 0; k < nchunks; ++k) {
      first_line[k + 1] = first_line[k] + lines[k];
      first_content[k + 1] = first_content[k] + content[k];
    }
  }
  std::vector<OffBody> parts(nchunks);
  // Reserve no more than the file can hold (a header may lie).
  if (nchunks == 1) {
    parts[0].vertices.reserve(size_t(std::min<long long>(nv, (long long)text.size() / 6)));
    parts[0].triangles.reserve(size_t(std::min<long long>(nf, (long long)text.size() / 8)));
  }
  par::parallel_for(nchunks, 1, [&](size_t k, size_t) {
    parse_off_body(path, cut[k], cut[k + 1], first_line[k], first_content[k], nv, nf, max,
                   &parts[k]);
  });
  long long content = 0;
  uint64_t triangles = 0;
  size_t vcount = 0, tcount = 0;
  lineno = first_line[0] - 1;
  for (const OffBody& part : parts) {
    if (part.error) return *part.error;
    content += part.content;
    lineno += part.lines;
    triangles += part.triangle_count;
    vcount += part.vertices.size();
    tcount += part.triangles.size();
  }
  if (content < nv)
    return located(
        path, lineno,
        "file ends after " + std::to_string(content) + " of " + std::to_string(nv) + " vertices");
  if (content < nv + nf)
    return located(
        path, lineno,
        "file ends after " + std::to_string(content - nv) + " of " + std::to_string(nf) + " faces");
  if (triangles > max)
    return Error{path + ": " + std::to_string(triangles) + " triangles, more than the limit of " +
                     std::to_string(max),
                 limit_hint("max_mesh_triangles")};
  if (uint64_t(nv) > max)
    return Error{path + ": " + std::to_string(nv) + " vertices, more than the limit of " +
                     std::to_string(max),
                 limit_hint("max_mesh_triangles")};
  if (nchunks == 1) {
    mesh.vertices = std::move(parts[0].vertices);
    mesh.triangles = std::move(parts[0].triangles);
  } else {
    mesh.vertices.reserve(vcount);
    mesh.triangles.reserve(tcount);
    for (OffBody& part : parts) {
      mesh.vertices.insert(mesh.vertices.end(), part.vertices.begin(), part.vertices.end());
      mesh.triangles.insert(mesh.triangles.end(), part.triangles.begin(), part.triangles.end());
    }
  }
  return mesh;
}

namespace {

// Line-located checks of a text OBJ file: vertex coordinates and face indices (1-based, or
// negative = relative to the last vertex so far, in the forms i, i/j, i//k, i/j/k).
std::optional<Error> precheck_obj(const std::string& path, const std::string& text) {
  std::istringstream in(text);
  std::string line;
  size_t lineno = 0;
  long long nv = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::vector<std::string> tok = tokens_of(line);
    if (tok.empty()) continue;
    if (tok[0] == "v") {
      if (tok.size() < 4) return located(path, lineno, "a vertex needs 3 coordinates");
      for (int k = 1; k <= 3; ++k) {
        auto v = parse_real(tok[k]);
        if (!v) return located(path, lineno, "malformed coordinate '" + tok[k] + "'");
        if (!std::isfinite(*v) || !std::isfinite(static_cast<float>(*v)))
          return located(path, lineno, "non-finite coordinate '" + tok[k] + "'");
      }
      ++nv;
    } else if (tok[0] == "f") {
      if (tok.size() < 4) return located(path, lineno, "a face needs at least 3 vertices");
      for (size_t k = 1; k < tok.size(); ++k) {
        std::string first = tok[k].substr(0, tok[k].find('/'));
        auto idx = parse_int(first);
        if (!idx) return located(path, lineno, "malformed vertex index '" + tok[k] + "'");
        long long i = *idx < 0 ? nv + *idx + 1 : *idx;
        if (*idx == 0 || i < 1 || i > nv)
          return located(path, lineno,
                         "vertex index " + first + " out of range 1.." + std::to_string(nv) +
                             " (vertices defined so far)");
      }
    }
  }
  return std::nullopt;
}

// Bytes of a PLY scalar type; 0 for a name that is not one.
size_t ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// A PLY property as the body checks need it.
struct PlyProperty {
  size_t size = 0;         // a scalar's bytes, or a list item's
  size_t count_size = 0;   // a list: the bytes of its count; 0 for a scalar
  bool is_signed = true;   // the (item) type is signed
  bool is_integer = true;  // the (item) type is an integer type
};
struct PlyElement {
  std::string name;
  unsigned long long count = 0;
  std::vector<PlyProperty> properties;
};

// The body of an ASCII PLY (from byte `body`, line `lineno` + 1): one element a line, every
// property a number, list counts non-negative integers, face indices in range. Assimp's ASCII
// reader takes garbage without a word and then aborts on an internal assertion
// (TriangulateProcess.cpp: numOut != pMesh->mNumFaces; found by fuzz/mesh_fuzz.cpp), or
// leaks; these checks also give the line of the problem.
std::optional<Error> precheck_ply_ascii_body(const std::string& path, const std::string& text,
                                             size_t body, size_t lineno,
                                             const std::vector<PlyElement>& elements) {
  unsigned long long vertices = 0;
  for (const PlyElement& e : elements)
    if (e.name == "vertex") vertices = e.count;
  size_t pos = body;
  for (const PlyElement& e : elements) {
    if (e.properties.empty()) continue;
    for (unsigned long long i = 0; i < e.count; ++i) {
      std::vector<std::string> tok;
      while (tok.empty() && pos < text.size()) {  // blank lines are skipped
        size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        tok = tokens_of(text.substr(pos, end - pos));
        pos = end + 1;
        ++lineno;
      }
      const std::string what =
          e.name + " " + std::to_string(i + 1) + " of " + std::to_string(e.count);
      if (tok.empty()) return located(path, lineno, "truncated PLY: " + what + " is missing");
      size_t t = 0;
      auto number = [&](std::optional<double>* v) {
        *v = t < tok.size() ? parse_real(tok[t]) : std::nullopt;
        ++t;
        return v->has_value();
      };
      for (const PlyProperty& p : e.properties) {
        std::optional<double> v;
        if (!number(&v)) return located(path, lineno, "malformed or missing number in " + what);
        if (!p.count_size) continue;
        if (*v < 0 || *v != std::floor(*v))
          return located(path, lineno, "bad list length " + tok[t - 1] + " in " + what);
        if (*v == 0 && e.name == "face") return located(path, lineno, what + " has no vertices");
        if (*v > static_cast<double>(tok.size() - t))
          return located(path, lineno, "list of " + tok[t - 1] + " values is cut short in " + what);
        for (long long k = static_cast<long long>(*v); k > 0; --k) {
          if (!number(&v)) return located(path, lineno, "malformed or missing number in " + what);
          if (e.name == "face" &&
              (*v < 0 || *v != std::floor(*v) || *v >= static_cast<double>(vertices)))
            return located(path, lineno,
                           "vertex index " + tok[t - 1] + " out of range 0.." +
                               std::to_string(vertices) + " - 1 in " + what);
        }
      }
      if (t != tok.size()) return located(path, lineno, "extra values in " + what);
    }
  }
  return std::nullopt;
}

// A PLY file must be complete before Assimp sees it: Assimp 5.2 loops forever on a header
// without "end_header", and its binary reader reads past the end of a body shorter than the
// header's element counts say (then crashes on the garbage indices; found by
// fuzz/mesh_fuzz.cpp). So the header is parsed (format, elements, property types; a line
// that is none of these is an error) and the body checked: a binary one is walked, list counts
// included, to check that every element fits in the file and that every face has vertices in
// range; an ASCII one line by line (precheck_ply_ascii_body).
std::optional<Error> precheck_ply(const std::string& path, const std::string& text) {
  std::vector<PlyElement> elements;
  bool binary = false, big_endian = false;
  size_t pos = 0, lineno = 0, body = std::string::npos;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (lineno == 1) {
      if (line != "ply") return located(path, 1, "expected the PLY magic 'ply'");
      continue;
    }
    if (line == "end_header") {
      body = std::min(pos, text.size());
      break;
    }
    if (lineno > 1000 || pos > 65536) break;
    const std::vector<std::string> tok = tokens_of(line);
    if (tok.empty()) continue;
    if (tok[0] == "format" && tok.size() >= 2) {
      binary = tok[1] != "ascii";
      big_endian = tok[1] == "binary_big_endian";
    } else if (tok[0] == "element") {
      std::optional<long long> n = tok.size() == 3 ? parse_int(tok[2]) : std::nullopt;
      if (!n || *n < 0) return located(path, lineno, "malformed PLY element line '" + line + "'");
      elements.push_back({tok[1], static_cast<unsigned long long>(*n), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) return located(path, lineno, "PLY property before any element");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.count_size = ply_type_size(tok[2]);
        p.size = ply_type_size(tok[3]);
        if (p.count_size == 0 || p.size == 0)
          return located(path, lineno, "unknown PLY list type in '" + line + "'");
      } else {
        p.size = tok.size() == 3 ? ply_type_size(tok[1]) : 0;
        if (p.size == 0) return located(path, lineno, "malformed PLY property '" + line + "'");
      }
      p.is_signed = tok[tok.size() - 2].find('u') == std::string::npos;  // int8, not uint8
      p.is_integer =
          tok[tok.size() - 2].find("float") == std::string::npos && tok[tok.size() - 2] != "double";
      elements.back().properties.push_back(p);
    } else if (tok[0] != "comment" && tok[0] != "obj_info") {
      // What Assimp would make of it is unknown, and the body checks below would then
      // disagree with its reading of the body.
      return located(path, lineno, "unknown PLY header line '" + line + "'");
    }
  }
  if (body == std::string::npos) return Error{path + ": malformed PLY header (no end_header line)"};
  if (!binary) return precheck_ply_ascii_body(path, text, body, lineno, elements);
  unsigned long long vertices = 0;
  for (const PlyElement& e : elements)
    if (e.name == "vertex") vertices = e.count;
  // The unsigned value of the `size` bytes at `at` (the file's byte order).
  auto read = [&](size_t at, size_t size) {
    unsigned long long n = 0;
    for (size_t b = 0; b < size; ++b) {
      const size_t k = big_endian ? b : size - 1 - b;
      n = (n << 8) | static_cast<unsigned char>(text[at + k]);
    }
    return n;
  };
  // Every property takes at least one byte, so this walk ends within text.size() steps.
  size_t at = body;
  for (const PlyElement& e : elements) {
    if (e.properties.empty()) continue;
    for (unsigned long long i = 0; i < e.count; ++i) {
      const std::string what =
          e.name + " " + std::to_string(i + 1) + " of " + std::to_string(e.count);
      for (const PlyProperty& p : e.properties) {
        size_t need = p.count_size ? p.count_size : p.size;
        unsigned long long n = 0;
        if (p.count_size && text.size() - at >= p.count_size) {
          n = read(at, p.count_size);
          need = n > (text.size() / p.size) ? text.size() + 1 : p.count_size + n * p.size;
        }
        if (text.size() - at < need)
          return Error{path + ": truncated binary PLY: " + what + " runs past the end of the file"};
        if (p.count_size && e.name == "face") {
          // Assimp aborts on a face without vertices (an assertion in its triangulation).
          if (n == 0) return Error{path + ": binary PLY: " + what + " has no vertices"};
          for (unsigned long long k = 0; k < n && p.is_integer; ++k) {
            unsigned long long v = read(at + p.count_size + k * p.size, p.size);
            const bool negative = p.is_signed && (v >> (8 * p.size - 1)) != 0;
            if (negative || v >= vertices)
              return Error{path + ": binary PLY: " + what + " has a vertex index out of range"};
          }
        }
        at += need;
      }
    }
  }
  return std::nullopt;
}

bool is_degenerate(const TriangleMesh& m, const std::array<uint32_t, 3>& t) {
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
  // Exact test in double: products of floats are exact there, so a zero cross product means
  // the three corners are (nearly exactly) collinear.
  auto d = [&](int k) {
    Vec3 v = m.vertices[t[k]];
    return std::array<double, 3>{v.x, v.y, v.z};
  };
  auto a = d(0), b = d(1), c = d(2);
  double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double n0 = e1[1] * e2[2] - e1[2] * e2[1];
  double n1 = e1[2] * e2[0] - e1[0] * e2[2];
  double n2 = e1[0] * e2[1] - e1[1] * e2[0];
  return n0 == 0 && n1 == 0 && n2 == 0;
}

}  // namespace

Result<TriangleMesh> finish_mesh(TriangleMesh mesh, std::vector<uint64_t>* tags) {
  HFRT_CHECK(!tags || tags->size() == mesh.triangles.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!is_finite(mesh.vertices[i]))
      return Error{mesh.source + ": vertex " + std::to_string(i + 1) +
                   " has a non-finite coordinate"};
  }
  std::vector<std::array<uint32_t, 3>> kept;
  kept.reserve(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    for (int k = 0; k < 3; ++k) {
      if (t[k] >= mesh.vertices.size())
        return Error{mesh.source + ": triangle " + std::to_string(i + 1) + " uses vertex " +
                     std::to_string(t[k] + 1) + " of " + std::to_string(mesh.vertices.size())};
    }
    if (is_degenerate(mesh, t)) {
      ++mesh.degenerate_skipped;
      continue;
    }
    if (tags) (*tags)[kept.size()] = (*tags)[i];
    kept.push_back(t);
  }
  if (kept.empty()) {
    std::string why = mesh.triangles.empty() ? "no triangles"
                                             : "all " + std::to_string(mesh.triangles.size()) +
                                                   " triangles are degenerate";
    return Error{mesh.source + ": empty mesh (" + why + ")"};
  }
  mesh.triangles = std::move(kept);
  if (tags) tags->resize(mesh.triangles.size());
  return mesh;
}

Error file_error(const std::string& path, const Error& read_error) {
  if (read_error.message.rfind(path + ": is ", 0) == 0) return read_error;
  return Error{path + ": cannot read: " + read_error.message};
}

Result<TriangleMesh> load_mesh(const std::string& path, const Limits& limits) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return Error{path + ": no such file"};
  if (std::filesystem::is_directory(path, ec)) return Error{path + ": is a directory"};
  Result<std::string> text =
      read_file_limited(path, limits.max_mesh_bytes, /*regular_only=*/true, "max_mesh_bytes");
  if (!text) return file_error(path, text.error());
  const std::string ext = lower_extension(path);
  if (ext != ".off" && ext != ".obj" && ext != ".ply" && ext != ".stl")
    return Error{path + ": unknown mesh format '" + ext + "' (expected .off, .obj, .ply or .stl)"};
  if (text->empty()) return Error{path + ": empty file"};
  // Text formats get line-located checks before Assimp sees them.
  if (ext == ".off") {
    Result<TriangleMesh> mesh = parse_off(path, *text, limits);
    if (!mesh) return mesh.error();
    return finish_mesh(std::move(mesh).value());
  }
  if (ext == ".obj") {
    if (auto err = precheck_obj(path, *text)) return *err;
  } else if (ext == ".ply") {
    if (auto err = precheck_ply(path, *text)) return *err;
  }

  auto module = module_table<mesh_import::Module>("meshimport", mesh_import::kEntrySymbol,
                                                  mesh_import::kAbiVersion);
  if (!module.ok()) return Error{path + ": " + module.error().message, module.error().hint};
  mesh_import::Imported imported;
  std::string why;
  const uint64_t max = static_cast<uint64_t>(limits.max_mesh_triangles);
  if (!(*module)->import(text->data(), text->size(), ext.c_str() + 1, max, &imported, &why))
    return Error{path + ": malformed mesh: " + why};
  if (imported.over_limit) {
    const bool faces = imported.num_faces > max;
    return Error{path + ": " + std::to_string(faces ? imported.num_faces : imported.num_vertices) +
                     (faces ? " triangles" : " vertices") + ", more than the limit of " +
                     std::to_string(max),
                 limit_hint("max_mesh_triangles")};
  }
  TriangleMesh mesh;
  mesh.source = path;
  mesh.vertices = std::move(imported.vertices);
  mesh.triangles = std::move(imported.triangles);
  return finish_mesh(std::move(mesh));
}

Result<TriangleMesh> mesh_from_arrays(std::span<const double> v, std::span<const double> t,
                                      const std::string& what) {
  if (v.size() % 3 != 0)
    return Error{what + ": the vertex array has " + std::to_string(v.size()) +
                 " numbers, not a multiple of 3"};
  if (t.size() % 3 != 0)
    return Error{what + ": the triangle array has " + std::to_string(t.size()) +
                 " numbers, not a multiple of 3"};
  TriangleMesh mesh;
  mesh.source = what;
  const size_t nv = v.size() / 3;
  for (size_t i = 0; i < nv; ++i) {
    Vec3 p{static_cast<float>(v[3 * i]), static_cast<float>(v[3 * i + 1]),
           static_cast<float>(v[3 * i + 2])};
    if (!is_finite(p))
      return Error{what + ": vertex " + std::to_string(i + 1) + " has a non-finite coordinate"};
    mesh.vertices.push_back(p);
  }
  for (size_t i = 0; i < t.size() / 3; ++i) {
    std::array<uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      double idx = t[3 * i + k];
      if (!(idx >= 1 && idx <= static_cast<double>(nv)) || idx != std::floor(idx)) {
        std::ostringstream os;
        os << what << ": triangle " << i + 1 << " has vertex index " << idx
           << ", expected an integer in 1.." << nv;
        return Error{os.str()};
      }
      tri[k] = static_cast<uint32_t>(idx) - 1;
    }
    mesh.triangles.push_back(tri);
  }
  return finish_mesh(std::move(mesh));
}

}  // namespace hfrt::geom
