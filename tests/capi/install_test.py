#!/usr/bin/env python3
"""The install test of hfrt as a library (CTest capi.install_consumers).

1. `cmake --install BUILD --prefix TMP/prefix` (no rebuild: the build tree is complete).
2. The installed include/ holds the public headers only (hfrt/hfrt.h, model.h, render.h).
3. Builds, outside the source and build trees, against the installed files only:
   - examples/embed/c/main.c with `cc -std=c99 $(pkg-config --cflags --libs hfrt)`;
   - examples/embed/cmake (find_package(hfrt) -> hfrt::hfrt) with a fresh CMake project: the
     C++ example and the C example again.
4. Runs them, the installed `hfrt eval` and (with --python) the installed Python module
   (`python3 -m hfrt eval`) on the same points of corpus models and requires every output to
   be byte-identical to `hfrt eval`'s (17 significant digits: bit-identical doubles).
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile

# Corpus models (path under corpus/models, object or "", parameters) and their point grids.
MODELS = [
    ("web/frep_org__hf_objects__Sphere.hf", "", ""),
    ("web/frep_org__hf_objects__ColorSphere.hf", "ColorSphere", "0.5,0,0,1.5"),
    ("web/hyperfun_org__sample_model__superell_torus_soft.hf", "", ""),
    ("web/frep_org__tut_start__example1.hf", "", ""),
]


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.stderr.write(f"FAILED ({r.returncode}): {' '.join(map(str, cmd))}\n{r.stdout}{r.stderr}\n")
        sys.exit(1)
    return r.stdout


def points(k):
    """A deterministic grid of points (exact binary fractions and a few irrational ones)."""
    rows = []
    vals = [-1.75, -0.5, 0.0, 0.3, 1.25, 2.0 / 3.0]
    for i, a in enumerate(vals):
        for j, b in enumerate(vals):
            c = vals[(i + 2 * j) % len(vals)]
            rows.append([a, b, c, 0.1 * i][:k] + [0.0] * max(0, k - 4))
    return "".join(" ".join(repr(v) for v in r) + "\n" for r in rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--corpus", required=True)
    ap.add_argument("--cmake", default="cmake")
    ap.add_argument("--cc", default="cc")
    ap.add_argument("--cxx", default="c++")
    ap.add_argument("--generator", default="Ninja")
    ap.add_argument("--python", default=None)
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="hfrt-install-")
    try:
        prefix = os.path.join(tmp, "prefix")
        run([args.cmake, "--install", args.build, "--prefix", prefix])

        # Only the public headers are installed.
        inc = os.path.join(prefix, "include")
        headers = sorted(os.path.relpath(os.path.join(d, f), inc)
                         for d, _, fs in os.walk(inc) for f in fs)
        expect = ["hfrt/hfrt.h", "hfrt/model.h", "hfrt/render.h"]
        if headers != expect:
            sys.exit(f"installed headers {headers}, expected {expect}")
        libdirs = [d for d in ("lib", "lib64") if os.path.isdir(os.path.join(prefix, d))]
        libdir = os.path.join(prefix, libdirs[0])
        sonames = [f for f in os.listdir(libdir) if f.startswith("libhfrt.so")]
        if not any(f.count(".") >= 3 for f in sonames):
            sys.exit(f"no versioned libhfrt.so in {libdir}: {sonames}")

        env = dict(os.environ)
        env["PKG_CONFIG_PATH"] = os.path.join(libdir, "pkgconfig")
        # Nothing of the source or build tree may be used.
        env.pop("CPATH", None)
        env.pop("LIBRARY_PATH", None)
        env.pop("LD_LIBRARY_PATH", None)

        # C, through pkg-config.
        flags = run(["pkg-config", "--cflags", "--libs", "hfrt"], env=env).split()
        c_exe = os.path.join(tmp, "hfrt_eval_c")
        run([args.cc, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror",
             os.path.join(args.source, "examples/embed/c/main.c"), "-o", c_exe] + flags +
            ["-lm", "-Wl,-rpath," + libdir], env=env, cwd=tmp)

        # C++, through find_package(hfrt) in a fresh project.
        cxx_build = os.path.join(tmp, "cxx")
        run([args.cmake, "-S", os.path.join(args.source, "examples/embed/cmake"), "-B", cxx_build,
             "-G", args.generator, "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_PREFIX_PATH=" + prefix,
             "-DCMAKE_CXX_COMPILER=" + args.cxx, "-DCMAKE_C_COMPILER=" + args.cc], env=env, cwd=tmp)
        run([args.cmake, "--build", cxx_build], env=env, cwd=tmp)
        cxx_exe = os.path.join(cxx_build, "hfrt_eval_cxx")
        hfrt_exe = os.path.join(prefix, "bin", "hfrt")

        py_env = dict(env)
        if args.python:
            py_env["PYTHONPATH"] = os.path.join(prefix, "lib/python3/dist-packages")

        checked = 0
        for rel, obj, params in MODELS:
            model = os.path.join(args.corpus, "models", rel)
            pts = points(3)  # these corpus models take x[3]
            opts = (["--object", obj] if obj else []) + (["-a", params] if params else [])
            ref = run([hfrt_exe, "eval", model] + opts, input=pts, env=env)
            positional = [obj, params] if params else ([obj] if obj else [])
            outs = {"c (pkg-config)": run([c_exe, model] + positional, input=pts, env=env),
                    "c++ (find_package)": run([cxx_exe, model] + positional, input=pts, env=env),
                    "c (find_package)": run([os.path.join(cxx_build, "hfrt_eval_c_cmake"), model] +
                                            positional, input=pts, env=env)}
            if args.python:
                outs["python -m hfrt"] = run([args.python, "-m", "hfrt", "eval", model] + opts,
                                             input=pts, env=py_env, cwd=tmp)
            if "nan" in ref or len(ref.splitlines()) != len(pts.splitlines()):
                sys.exit(f"{rel}: unusable reference output:\n{ref}")
            for name, out in outs.items():
                if out != ref:
                    sys.exit(f"{rel}: {name} differs from `hfrt eval`:\n--- hfrt eval\n{ref}"
                             f"--- {name}\n{out}")
            checked += len(ref.splitlines())
        # The installed C++ library renders too.
        png = os.path.join(tmp, "render.png")
        run([cxx_exe, os.path.join(args.corpus, "models", MODELS[0][0]), "--render", "32", "24",
             png], env=env)
        if not os.path.getsize(png):
            sys.exit("the C++ consumer wrote an empty image")
        print(f"install test: OK ({checked} values x {3 + bool(args.python)} consumers "
              f"identical to hfrt eval, {len(MODELS)} corpus models)")
    finally:
        if args.keep:
            print("kept", tmp)
        else:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
