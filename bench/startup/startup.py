#!/usr/bin/env python3
"""Start-up cost of hfrt commands (issue 25): CPU time (user + system) and peak memory (max RSS)
of whole processes, min / median / max over N runs, for one or more hfrt binaries side by side
(e.g. this build against an older one), plus how many shared objects each process loaded.

    bench/startup/startup.py --hfrt build/tools/hfrt/hfrt [--hfrt OLD/hfrt] [--runs 10]

Each run is a fresh process (CPU from wait4's rusage, peak RSS from /usr/bin/time); the binaries alternate run by run so
that load from other processes falls on each alike. The commands are `hfrt --help`, `hfrt check
M` and `hfrt eval M` (a one-line model; eval compiles it with the JIT, so it shows LLVM's share),
and `hfrt render M --size 64 -o out.png` (JIT, renderer; the PNG written without OpenImageIO).
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile

MODEL = "my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n"


def run_once(argv, cwd, stdin_text):
    """CPU ms and peak RSS MiB of one run. The command runs under /usr/bin/time, which reports
    its peak RSS (%M): a process started from Python inherits Python's peak RSS across exec
    (Linux keeps the larger), so wait4's ru_maxrss would never be below Python's. The CPU time
    is wait4's (the command plus time's own ~1 ms)."""
    env = dict(os.environ, HFRT_NO_CACHE="1")
    with tempfile.NamedTemporaryFile(mode="r") as report:
        p = subprocess.Popen(["/usr/bin/time", "-f", "%M", "-o", report.name] + argv, cwd=cwd,
                             stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, env=env)
        p.stdin.write(stdin_text.encode())
        p.stdin.close()
        _, status, ru = os.wait4(p.pid, 0)
        if os.waitstatus_to_exitcode(status) != 0:
            sys.exit(f"startup: {' '.join(argv)} failed ({status})")
        rss_kib = int(report.read().split()[-1])
    return (ru.ru_utime + ru.ru_stime) * 1000.0, rss_kib / 1024.0


def loaded_objects(argv, cwd, stdin_text):
    env = dict(os.environ, HFRT_NO_CACHE="1", LD_DEBUG="files")
    r = subprocess.run(argv, cwd=cwd, input=stdin_text.encode(), env=env,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    names = set()
    for line in r.stderr.decode(errors="replace").splitlines():
        if "file=" in line and ("needed by" in line or "dynamically loaded by" in line):
            names.add(line.split("file=")[1].split()[0])
    return len(names)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hfrt", action="append", required=True, help="an hfrt binary (repeatable)")
    ap.add_argument("--runs", type=int, default=10)
    args = ap.parse_args()
    work = tempfile.mkdtemp(prefix="hfrt_startup_")
    with open(os.path.join(work, "ball.hf"), "w") as f:
        f.write(MODEL)
    commands = [
        ("--help", ["--help"], ""),
        ("check", ["check", "ball.hf"], ""),
        ("eval", ["eval", "ball.hf"], "0.5 0 0\n"),
        ("render 64", ["render", "ball.hf", "--size", "64", "-o", "out.png"], ""),
    ]
    with open("/proc/loadavg") as f:
        load = f.read().split()[:3]
    print(f"hfrt start-up: {args.runs} runs per command and binary, CPU = user + system, "
          f"load average {' '.join(load)}")
    print(f"{'command':<10} {'binary':<40} {'CPU ms min/med/max':>22} {'max RSS MiB min/med/max':>26} {'objects':>8}")
    for name, cmd, stdin_text in commands:
        samples = {b: ([], []) for b in args.hfrt}
        for _ in range(args.runs):
            for b in args.hfrt:
                cpu, rss = run_once([os.path.abspath(b)] + cmd, work, stdin_text)
                samples[b][0].append(cpu)
                samples[b][1].append(rss)
        for b in args.hfrt:
            cpu, rss = samples[b]
            objs = loaded_objects([os.path.abspath(b)] + cmd, work, stdin_text)
            fmt = lambda v: f"{min(v):.0f}/{statistics.median(v):.0f}/{max(v):.0f}"
            print(f"{name:<10} {b[-40:]:<40} {fmt(cpu):>22} {fmt(rss):>26} {objs:>8}")


if __name__ == "__main__":
    main()
