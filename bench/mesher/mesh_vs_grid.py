#!/usr/bin/env python3
"""hfrt mesh vs scikit-image marching cubes on a grid sampled by hfrt's own JIT.

For each model, at the same effective resolution (N cells along the longest side of the same
box), side by side in one run:

  hfrt:  `hfrt mesh MODEL --bbox BOX --resolution N -o out.ply --threads T --stats`
         (interval-pruned octree, dual contouring), timed as a whole process and by its own
         "mesh" figure;
  grid:  `hfrt_bench_mesh_tool grid` samples F at the (N+1)^3 nodes with the f32 JIT on T
         threads (timed), then skimage.measure.marching_cubes(volume, 0) (timed; single
         threaded, as scikit-image is).

Then the distance of every vertex of each mesh from the surface F = 0 (Newton steps along the
f64 gradient, `hfrt_bench_mesh_tool dist`). Prints one table; --json writes the numbers.

With --repeat R every timed step runs R times, alternating the two sides (hfrt, sampling,
marching cubes, hfrt, ...), and the table shows each step's fastest run (the runs' times are
in the JSON): on a shared machine whose speed drifts, the minimum of each side is the
figure least disturbed by the others, and both sides are treated alike.

    /usr/bin/python3 bench/mesher/mesh_vs_grid.py [--build build] [--res 512] [--threads 2]
        [--models gyroid,blend] [--repeat 1] [--out out/bench-mesh]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np
from skimage.measure import marching_cubes

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
BENCH = os.path.join(ROOT, "..", "shared", "corpus", "models", "github",
                     "alexander-penev__FRep-Designer-Bench")
MODELS = {
    # name: (file, box)
    "gyroid": (os.path.join(BENCH, "s4_gyroid.hf"), "-1.5,-1.5,-1.5,1.5,1.5,1.5"),
    "blend": (os.path.join(BENCH, "s3_blend.hf"), "-1.25,-0.8,-0.8,1.25,0.8,0.8"),
    "csg": (os.path.join(BENCH, "s2_csg.hf"), "-1,-1,-1,1,1,1"),
}


def run(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), p.stdout, p.stderr))
    return p, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--models", default="gyroid,blend")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "bench-mesh"))
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs of each timed step (the table shows the fastest)")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    hfrt = os.path.join(args.build, "tools", "hfrt", "hfrt")
    tool = os.path.join(args.build, "bench", "hfrt_bench_mesh_tool")
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for name in args.models.split(","):
        path, box = MODELS[name]
        lo = np.array([float(v) for v in box.split(",")[:3]])
        out_ply = os.path.join(args.out, name + "_hfrt.ply")
        grid_f = os.path.join(args.out, name + "_grid.f32")
        hfrt_runs, hfrt_walls, sample_runs, mc_runs = [], [], [], []
        for _ in range(max(1, args.repeat)):
            # hfrt mesh
            p, wall = run([hfrt, "mesh", path, "-o", out_ply, "--bbox", box, "--resolution",
                           str(args.res), "--threads", str(args.threads), "--stats"])
            hfrt_runs.append(float(re.search(r"stats: mesh ([0-9.]+) s", p.stderr).group(1)))
            hfrt_walls.append(wall)
            hfrt_tris = int(re.search(r"([0-9]+) vertices, ([0-9]+) triangles", p.stderr).group(2))
            # grid + marching cubes
            p, _ = run([tool, "grid", path, box, str(args.res), grid_f, str(args.threads)])
            g = p.stdout.split()
            shape = (int(g[1]), int(g[2]), int(g[3]))
            h = float(g[4])
            sample_runs.append(float(g[5]))
            vol = np.fromfile(grid_f, dtype=np.float32).reshape(shape)
            os.remove(grid_f)
            t0 = time.perf_counter()
            verts, faces, _, _ = marching_cubes(vol, level=0.0, spacing=(h, h, h))
            mc_runs.append(time.perf_counter() - t0)
            del vol
        hfrt_mesh_s, hfrt_wall, sample_s, mc_s = (min(hfrt_runs), min(hfrt_walls),
                                                  min(sample_runs), min(mc_runs))
        d = run([tool, "dist", path, out_ply])[0].stdout.split()
        hfrt_dist = float(d[1])
        verts = (verts + lo).astype(np.float32)
        vf = os.path.join(args.out, name + "_mc_verts.f32")
        verts.tofile(vf)
        d = run([tool, "dist", path, vf])[0].stdout.split()
        mc_dist = float(d[1])
        os.remove(vf)
        row = dict(model=name, res=args.res, threads=args.threads, hfrt_mesh_s=hfrt_mesh_s,
                   hfrt_process_s=hfrt_wall, hfrt_triangles=hfrt_tris, hfrt_max_dist=hfrt_dist,
                   grid_sample_s=sample_s, grid_mc_s=mc_s, grid_total_s=sample_s + mc_s,
                   grid_triangles=len(faces), grid_max_dist=mc_dist, cell=h,
                   repeat=len(hfrt_runs), hfrt_mesh_runs=hfrt_runs, grid_sample_runs=sample_runs,
                   grid_mc_runs=mc_runs)
        row["speedup"] = row["grid_total_s"] / hfrt_mesh_s
        # Run by run (each hfrt run against the grid run right after it): the median ratio.
        ratios = sorted((g + m) / t for t, g, m in zip(hfrt_runs, sample_runs, mc_runs))
        row["speedup_median"] = ratios[len(ratios) // 2] if len(ratios) % 2 else \
            0.5 * (ratios[len(ratios) // 2 - 1] + ratios[len(ratios) // 2])
        rows.append(row)
        print(json.dumps(row), flush=True)
    print()
    print("| model | N | hfrt mesh s | grid sample s | marching cubes s | grid total s | speed-up "
          "| hfrt tris | grid tris | hfrt max dist | grid max dist | cell | runs | median speed-up |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %.3f | %.3f | %.3f | %.3f | %.1fx | %d | %d | %.2e | %.2e | %.2e | %d "
              "| %.1fx |" % (
                  r["model"], r["res"], r["hfrt_mesh_s"], r["grid_sample_s"], r["grid_mc_s"],
                  r["grid_total_s"], r["speedup"], r["hfrt_triangles"], r["grid_triangles"],
                  r["hfrt_max_dist"], r["grid_max_dist"], r["cell"], r["repeat"],
                  r["speedup_median"]))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
