#!/usr/bin/env python3
"""hfrt from Python: evaluate a model on a NumPy grid, plot a slice with matplotlib, and ray
trace it into an array.

    PYTHONPATH=build/python python3 examples/embed/python/embed.py [OUT_DIR]

(With an installed hfrt, `import hfrt` works without PYTHONPATH.) Writes slice.png (when
matplotlib is installed) and render.png into OUT_DIR (default: the current folder).
"""
import os
import sys

import numpy as np

import hfrt

SOURCE = """
-- A box with a spherical bite, and an attribute.
my_model(x[3], a[2], s[1])
{
  array v[3], c[3];
  v = [-1, -1, -1];
  c = [1, 1, 1];
  box = hfBlock(x, v, 2, 2, 2);
  bite = hfSphere(x, c, a[1]);
  s[1] = x[3];
  my_model = box \\ bite;
}
"""


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else "."
    try:
        model = hfrt.Model(SOURCE, params=[1.2, 0], name="embed.hf")
    except hfrt.CompileError as e:  # located diagnostics: e.diagnostics[i].line, .column, ...
        print(e, file=sys.stderr)
        return 1
    print(model)

    # F on a 200 x 200 grid of the plane z = 0.5: an (n, 3) array in, n values out.
    u = np.linspace(-1.5, 1.5, 200)
    X, Y = np.meshgrid(u, u)
    pts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 0.5)], axis=1)
    F = model.eval(pts).reshape(X.shape)
    print(f"inside: {np.mean(F >= 0):.3f} of the slice")

    # Gradients and intervals work the same way.
    g = model.gradient(pts[:3])  # columns F, dF/dx, dF/dy, dF/dz
    lo, hi, maybe_nan = model.eval_interval(pts[:3] - 0.1, pts[:3] + 0.1)
    print("gradient at the first point:", g[0, 1:], "F over a box around it:", lo[0], hi[0])

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 5))
        ax.contourf(X, Y, F, levels=20, cmap="RdBu")
        ax.contour(X, Y, F, levels=[0], colors="k")
        ax.set_title("F on z = 0.5 (black: the surface)")
        fig.savefig(os.path.join(out_dir, "slice.png"), dpi=80)
        print("wrote", os.path.join(out_dir, "slice.png"))
    except ImportError:
        print("matplotlib is not installed: no slice plot")

    # Ray trace into an (h, w, 4) float32 array (linear RGB + alpha), then save it.
    img = hfrt.render(model, size=(320, 240), camera={"eye": [4, 3, 5]}, bbox=2)
    print(f"render: {img.shape}, coverage {img[..., 3].mean():.3f}")
    hfrt.write_image(os.path.join(out_dir, "render.png"), img)
    print("wrote", os.path.join(out_dir, "render.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
