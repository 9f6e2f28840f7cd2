#!/usr/bin/python3
"""MPI scaling of `hfrt render` on one machine, and an estimate for 64 ranks.

Runs the same scene render (one image, tile farm) and the same frame sequence (split by frames)
with 1 process (no mpirun) and with `mpirun -np N` for N in --ranks, every rank on --threads
threads (default 1, so that N ranks use N cores), checks that every result is bit-identical
to the one-process render, and prints wall times and parallel efficiency
(T1 / (N * TN)). Then it measures what the estimate needs: the per-rank fixed cost (start-up
and compile: a 1x1 render), the per-tile render cost (--stats of the one-process render), and
the bytes sent per batch of tiles, and prints the efficiency the model predicts at 64 ranks.

    make bench-cluster              # = bench/cluster/mpi_scaling.py --build build
    bench/cluster/mpi_scaling.py --scene examples/scenes/gyroid_dof.toml --size 640x480 --spp 4
"""
import argparse
import filecmp
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time


def run(cmd, cwd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr}")
    return dt, p.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--scene", default="examples/scenes/glass_blob_mirror.toml")
    ap.add_argument("--anim", default="examples/anim/metamorph.toml")
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--spp", default="4")
    ap.add_argument("--frames", default="0:23", help="frames of --anim for the sequence test")
    ap.add_argument("--ranks", default="2")
    ap.add_argument("--threads", default="1", help="threads per rank")
    ap.add_argument("--repeat", type=int, default=2, help="best of N runs")
    a = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    hfrt = os.path.abspath(os.path.join(a.build, "tools/hfrt/hfrt"))
    scene = os.path.abspath(os.path.join(root, a.scene))
    anim = os.path.abspath(os.path.join(root, a.anim))
    mpirun = shutil.which("mpirun")
    if not mpirun:
        sys.exit("mpirun not found: scripts/install-deps.sh installs openmpi-bin")
    work = tempfile.mkdtemp(prefix="hfrt_mpi_bench_")
    common = ["--size", a.size, "--spp", a.spp, "--threads", a.threads]
    ranks = [int(r) for r in a.ranks.split(",")]
    mpi = [mpirun, "--allow-run-as-root", "--oversubscribe", "--bind-to", "none"]

    def best(cmd):
        return min((run(cmd, work) for _ in range(a.repeat)), key=lambda r: r[0])

    print(f"hfrt MPI scaling: {os.cpu_count()} cores, {a.threads} thread(s) per rank, best of {a.repeat}")
    print(f"image: {a.scene} {a.size} spp {a.spp}; sequence: {a.anim} frames {a.frames} at 240x180")
    rows = []
    t1, err = best([hfrt, "render", scene, "-o", "one.exr", "--stats"] + common)
    m = re.search(r"trace: \S+, \d+ spp, max depth \d+, ([0-9.]+) ms", err)
    render_ms = float(m.group(1)) if m else float("nan")
    seq = ["--size", "240x180", "--spp", "2", "--threads", a.threads, "--frames", a.frames]
    s1, _ = best([hfrt, "render", anim, "-o", "s1/f_###.png"] + seq)
    rows.append((1, t1, 1.0, s1, 1.0, True, True))
    for n in ranks:
        tn, _ = best(mpi + ["-np", str(n), hfrt, "render", scene, "-o", f"many{n}.exr"] + common)
        # Every float of every pixel (the files differ in their DateTime header only).
        same_img = subprocess.run(["oiiotool", "one.exr", f"many{n}.exr", "--diff", "--fail", "0",
                                   "--warn", "0"], cwd=work, capture_output=True).returncode == 0
        sn, _ = best(mpi + ["-np", str(n), hfrt, "render", anim, "-o", f"s{n}/f_###.png"] + seq)
        names = sorted(os.listdir(os.path.join(work, "s1")))
        same_seq = names == sorted(os.listdir(os.path.join(work, f"s{n}"))) and all(
            filecmp.cmp(os.path.join(work, "s1", f), os.path.join(work, f"s{n}", f), shallow=False) for f in names)
        rows.append((n, tn, t1 / (n * tn), sn, s1 / (n * sn), same_img, same_seq))
    print("\n| ranks | image s | efficiency | sequence s | efficiency | image identical | frames identical |")
    print("|---:|---:|---:|---:|---:|---|---|")
    for n, tn, en, sn, es, si, ss in rows:
        print(f"| {n} | {tn:.2f} | {en:.2f} | {sn:.2f} | {es:.2f} | {'yes' if si else 'NO'} | {'yes' if ss else 'NO'} |")

    # The model for many ranks: T(N) = fixed + render / N + rank 0's messages, where fixed is a
    # rank's start-up and compile (measured by a 1x1 render of the scene: every rank pays it,
    # in parallel), render the one-process trace time, and the messages are every pixel once
    # (8 floats) plus one small request per batch, through rank 0 at a network's bandwidth and
    # latency (assumed: 10 GB/s, 5 us, a typical InfiniBand/100 GbE cluster).
    fixed, _ = best([hfrt, "render", scene, "-o", "tiny.exr", "--size", "1x1", "--spp", "1", "--threads", a.threads])
    w, h = (int(v) for v in a.size.split("x"))
    tiles = ((w + 15) // 16) * ((h + 15) // 16)
    n64 = 64
    batch = max(1, tiles // (n64 * 8))
    batches = (tiles + batch - 1) // batch
    bytes_total = w * h * 8 * 4 + batches * 8
    bandwidth, latency = 10e9, 5e-6
    comm = bytes_total / bandwidth + 2 * batches * latency
    per_tile_ms = render_ms / tiles
    t64 = fixed + render_ms / 1000 / n64 + comm
    # Load imbalance: the last batch may start when the others finish: up to one batch's time.
    t64 += batch * per_tile_ms / 1000
    t1_model = fixed + render_ms / 1000
    print(f"\nmeasured: one-process wall {t1:.2f} s, of which trace {render_ms / 1000:.2f} s; a rank's fixed cost "
          f"(start-up, compile, framing: 1x1 render) {fixed:.2f} s")
    print(f"          {tiles} tiles, {per_tile_ms:.2f} ms per tile on {a.threads} thread(s); at 64 ranks {batches} batches "
          f"of {batch} tiles, {bytes_total / 1e6:.1f} MB to rank 0")
    print(f"estimate at 64 ranks: T = {fixed:.2f} + {render_ms / 1000 / n64:.3f} + comm {comm * 1000:.2f} ms "
          f"+ imbalance {batch * per_tile_ms:.1f} ms = {t64:.2f} s; efficiency {t1_model / (n64 * t64):.2f} "
          f"(the fixed cost dominates: the trace would need ~{fixed * n64:.0f} s of work per image for 50 %)")
    shutil.rmtree(work)


if __name__ == "__main__":
    main()
