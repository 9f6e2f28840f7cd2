/* hfrt from C (C99, the stable C API hfrt/hfrt.h), built against an installed hfrt with
 * pkg-config:
 *
 *   cc -std=c99 main.c $(pkg-config --cflags --libs hfrt) -o hfrt_eval_c
 *   echo "1 2 3" | ./hfrt_eval_c MODEL.hf [OBJECT [a1,a2,...]]
 *
 * Reads points (one per line, x[1] x[2] ... ; missing coordinates are 0) from stdin and
 * prints F and s[] of each with 17 significant digits, the format of `hfrt eval` (the
 * install test compares the two byte for byte). With `--render W H OUT.ppm` instead of
 * reading points, ray traces the model into an RGBA buffer and writes a PPM.
 */
#include <hfrt/hfrt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void print_number(double v) {
  if (isnan(v)) {
    fputs("nan", stdout);
  } else {
    printf("%.17g", v);
  }
}

static int fail(const char* what) {
  const char* file = NULL;
  int32_t line = 0, column = 0;
  hfrt_last_error_location(&file, &line, &column);
  fprintf(stderr, "%s failed (%s at %s:%d:%d):\n%s\n", what,
          hfrt_status_name(hfrt_last_error_status()), file, (int)line, (int)column,
          hfrt_last_error_message());
  return 1;
}

static int render(hfrt_model* model, int w, int h, const char* out_path) {
  hfrt_render_options ro;
  float* rgba = malloc(sizeof(float) * 4 * (size_t)w * (size_t)h);
  FILE* out;
  size_t i;
  if (!rgba) return 1;
  hfrt_render_options_init(&ro);
  ro.width = w;
  ro.height = h;
  if (hfrt_render_model(model, &ro, rgba, 4 * (int64_t)w * h) != HFRT_OK) {
    free(rgba);
    return fail("hfrt_render_model");
  }
  out = fopen(out_path, "wb");
  if (!out) {
    free(rgba);
    return 1;
  }
  fprintf(out, "P6\n%d %d\n255\n", w, h);
  for (i = 0; i < (size_t)w * (size_t)h * 4; ++i) {
    if (i % 4 == 3) continue;
    {
      double v = rgba[i] < 0 ? 0 : rgba[i] > 1 ? 1 : rgba[i];
      fputc((int)(255.0 * pow(v, 1 / 2.2) + 0.5), out);
    }
  }
  fclose(out);
  free(rgba);
  return 0;
}

int main(int argc, char** argv) {
  hfrt_compile_options opt;
  hfrt_model* model = NULL;
  int32_t k = 0, na = 0, ns = 0;
  double* params = NULL;
  size_t cap = 1024, n = 0, i;
  double *rows, *xs, *f, *s;
  char line[4096];
  int rc = 0;
  int32_t c;

  if (argc < 2) {
    fprintf(stderr, "usage: %s MODEL.hf [OBJECT [a1,a2,...]] [--render W H OUT.ppm]\n", argv[0]);
    return 2;
  }
  hfrt_compile_options_init(&opt);
  if (argc > 2 && strcmp(argv[2], "--render") != 0) opt.object = argv[2];
  if (argc > 3 && strcmp(argv[3], "--render") != 0) {
    const char* p = argv[3];
    params = malloc(sizeof(double) * 64);
    while (*p && opt.num_params < 64) {
      char* end;
      params[opt.num_params++] = strtod(p, &end);
      p = *end == ',' ? end + 1 : end;
      if (end == p && *p) break;
    }
    opt.params = params;
  }
  if (hfrt_model_compile_file(argv[1], &opt, &model) != HFRT_OK) {
    free(params);
    return fail("hfrt_model_compile_file");
  }
  free(params);
  hfrt_model_info(model, &k, &na, &ns);
  for (c = 0; c < hfrt_model_diagnostic_count(model); ++c) {
    hfrt_diagnostic d;
    hfrt_model_diagnostic(model, c, &d);
    fprintf(stderr, "%s:%d:%d: warning: %s\n", d.file, (int)d.line, (int)d.column, d.message);
  }
  for (c = 2; c + 3 < argc; ++c) {
    if (strcmp(argv[c], "--render") == 0) {
      rc = render(model, atoi(argv[c + 1]), atoi(argv[c + 2]), argv[c + 3]);
      hfrt_model_free(model);
      return rc;
    }
  }

  rows = malloc(sizeof(double) * cap * (size_t)(k > 0 ? k : 1));
  while (fgets(line, sizeof line, stdin)) {
    char* p = line;
    int32_t j;
    while (*p == ' ' || *p == '\t') ++p;
    if (*p == '\n' || *p == '\r' || *p == '\0' || *p == '#') continue;
    if (n == cap) {
      cap *= 2;
      rows = realloc(rows, sizeof(double) * cap * (size_t)(k > 0 ? k : 1));
    }
    for (j = 0; j < k; ++j) {
      char* end;
      double v = strtod(p, &end);
      rows[n * (size_t)k + (size_t)j] = end == p ? 0.0 : v;
      p = end;
    }
    ++n;
  }
  /* Rows to a structure of arrays: coordinate j of point i at xs[j*n + i]. */
  xs = malloc(sizeof(double) * (n * (size_t)k + 1));
  f = malloc(sizeof(double) * (n + 1));
  s = malloc(sizeof(double) * (n * (size_t)ns + 1));
  for (i = 0; i < n; ++i) {
    int32_t j;
    for (j = 0; j < k; ++j) xs[(size_t)j * n + i] = rows[i * (size_t)k + (size_t)j];
  }
  if (hfrt_model_eval_f64(model, (int64_t)n, xs, (int64_t)(n * (size_t)k), f, (int64_t)n, s,
                          (int64_t)(n * (size_t)ns)) != HFRT_OK) {
    rc = fail("hfrt_model_eval_f64");
  } else {
    for (i = 0; i < n; ++i) {
      int32_t j;
      print_number(f[i]);
      for (j = 0; j < ns; ++j) {
        putchar(' ');
        print_number(s[(size_t)j * n + i]);
      }
      putchar('\n');
    }
  }
  free(rows);
  free(xs);
  free(f);
  free(s);
  hfrt_model_free(model);
  return rc;
}
