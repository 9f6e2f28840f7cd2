"""`python3 -m hfrt render MODEL.hf -o OUT.png [options]` and `python3 -m hfrt eval MODEL.hf`:
the render and eval commands of the `hfrt` command line (same options, same output format),
through the Python module. Exit codes as hfrt's: 0 done, 1 compile errors, 2 usage or
environment errors."""

import argparse
import math
import sys

import numpy as np

import hfrt


def _usage(message):
    """A usage error: the message on stderr, exit 2 (as hfrt's)."""
    sys.stderr.write(message + "\n")
    sys.exit(2)


def _floats(text, n, what):
    try:
        v = [float(t) for t in text.split(",")]
    except ValueError:
        v = []
    if len(v) != n:
        _usage(f"hfrt: {what} expects {n} comma-separated numbers (got '{text}')")
    return v


def _size(text):
    try:
        w, h = (int(t) for t in text.lower().split("x"))
        if w > 0 and h > 0:
            return w, h
    except ValueError:
        pass
    _usage(f"hfrt render: --size expects WxH with positive integers (got '{text}')")


def _params(text):
    if not text:
        return []
    try:
        return [float(t) for t in text.lstrip("=").split(",")]
    except ValueError:
        _usage(f"hfrt: -a expects numbers separated by commas, e.g. -a 1,0.5 (got '{text}')")


def _load(args):
    try:
        return hfrt.Model(__import__("pathlib").Path(args.model), object=args.object,
                          params=_params(args.a), backend=args.backend,
                          precision=getattr(args, "precision", "f64"))
    except hfrt.CompileError as e:
        sys.stderr.write(str(e))
        sys.exit(1)
    except (OSError, ValueError) as e:
        sys.stderr.write(f"hfrt: {e}\n")
        sys.exit(2)


def _number(v):
    return "nan" if math.isnan(v) else "%.17g" % v


def cmd_eval(args):
    m = _load(args)
    k = m.num_inputs
    rows = []
    for line in sys.stdin:
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        vals = [float(t) for t in line.split()][:k]
        rows.append(vals + [0.0] * (k - len(vals)))
    dtype = np.float32 if args.precision == "f32" else np.float64
    pts = np.array(rows, dtype=dtype).reshape(len(rows), k)
    f, s = m.eval(pts, attributes=True)
    out = []
    for i in range(len(rows)):
        out.append(" ".join([_number(float(f[i]))] + [_number(float(v)) for v in s[i]]))
    sys.stdout.write("".join(line + "\n" for line in out))
    return 0


def cmd_render(args):
    camera = {}
    if args.eye:
        camera["eye"] = _floats(args.eye, 3, "--eye")
    if args.look_at:
        camera["look_at"] = _floats(args.look_at, 3, "--look-at")
    if args.up:
        camera["up"] = _floats(args.up, 3, "--up")
    if args.fov:
        camera["fov"] = args.fov
    if args.ortho:
        camera["ortho"] = args.ortho
    bbox = None
    if args.bbox:
        parts = args.bbox.split(",")
        bbox = _floats(args.bbox, 6 if len(parts) == 6 else 1, "--bbox")
    background = _floats(args.background, 3, "--background") if args.background else None
    size = _size(args.size)  # the options first, then the model (as `hfrt render`)
    m = _load(args)
    try:
        img = hfrt.render(m, size=size, camera=camera, bbox=bbox, root=args.root,
                          spp=args.spp, threads=args.threads, shadows=not args.no_shadows,
                          background=background)
        hfrt.write_image(args.output, img)
    except hfrt.CompileError as e:
        sys.stderr.write(str(e))
        return 1
    except (ValueError, RuntimeError) as e:
        sys.stderr.write(f"hfrt render: {e}\n")
        return 2
    sys.stderr.write(f"hfrt: wrote {args.output} ({img.shape[1]}x{img.shape[0]}, {args.spp} spp)\n")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m hfrt", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)

    def common(p):
        p.add_argument("model", help="HyperFun model file")
        p.add_argument("--object", default=None, help="object to evaluate")
        p.add_argument("-a", default="", help="parameters a[1..], comma-separated")
        p.add_argument("--backend", default="jit", choices=["jit", "interp"])

    e = sub.add_parser("eval", help="evaluate points read from stdin ('x y z' per line)")
    common(e)
    e.add_argument("--precision", default="f64", choices=["f64", "f32"])
    e.set_defaults(run=cmd_eval)

    r = sub.add_parser("render", help="ray trace a model to an image (PNG, EXR, TIFF, JPEG)")
    common(r)
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--size", default="512x512")
    r.add_argument("--bbox", default="")
    r.add_argument("--eye", default="")
    r.add_argument("--look-at", dest="look_at", default="")
    r.add_argument("--up", default="")
    r.add_argument("--fov", type=float, default=0)
    r.add_argument("--ortho", type=float, default=0)
    r.add_argument("--root", default="auto", choices=["sign", "interval", "analytic", "auto"])
    r.add_argument("--spp", type=int, default=1)
    r.add_argument("--threads", type=int, default=0)
    r.add_argument("--background", default="")
    r.add_argument("--no-shadows", action="store_true")
    r.set_defaults(run=cmd_render)

    args = ap.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
