// One device check case (check_case.h); the file format is docs/gpu.md, "Device check cases".
#include "tools/gpu_runner/check_case.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <vector>

#include "base/file.h"
#include "gpu/check_grid.h"
#include "gpu/kernel_abi.h"

namespace hfrt::gpu_runner {

namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little,
              "the case files hold little-endian floats, read as they are");

int64_t ulp_distance(float a, float b) {
  const bool nan_a = std::isnan(a), nan_b = std::isnan(b);
  if (nan_a || nan_b) return nan_a && nan_b ? 0 : -1;
  auto ordered = [](float f) {
    const uint32_t bits = std::bit_cast<uint32_t>(f);
    return (bits & 0x80000000u) ? -int64_t{bits & 0x7fffffffu} : int64_t{bits};
  };
  const int64_t d = ordered(a) - ordered(b);
  return d < 0 ? -d : d;
}

UlpStats compare_ulps(const std::vector<float>& gpu, const std::vector<float>& expect) {
  UlpStats s;
  for (size_t i = 0; i < gpu.size(); ++i) {
    int64_t d = ulp_distance(gpu[i], expect[i]);
    if (d < 0)
      ++s.nan_mismatch;
    else if (d > s.max_ulp) {
      s.max_ulp = d;
      s.worst = i;
    }
  }
  return s;
}

static bool covered(const float* px) {
  return px[3] > 0.5f;
}

ImageStats compare_images(const std::vector<float>& gpu, const std::vector<float>& expect,
                          int64_t pixels) {
  constexpr int k = gpu::kRenderFloatsPerPixel;
  ImageStats s;
  int64_t differ = 0;
  double sum = 0;
  for (int64_t p = 0; p < pixels; ++p) {
    const float* a = &gpu[static_cast<size_t>(p * k)];
    const float* b = &expect[static_cast<size_t>(p * k)];
    for (int c = 0; c < k; ++c) s.nan_mismatch += std::isnan(a[c]) != std::isnan(b[c]);
    if (covered(a) != covered(b)) {
      ++differ;
      continue;
    }
    if (!covered(a)) continue;
    ++s.both;
    for (int c = 0; c < 3; ++c) {
      const double d = std::fabs(double{a[c]} - double{b[c]});
      if (std::isnan(d)) continue;  // counted as a NaN mismatch, or NaN in both
      s.max_rgb = std::max(s.max_rgb, d);
      sum += d;
    }
  }
  s.cover_diff = pixels ? static_cast<double>(differ) / static_cast<double>(pixels) : 0.0;
  s.mean_rgb = s.both ? sum / (3.0 * static_cast<double>(s.both)) : 0.0;
  return s;
}

namespace {

/// "1.5", "nan", "-inf": enough digits to tell floats apart.
std::string fmt_float(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string fmt_ms(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

/// The message on one line (a JIT log has several).
std::string one_line(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  std::string out;
  for (char c : s) {
    if (c == '\n')
      out += " | ";
    else if (c != '\r')
      out += c;
  }
  return out;
}

/// case.txt: `key=value` lines; blank lines and lines starting with '#' are skipped.
struct CaseText {
  std::map<std::string, std::string> values;

  Result<int64_t> integer(const std::string& key, int64_t min) const {
    auto it = values.find(key);
    if (it == values.end()) return Error{"case.txt has no " + key + "="};
    const std::string& v = it->second;
    int64_t x = 0;
    auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
    if (ec != std::errc() || end != v.data() + v.size()) {
      return Error{"case.txt: " + key + "=" + v + " is not an integer"};
    }
    if (x < min)
      return Error{"case.txt: " + key + "=" + v + " (at least " + std::to_string(min) + ")"};
    return x;
  }
};

Result<CaseText> read_case_text(const fs::path& dir) {
  auto text = read_file((dir / "case.txt").string());
  if (!text) return text.error();
  CaseText c;
  size_t pos = 0;
  int line_no = 0;
  const std::string& t = text.value();
  while (pos < t.size()) {
    size_t end = t.find('\n', pos);
    if (end == std::string::npos) end = t.size();
    std::string line = t.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) {
      line.pop_back();
    }
    if (line.empty() || line[0] == '#') continue;
    size_t eq = line.find('=');
    if (eq == std::string::npos || eq == 0) {
      return Error{"case.txt line " + std::to_string(line_no) + ": expected key=value, got '" +
                   line + "'"};
    }
    std::string key = line.substr(0, eq);
    if (!c.values.emplace(key, line.substr(eq + 1)).second) {
      return Error{"case.txt line " + std::to_string(line_no) + ": " + key + "= given twice"};
    }
  }
  return c;
}

/// A whole file of `count` little-endian floats; the error names the file and both sizes.
Result<std::vector<float>> read_floats(const fs::path& dir, const char* file, int64_t count) {
  auto bytes = read_file((dir / file).string());
  if (!bytes) return bytes.error();
  const size_t want = static_cast<size_t>(count) * sizeof(float);
  if (bytes->size() != want) {
    return Error{std::string(file) + " has " + std::to_string(bytes->size()) + " bytes, expected " +
                 std::to_string(want) + " (" + std::to_string(count) + " floats)"};
  }
  std::vector<float> v(static_cast<size_t>(count));
  if (want) std::memcpy(v.data(), bytes->data(), want);
  return v;
}

/// A device buffer holding `data` (or `bytes` zero bytes when data is null).
Result<gpu::DeviceBuffer> upload(gpu::CudaDevice& device, const void* data, size_t bytes,
                                 const char* what) {
  auto buf = gpu::DeviceBuffer::allocate(device, bytes);
  if (!buf) return Error{std::string(what) + ": " + buf.error().message};
  std::vector<char> zeros;
  if (!data) {
    zeros.assign(bytes, 0);
    data = zeros.data();
  }
  if (auto r = buf->upload(data, bytes); !r)
    return Error{std::string(what) + ": " + r.error().message};
  return std::move(buf).value();
}

struct Timing {
  double min = 0, median = 0;
};

/// Launches `entry` `repeat` times; the minimum and the median of the kernel times.
Result<Timing> time_launches(gpu::CudaModule& module, const char* entry, int64_t threads,
                             const std::vector<void*>& args, int repeat) {
  std::vector<double> ms;
  for (int i = 0; i < repeat; ++i) {
    auto t = module.launch(entry, threads, args);
    if (!t) return t.error();
    ms.push_back(*t);
  }
  std::sort(ms.begin(), ms.end());
  const size_t k = ms.size() / 2;
  return Timing{ms.front(), ms.size() % 2 ? ms[k] : 0.5 * (ms[k - 1] + ms[k])};
}

/// Binary PPM (P6) of the r, g, b of each pixel, sRGB-encoded and clamped.
Result<bool> write_ppm(const fs::path& path, const std::vector<float>& image, int width,
                       int height) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return Error{"cannot write '" + path.string() + "': " + std::strerror(errno)};
  out << "P6\n" << width << " " << height << "\n255\n";
  std::vector<unsigned char> row(static_cast<size_t>(width) * 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float* px = &image[(static_cast<size_t>(y) * width + x) * gpu::kRenderFloatsPerPixel];
      for (int c = 0; c < 3; ++c) {
        row[static_cast<size_t>(x) * 3 + c] =
            static_cast<unsigned char>(std::lround(linear_to_srgb(px[c]) * 255.0f));
      }
    }
    out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size()));
  }
  out.close();
  if (!out) return Error{"cannot write '" + path.string() + "'"};
  return true;
}

/// What a case produces before the common prefix and the verdict are added.
struct Report {
  std::string fields;  ///< " key=value ..." (leading space)
  int64_t nan_mismatch_host = 0;
};

Result<Report> run_eval(gpu::CudaDevice& device, gpu::CudaModule& module, const fs::path& dir,
                        const CaseText& c, const RunOptions& options) {
  auto n = c.integer("n", 1);
  auto num_inputs = c.integer("num_inputs", 0);
  auto num_params = c.integer("num_params", 0);
  auto num_s = c.integer("num_s", 0);
  for (const auto* r : {&n, &num_inputs, &num_params, &num_s}) {
    if (!*r) return r->error();
  }
  // The points: xs.f32, or `grid=W,H,X0,X1,Y0,Y1,Z` (gpu/check_grid.h).
  Result<std::vector<float>> xs = std::vector<float>{};
  if (auto g = c.values.find("grid"); g != c.values.end()) {
    double v[7];
    if (std::sscanf(g->second.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3],
                    &v[4], &v[5], &v[6]) != 7 ||
        !(v[0] >= 1) || !(v[1] >= 1) || v[0] * v[1] != double(*n)) {
      return Error{"case.txt: grid=" + g->second + " (W,H,X0,X1,Y0,Y1,Z with W*H = n)"};
    }
    xs = gpu::grid_points(int(v[0]), int(v[1]), float(v[2]), float(v[3]), float(v[4]), float(v[5]),
                          float(v[6]), int(*num_inputs));
  } else {
    xs = read_floats(dir, "xs.f32", *num_inputs * *n);
  }
  if (!xs) return xs.error();
  auto a = read_floats(dir, "a.f32", *num_params);
  if (!a) return a.error();
  auto expect_jit = read_floats(dir, "expect_jit.f32", *n);
  if (!expect_jit) return expect_jit.error();
  auto expect_host = read_floats(dir, "expect_host.f32", *n);
  if (!expect_host) return expect_host.error();

  auto xs_buf = upload(device, xs->data(), xs->size() * sizeof(float), "xs");
  if (!xs_buf) return xs_buf.error();
  auto a_buf = upload(device, a->data(), a->size() * sizeof(float), "a");
  if (!a_buf) return a_buf.error();
  auto out_buf = upload(device, nullptr, static_cast<size_t>(*n) * sizeof(float), "out_f");
  if (!out_buf) return out_buf.error();

  int64_t count = *n;
  uint64_t xs_ptr = xs_buf->address(), a_ptr = a_buf->address(), out_ptr = out_buf->address();
  uint64_t out_s_ptr = 0;  // out_s: null, F only
  std::vector<void*> args = {&count, &xs_ptr, &a_ptr, &out_ptr, &out_s_ptr};
  auto timing = time_launches(module, gpu::kEvalEntry, count, args, options.repeat);
  if (!timing) return timing.error();
  std::vector<float> out(static_cast<size_t>(count));
  if (auto r = out_buf->download(out.data(), out.size() * sizeof(float)); !r) {
    return Error{"out_f: " + r.error().message};
  }

  const UlpStats jit = compare_ulps(out, *expect_jit);
  const UlpStats host = compare_ulps(out, *expect_host);
  Report rep;
  rep.nan_mismatch_host = host.nan_mismatch;
  auto worst = [&](const UlpStats& s, const std::vector<float>& expect) {
    return std::to_string(s.worst) + ":" + fmt_float(out[s.worst]) + ":" +
           fmt_float(expect[s.worst]);
  };
  rep.fields = " n=" + std::to_string(count) + " max_ulp_jit=" + std::to_string(jit.max_ulp) +
               " max_ulp_host=" + std::to_string(host.max_ulp) +
               " nan_mismatch_jit=" + std::to_string(jit.nan_mismatch) +
               " nan_mismatch_host=" + std::to_string(host.nan_mismatch) +
               " worst_jit=" + worst(jit, *expect_jit) +
               " worst_host=" + worst(host, *expect_host) + " ms_min=" + fmt_ms(timing->min) +
               " ms_median=" + fmt_ms(timing->median);
  return rep;
}

Result<Report> run_render(gpu::CudaDevice& device, gpu::CudaModule& module, const fs::path& dir,
                          const CaseText& c, const std::string& name, const RunOptions& options) {
  auto width = c.integer("width", 1);
  auto height = c.integer("height", 1);
  auto num_params = c.integer("num_params", 0);
  for (const auto* r : {&width, &height, &num_params}) {
    if (!*r) return r->error();
  }
  auto params = read_file((dir / "params.bin").string());
  if (!params) return params.error();
  if (params->size() != sizeof(gpu::RenderParams)) {
    return Error{"params.bin has " + std::to_string(params->size()) + " bytes, expected " +
                 std::to_string(sizeof(gpu::RenderParams)) + " (sizeof(gpu::RenderParams))"};
  }
  gpu::RenderParams rp;
  std::memcpy(&rp, params->data(), sizeof rp);
  if (rp.width != *width || rp.height != *height) {
    return Error{"params.bin is for " + std::to_string(rp.width) + "x" + std::to_string(rp.height) +
                 " pixels, case.txt says " + std::to_string(*width) + "x" +
                 std::to_string(*height)};
  }
  const int64_t pixels = *width * *height;
  const int64_t floats = pixels * gpu::kRenderFloatsPerPixel;
  auto a = read_floats(dir, "a.f32", *num_params);
  if (!a) return a.error();
  // The expectations: kRenderFloatsPerPixel floats a pixel (format=f32, the default), or
  // 8-bit sRGB + coverage (format=rgba8, gpu::quantize_rgba8), which the GPU's output is
  // then quantized to before comparing.
  std::string format = "f32";
  if (auto f = c.values.find("format"); f != c.values.end()) format = f->second;
  if (format != "f32" && format != "rgba8") {
    return Error{"case.txt: format=" + format + " (f32 or rgba8)"};
  }
  const bool rgba8 = format == "rgba8";
  auto read_rgba8 = [&](const char* file) -> Result<std::vector<float>> {
    auto bytes = read_file((dir / file).string());
    if (!bytes) return bytes.error();
    if (bytes->size() != size_t(pixels) * 4) {
      return Error{std::string(file) + " has " + std::to_string(bytes->size()) +
                   " bytes, expected " + std::to_string(size_t(pixels) * 4) + " (rgba8)"};
    }
    // As kernel-output-shaped floats in 8-bit units / 255, for compare_images.
    std::vector<float> v(size_t(pixels) * gpu::kRenderFloatsPerPixel, 0.0f);
    for (int64_t p = 0; p < pixels; ++p) {
      for (int ch = 0; ch < 4; ++ch) {
        v[size_t(p) * gpu::kRenderFloatsPerPixel + ch] =
            float(static_cast<unsigned char>((*bytes)[size_t(p) * 4 + ch])) / 255.0f;
      }
    }
    return v;
  };
  auto expect_host =
      rgba8 ? read_rgba8("expect_host.rgba8") : read_floats(dir, "expect_host.f32", floats);
  if (!expect_host) return expect_host.error();
  auto expect_cpu =
      rgba8 ? read_rgba8("expect_cpu.rgba8") : read_floats(dir, "expect_cpu.f32", floats);
  if (!expect_cpu) return expect_cpu.error();

  auto p_buf = upload(device, &rp, sizeof rp, "params");
  if (!p_buf) return p_buf.error();
  auto a_buf = upload(device, a->data(), a->size() * sizeof(float), "a");
  if (!a_buf) return a_buf.error();
  auto out_buf = upload(device, nullptr, static_cast<size_t>(floats) * sizeof(float), "out");
  if (!out_buf) return out_buf.error();
  uint64_t p_ptr = p_buf->address(), a_ptr = a_buf->address(), out_ptr = out_buf->address();
  std::vector<void*> args = {&p_ptr, &a_ptr, &out_ptr};
  auto timing = time_launches(module, gpu::kRenderEntry, pixels, args, options.repeat);
  if (!timing) return timing.error();
  std::vector<float> out(static_cast<size_t>(floats));
  if (auto r = out_buf->download(out.data(), out.size() * sizeof(float)); !r) {
    return Error{"out: " + r.error().message};
  }

  std::vector<float> compared = out;
  if (rgba8) {
    for (int64_t p = 0; p < pixels; ++p) {
      float* px = &compared[size_t(p) * gpu::kRenderFloatsPerPixel];
      uint8_t q[4];
      gpu::quantize_rgba8(px, q);
      for (int ch = 0; ch < gpu::kRenderFloatsPerPixel; ++ch)
        px[ch] = ch < 4 ? float(q[ch]) / 255.0f : 0.0f;
    }
  }
  const ImageStats host = compare_images(compared, *expect_host, pixels);
  const ImageStats cpu = compare_images(compared, *expect_cpu, pixels);
  int64_t covered_gpu = 0;
  for (int64_t p = 0; p < pixels; ++p) {
    covered_gpu += covered(&out[static_cast<size_t>(p * gpu::kRenderFloatsPerPixel)]);
  }
  Report rep;
  rep.nan_mismatch_host = host.nan_mismatch;
  auto stats = [](const ImageStats& s, const char* to) {
    const std::string t = to;
    return " cover_diff_" + t + "=" + fmt_float(s.cover_diff) + " both_" + t + "=" +
           std::to_string(s.both) + " max_rgb_" + t + "=" + fmt_float(s.max_rgb) + " mean_rgb_" +
           t + "=" + fmt_float(s.mean_rgb);
  };
  rep.fields = " width=" + std::to_string(*width) + " height=" + std::to_string(*height) +
               " format=" + format + " covered_gpu=" + std::to_string(covered_gpu) +
               stats(host, "host") + stats(cpu, "cpu") +
               " nan_mismatch_host=" + std::to_string(host.nan_mismatch) +
               " ms_min=" + fmt_ms(timing->min) + " ms_median=" + fmt_ms(timing->median);
  if (!options.out_dir.empty()) {
    const fs::path image = options.out_dir / (name + ".ppm");
    if (auto r = write_ppm(image, out, static_cast<int>(*width), static_cast<int>(*height)); !r) {
      return r.error();
    }
    rep.fields += " image=" + image.string();
  }
  return rep;
}

bool valid_name(const std::string& s) {
  return !s.empty() && s != "." && s != ".." && std::all_of(s.begin(), s.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.';
  });
}

}  // namespace

CaseOutcome run_case(gpu::CudaDevice& device, const fs::path& dir, const RunOptions& options) {
  std::string name = dir.filename().string();
  std::string kind = "?";
  auto fail = [&](const std::string& why) {
    return CaseOutcome{false,
                       "case=" + name + " kind=" + kind + " status=fail error=" + one_line(why)};
  };
  auto text = read_case_text(dir);
  if (!text) return fail(text.error().message);
  const CaseText& c = text.value();
  if (auto it = c.values.find("kind"); it != c.values.end()) kind = it->second;
  if (auto it = c.values.find("name"); it != c.values.end()) {
    if (!valid_name(it->second)) {
      return fail("case.txt: name=" + it->second + " (letters, digits, '_', '-' and '.' only)");
    }
    name = it->second;
  }
  if (kind != "eval" && kind != "render") {
    return fail(kind == "?" ? "case.txt has no kind="
                            : "case.txt: kind=" + kind + " (eval or render)");
  }
  auto ptx = read_file((dir / "kernel.ptx").string());
  if (!ptx) return fail(ptx.error().message);
  const auto t0 = std::chrono::steady_clock::now();
  auto module = device.load_ptx(ptx.value());
  const double jit_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!module) return fail(module.error().message);
  auto report = kind == "eval" ? run_eval(device, *module.value(), dir, c, options)
                               : run_render(device, *module.value(), dir, c, name, options);
  if (!report) return fail(report.error().message);
  const bool ok = report->nan_mismatch_host == 0;
  std::string line = "case=" + name + " kind=" + kind + " status=" + (ok ? "ok" : "fail") +
                     report->fields + " jit_ms=" + fmt_ms(jit_ms);
  if (!ok) {
    line += " error=the NaN pattern differs from expect_host at " +
            std::to_string(report->nan_mismatch_host) + " values";
  }
  return CaseOutcome{ok, line};
}

}  // namespace hfrt::gpu_runner
