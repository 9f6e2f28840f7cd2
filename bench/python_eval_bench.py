#!/usr/bin/env python3
"""Points/s of hfrt.Model.eval from Python on 10^6 points of a corpus model, side by side
with the same evaluation in C++ (hfrt_bench_eval_points: Model::eval_batch) and with the same
expression evaluated by pure NumPy (libfive-style: one whole-array operation per
instruction). One thread everywhere. The model must be straight-line HyperFun (`t = expr;`
with + - * / sqrt abs min max, like the machine-generated FRep-Designer-Bench corpus models):
it is translated to NumPy statement by statement, and the NumPy values are checked against
hfrt's before timing.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_eval_bench.py \\
        --cxx build/bench/hfrt_bench_eval_points [MODEL.hf] [--n 1000000] [--repeat 5] [--rounds 5]
"""
import argparse
import os
import re
import subprocess
import sys
import time

import numpy as np

import hfrt

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MODEL = os.path.join(
    HERE, "../../shared/corpus/models/github/alexander-penev__FRep-Designer-Bench/c1_gear.hf")


def to_numpy(source):
    """A NumPy function of (x1, x2, x3) for a straight-line HyperFun object."""
    body = source[source.index("{") + 1:source.rindex("}")]
    name = source[:source.index("(")].strip()
    lines = ["def f(x1, x2, x3):"]
    for stmt in body.split(";"):
        stmt = stmt.strip()
        if not stmt:
            continue
        m = re.fullmatch(r"(\w+)\s*=\s*(.+)", stmt, re.S)
        if not m or re.search(r"\b(if|while|array|hf\w+)\b", stmt):
            raise SystemExit(f"not straight-line arithmetic: {stmt!r}")
        lhs, rhs = m.groups()
        rhs = re.sub(r"x\[(\d)\]", r"x\1", rhs)
        for fn, np_fn in (("sqrt", "np.sqrt"), ("abs", "np.abs"), ("min", "np.minimum"),
                          ("max", "np.maximum")):
            rhs = re.sub(rf"\b{fn}\(", np_fn + "(", rhs)
        lines.append(f"    {lhs} = {rhs}")
    lines.append(f"    return {name}")
    ns = {"np": np}
    exec("\n".join(lines), ns)
    return ns["f"]


_FLUSH = np.zeros(8 << 20)  # 64 MB


def best(call, repeat):
    """The fastest of `repeat` calls, each with cold caches (as hfrt_bench_eval_points)."""
    t = 1e30
    for _ in range(repeat):
        _FLUSH[::8] += 1.0
        t0 = time.perf_counter()
        call()
        t = min(t, time.perf_counter() - t0)
    return t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model", nargs="?", default=DEFAULT_MODEL)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--half", type=float, default=1.6, help="points in [-half, half]^3")
    ap.add_argument("--cxx", help="hfrt_bench_eval_points (the C++ side); skipped if absent")
    args = ap.parse_args()

    src = open(args.model).read()
    model = hfrt.Model(src, name=args.model, precision="f64")
    model32 = hfrt.Model(src, name=args.model, precision="f32")
    np_f = to_numpy(src)
    rng = np.random.default_rng(12345)
    pts = rng.uniform(-args.half, args.half, size=(args.n, 3))        # C order (n, 3)
    pts_f = np.asfortranarray(pts)                                     # F order: SoA
    pts32 = pts.astype(np.float32)

    ref = model.eval(pts)
    got = np_f(pts[:, 0], pts[:, 1], pts[:, 2])
    err = np.max(np.abs(got - ref))
    if not err <= 1e-9:
        raise SystemExit(f"NumPy translation differs from hfrt by {err}")

    print(f"model {os.path.basename(args.model)}: {args.n} points, 1 thread, best of "
          f"{args.rounds} rounds x {args.repeat} (the variants interleaved in each round)")
    n = args.n
    x1, x2, x3 = (np.ascontiguousarray(pts[:, i]) for i in range(3))
    y1, y2, y3 = (v.astype(np.float32) for v in (x1, x2, x3))
    out64 = np.empty(n)
    out32 = np.empty(n, dtype=np.float32)
    variants = {
        "Python Model.eval f64, (n,3) C order": lambda: model.eval(pts),
        "Python Model.eval f64, (n,3) F order": lambda: model.eval(pts_f),
        # out=: into one reused buffer, as the C++ side writes into its (no fresh 8 MB array
        # per call, whose page faults cost as much as a fifth of the evaluation).
        "Python f64, C order, out=": lambda: model.eval(pts, out=out64),
        "Python f64, F order, out=": lambda: model.eval(pts_f, out=out64),
        "Python Model.eval f32, (n,3) C order": lambda: model32.eval(pts32),
        "Python f32, C order, out=": lambda: model32.eval(pts32, out=out32),
        "NumPy f64 (same expression)": lambda: np_f(x1, x2, x3),
        "NumPy f32 (same expression)": lambda: np_f(y1, y2, y3),
    }
    results = {}
    for _ in range(args.rounds):
        # The machine's load drifts: each round measures every variant once, C++ included.
        if args.cxx and os.path.exists(args.cxx):
            out = subprocess.run([args.cxx, args.model, "--n", str(n), "--repeat",
                                  str(args.repeat), "--half", str(args.half)],
                                 capture_output=True, text=True, check=True).stdout
            for line in out.splitlines():
                parts = line.split()
                if parts[0] == "cxx":
                    layout = "rows transposed" if parts[1].endswith("-rows") else "SoA"
                    key = f"C++ Model::eval_batch {parts[1].split('-')[0]}, {layout}"
                    results[key] = max(results.get(key, 0.0), float(parts[2]))
        for key, call in variants.items():
            reps = args.repeat if not key.startswith("NumPy") else max(1, args.repeat // 3)
            results[key] = max(results.get(key, 0.0), n / best(call, reps))
    results = dict(sorted(results.items(), key=lambda kv: not kv[0].startswith("C++")))
    for k, v in results.items():
        print(f"  {k:42s} {v / 1e6:10.2f} M points/s")
    cxx = results.get("C++ Model::eval_batch f64, SoA")
    py = results["Python Model.eval f64, (n,3) C order"]
    npy = results["NumPy f64 (same expression)"]
    if cxx:
        print(f"Python f64 C order / C++ f64 SoA: {py / cxx:.3f};  Python F order / C++ SoA: "
              f"{results['Python Model.eval f64, (n,3) F order'] / cxx:.3f}")
        print(f"with out=: Python F order / C++ SoA: "
              f"{results['Python f64, F order, out='] / cxx:.3f}")
        rows = results.get("C++ Model::eval_batch f64, rows transposed")
        if rows:
            print(f"Python f64 C order / C++ f64 rows transposed: {py / rows:.3f}; with out=: "
                  f"{results['Python f64, C order, out='] / rows:.3f}")
        cxx32 = results.get("C++ Model::eval_batch f32, SoA")
        if cxx32:
            print(f"Python f32 / C++ f32: {results['Python Model.eval f32, (n,3) C order'] / cxx32:.3f}"
                  f"; with out=: {results['Python f32, C order, out='] / cxx32:.3f}")
    print(f"Python hfrt f64 / NumPy f64: {py / npy:.1f}x")


if __name__ == "__main__":
    sys.exit(main())
