"""What bench/peers/povray (isosurfaces) and bench/peers/povray_meshes (meshes and patches)
share: timing a child process, and hfrt's side of a comparison with POV-Ray (the timed PNG
renders, the untimed EXR for the coverage, the coverage difference)."""
import re
import resource
import subprocess
import time

HFRT_RENDER_RE = re.compile(r"render ([0-9.]+) s on")


def run(cmd, cwd=None):
    """Runs cmd; returns (rc, wall s, CPU s of the child incl. its threads, stdout, stderr)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return p.returncode, wall, cpu, p.stdout, p.stderr


def hfrt_side(cmd, png, exr, repeat):
    """hfrt's measured renders: `cmd` (an `hfrt render ... --stats` command without -o) writes
    `png` `repeat` times (a PNG, as POV-Ray writes: the timed runs), then `exr` once (untimed:
    the alpha of the coverage comparison). Returns (rc, error text, fastest wall, fastest CPU,
    fastest render as --stats reports it, stderr of the last timed run)."""
    wall = cpu = render = float("inf")
    timed_err = ""
    for _ in range(max(1, repeat)):
        rc, w, c, _, err = run(cmd + ["-o", png])
        if rc != 0:
            return rc, err, wall, cpu, render, timed_err
        timed_err = err
        m = HFRT_RENDER_RE.search(err)
        wall, cpu = min(wall, w), min(cpu, c)
        render = min(render, float(m.group(1)) if m else float("nan"))
    rc, _, _, _, err = run(cmd + ["-o", exr])
    return rc, err, wall, cpu, render, timed_err


def coverage_difference(maskdiff, exr, pov_png):
    """The fraction of pixels whose coverage differs (hfrt_bench_maskdiff); NaN on failure."""
    rc, _, _, out, _ = run([maskdiff, exr, pov_png])
    return float(re.search(r"differ=([0-9.]+)", out).group(1)) if rc == 0 else float("nan")
