#!/usr/bin/python3
"""An independent reference for the coverage of the mesh and Bezier examples.

A brute-force ray cast in numpy that shares no code with hfrt: it reads the example's data file
itself (OFF triangles, or BPT patches that it tessellates finely), restates the example's model
from its text (examples/armadillo.hf, examples/teapot.hf) and the library's documented
semantics (hfRotate3D*, hfScale3D: ../shared/spec/library.md), and casts one ray through the
centre of each pixel of a perspective camera given explicitly (hfrt's documented camera:
vertical field of view, up vector, pixel (0, 0) at the top left).

Usage: coverage_raycast.py MODEL EXAMPLES_DIR WxH EYE LOOK_AT FOV_DEG OUT.pbm
  MODEL is armadillo or teapot; EYE and LOOK_AT are x,y,z; OUT is an ASCII PBM (P1) in which
  1 marks a pixel whose ray meets the solid.

A ray meets the solid when
  - armadillo (body | pedestal): it meets a triangle of the moved mesh, or the pedestal, the
    cylinder x^2 + z^2 <= 1.2^2 cut to -1.1 <= y <= -0.9;
  - teapot (pot minus the corner C = {x > 0.2, z > 0, y > 1.6}): it meets a triangle of the
    tessellated patches at a point outside C. (C is convex, so a ray whose every crossing of the
    pot lies in C is inside the pot only within C; one crossing outside C is a point of the
    boundary of pot \\ C.)
"""

import math
import os
import sys

import numpy as np


def read_off(path):
    with open(path) as f:
        words = f.read().split()
    if words[0] != "OFF":
        raise SystemExit("%s: not a text OFF file" % path)
    nv, nf = int(words[1]), int(words[2])
    at = 4
    v = np.array(words[at:at + 3 * nv], dtype=np.float64).reshape(nv, 3)
    at += 3 * nv
    tris = []
    for _ in range(nf):
        k = int(words[at])
        idx = [int(w) for w in words[at + 1:at + 1 + k]]
        at += 1 + k
        for j in range(1, k - 1):  # a fan for polygons
            tris.append((idx[0], idx[j], idx[j + 1]))
    t = np.array(tris, dtype=np.int64)
    return v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]


def bernstein(n, s):
    return np.stack([math.comb(n, i) * s**i * (1 - s)**(n - i) for i in range(n + 1)], axis=-1)


def read_bpt_tessellated(path, n):
    """Each patch sampled on an (n+1) x (n+1) grid of (u, v), two triangles per cell."""
    words = []
    with open(path) as f:
        for line in f:
            words += line.split("#")[0].split()
    count = int(words[0])
    at = 1
    s = np.linspace(0.0, 1.0, n + 1)
    a, b, c = [], [], []
    for _ in range(count):
        du, dv = int(words[at]), int(words[at + 1])
        at += 2
        m = (du + 1) * (dv + 1)
        cp = np.array(words[at:at + 3 * m], dtype=np.float64).reshape(dv + 1, du + 1, 3)
        at += 3 * m
        bu, bv = bernstein(du, s), bernstein(dv, s)  # (n+1, du+1), (n+1, dv+1)
        # point (i along u, j along v) is control point [j][i]
        grid = np.einsum("ui,vj,jik->uvk", bu, bv, cp)
        p00, p10 = grid[:-1, :-1].reshape(-1, 3), grid[1:, :-1].reshape(-1, 3)
        p01, p11 = grid[:-1, 1:].reshape(-1, 3), grid[1:, 1:].reshape(-1, 3)
        a += [p00, p00]
        b += [p10, p11]
        c += [p11, p01]
    return np.concatenate(a), np.concatenate(b), np.concatenate(c)


class Camera:
    def __init__(self, eye, look_at, fov_deg, width, height, up=(0.0, 1.0, 0.0)):
        self.eye = np.array(eye, dtype=np.float64)
        f = np.array(look_at, dtype=np.float64) - self.eye
        self.f = f / np.linalg.norm(f)
        r = np.cross(self.f, np.array(up, dtype=np.float64))
        self.r = r / np.linalg.norm(r)
        self.u = np.cross(self.r, self.f)
        self.half_h = math.tan(math.radians(fov_deg) / 2)
        self.half_w = self.half_h * width / height
        self.w, self.h = width, height

    def directions(self, px, py):
        """Ray directions through the image points (px, py) (pixel units, (0, 0) top left)."""
        sx = (2.0 * px / self.w - 1.0) * self.half_w
        sy = (1.0 - 2.0 * py / self.h) * self.half_h
        return self.f + sx[:, None] * self.r + sy[:, None] * self.u

    def project(self, p):
        """Image coordinates of the points p (all in front of the eye)."""
        q = p - self.eye
        depth = q @ self.f
        if np.any(depth <= 0):
            raise SystemExit("coverage_raycast: a vertex is behind the eye")
        sx = (q @ self.r) / depth / self.half_w
        sy = (q @ self.u) / depth / self.half_h
        return (sx + 1.0) * 0.5 * self.w, (1.0 - sy) * 0.5 * self.h


def triangle_hits(cam, a, b, c):
    """For every (triangle, pixel centre) pair whose projected bounding box contains the centre,
    the Moller-Trumbore test in double: returns the pixel indices and hit points of the hits."""
    xa, ya = cam.project(a)
    xb, yb = cam.project(b)
    xc, yc = cam.project(c)
    x0 = np.maximum(np.ceil(np.minimum(np.minimum(xa, xb), xc) - 0.5), 0).astype(np.int64)
    x1 = np.minimum(np.floor(np.maximum(np.maximum(xa, xb), xc) - 0.5), cam.w - 1).astype(np.int64)
    y0 = np.maximum(np.ceil(np.minimum(np.minimum(ya, yb), yc) - 0.5), 0).astype(np.int64)
    y1 = np.minimum(np.floor(np.maximum(np.maximum(ya, yb), yc) - 0.5), cam.h - 1).astype(np.int64)
    nx = np.maximum(x1 - x0 + 1, 0)
    ny = np.maximum(y1 - y0 + 1, 0)
    counts = nx * ny
    tri = np.repeat(np.arange(len(a)), counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    px = x0[tri] + k % nx[tri]
    py = y0[tri] + k // nx[tri]
    d = cam.directions(px + 0.5, py + 0.5)
    e1, e2 = b[tri] - a[tri], c[tri] - a[tri]
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = cam.eye - a[tri]
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    v = np.einsum("ij,ij->i", d, qv) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    pixel = py[hit] * cam.w + px[hit]
    return pixel, cam.eye + d[hit] * t[hit][:, None]


def rotation_y(theta):
    """The map of hfRotate3DY(xt, theta): (z, x) := (z co + x si, -z si + x co)."""
    co, si = math.cos(theta), math.sin(theta)
    return np.array([[co, 0, -si], [0, 1, 0], [si, 0, co]])


def rotation_x(theta):
    """The map of hfRotate3DX(xt, theta): (y, z) := (y co + z si, -y si + z co)."""
    co, si = math.cos(theta), math.sin(theta)
    return np.array([[1, 0, 0], [0, co, si], [0, -si, co]])


def armadillo(cam, examples):
    # armadillo.hf: p := Scale(Rotate_Y(x, 2.8), 0.017); body = hfMesh(p, ...). A world point w
    # is in the body when (R w) / 0.017 is in the mesh: w = R^T (0.017 v) for a mesh vertex v.
    m = rotation_y(2.8)
    a, b, c = (0.017 * t @ m for t in read_off(os.path.join(examples, "data", "armadillo.off")))
    covered = np.zeros(cam.w * cam.h, dtype=bool)
    pixel, _ = triangle_hits(cam, a, b, c)
    covered[pixel] = True
    # The pedestal: the ray o + t d meets the cylinder x^2 + z^2 <= r^2 for t in [c0, c1] and
    # the slab -1.1 <= y <= -0.9 for t in [s0, s1]; it meets the solid when they overlap.
    py, px = np.divmod(np.arange(cam.w * cam.h), cam.w)
    d = cam.directions(px + 0.5, py + 0.5)
    o = cam.eye
    qa = d[:, 0]**2 + d[:, 2]**2
    qb = 2 * (o[0] * d[:, 0] + o[2] * d[:, 2])
    qc = o[0]**2 + o[2]**2 - 1.2**2
    disc = qb * qb - 4 * qa * qc
    ok = (disc >= 0) & (qa > 0)
    sq = np.sqrt(np.where(ok, disc, 0))
    c0 = (-qb - sq) / (2 * np.where(ok, qa, 1))
    c1 = (-qb + sq) / (2 * np.where(ok, qa, 1))
    dy = np.where(d[:, 1] == 0, 1e-300, d[:, 1])
    ya, yb = (-1.1 - o[1]) / dy, (-0.9 - o[1]) / dy
    s0, s1 = np.minimum(ya, yb), np.maximum(ya, yb)
    lo, hi = np.maximum(np.maximum(c0, s0), 0), np.minimum(c1, s1)
    covered |= ok & (lo <= hi)
    return covered


def teapot(cam, examples):
    # teapot.hf: p := Rotate_X(x, -pi/2 (as written)); pot = hfBezierSurface(p, ...): w = R^T q
    # for a patch point q; teapot = pot \ ((x - 0.2) & z & (y - 1.6)).
    m = rotation_x(-1.5707963)
    a, b, c = (t @ m for t in read_bpt_tessellated(os.path.join(examples, "data", "teapot.bpt"), 48))
    pixel, p = triangle_hits(cam, a, b, c)
    outside_c = ~((p[:, 0] > 0.2) & (p[:, 2] > 0) & (p[:, 1] > 1.6))
    covered = np.zeros(cam.w * cam.h, dtype=bool)
    covered[pixel[outside_c]] = True
    return covered


def triple(text):
    v = [float(s) for s in text.split(",")]
    if len(v) != 3:
        raise SystemExit("coverage_raycast: expected x,y,z, got " + text)
    return v


def main(argv):
    if len(argv) != 8:
        raise SystemExit(__doc__)
    model, examples, size, eye, look_at, fov, out = argv[1:]
    w, h = (int(s) for s in size.split("x"))
    cam = Camera(triple(eye), triple(look_at), float(fov), w, h)
    scenes = {"armadillo": armadillo, "teapot": teapot}
    if model not in scenes:
        raise SystemExit("coverage_raycast: unknown model " + model)
    covered = scenes[model](cam, examples).reshape(h, w)
    with open(out, "w") as f:
        f.write("P1\n%d %d\n" % (w, h))
        for row in covered:
            f.write(" ".join("1" if c else "0" for c in row) + "\n")


if __name__ == "__main__":
    main(sys.argv)
