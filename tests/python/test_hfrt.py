"""Tests of the hfrt Python module: every call, its errors, NumPy dtypes and shapes (and that
contiguous arrays are not copied), thread safety and the GIL, `python3 -m hfrt`. Values are
checked against closed forms computed with NumPy and against the `hfrt eval` executable."""
import math
import os
import pathlib
import subprocess
import sys
import threading
import time
import tracemalloc
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import hfrt

CORPUS = pathlib.Path(os.environ.get("HFRT_CORPUS_DIR", "../shared/corpus"))
HFRT_EXE = os.environ.get("HFRT_EXE", "hfrt")

BALL = """my_model(x[3], a[1], s[2])
{
  s[1] = x[1] + 2 * x[2];
  s[2] = a[1];
  my_model = a[1] * a[1] - x[1] * x[1] - x[2] * x[2] - x[3] * x[3];
}
"""


def ball(r, p):
    p = np.asarray(p, dtype=np.float64)
    return r * r - p[:, 0] * p[:, 0] - p[:, 1] * p[:, 1] - p[:, 2] * p[:, 2]


@pytest.fixture(scope="module")
def model():
    return hfrt.Model(BALL, params=[1.5])


def rng_points(n, seed=1, scale=2.0):
    return np.random.default_rng(seed).uniform(-scale, scale, size=(n, 3))


# ---- compiling -----------------------------------------------------------------------------

def test_model_shape_and_properties(model):
    assert model.num_inputs == 3
    assert model.num_params == 1
    assert model.num_attributes == 2
    assert model.object == "my_model"
    assert model.objects == ["my_model"]
    assert model.params == [1.5]
    assert model.diagnostics == []
    assert "my_model" in repr(model)


def test_compile_from_path_str_and_pathlike(tmp_path):
    f = tmp_path / "ball.hf"
    f.write_text(BALL)
    for arg in (str(f), f):
        m = hfrt.Model(arg, params=[1.0])
        assert m.eval([0.5, 0, 0]) == 0.75


def test_object_selection_and_params():
    src = BALL + "other(x[3], a[2]) { other = a[1] + a[2] - x[1]; }\n"
    m = hfrt.Model(src, object="other", params=[1, 2])
    assert m.object == "other" and m.objects == ["my_model", "other"]
    assert m.eval([1.0, 0, 0]) == 2.0


def test_compile_error_carries_located_diagnostics():
    bad = "my_model(x[3], a[1])\n{\n  my_model = 1 - * x[1];\n}\n"
    with pytest.raises(hfrt.CompileError) as e:
        hfrt.Model(bad, name="bad.hf")
    err = e.value
    assert "bad.hf:3:18: error:" in str(err)
    assert (err.file, err.line, err.column) == ("bad.hf", 3, 18)
    d = err.diagnostics[0]
    assert d.severity == "error" and d.file == "bad.hf" and (d.line, d.column) == (3, 18)
    assert d.message
    assert str(d).startswith("bad.hf:3:18: error:")


def test_compile_error_from_a_file_names_the_file(tmp_path):
    f = tmp_path / "undef.hf"
    f.write_text("my_model(x[3], a[1])\n{\n  my_model = undefined_var;\n}\n")
    with pytest.raises(hfrt.CompileError) as e:
        hfrt.Model(f)
    assert (e.value.file, e.value.line, e.value.column) == (str(f), 3, 14)


def test_missing_file_and_bad_arguments():
    with pytest.raises(FileNotFoundError, match="nonexistent"):
        hfrt.Model("/nonexistent/model.hf")
    with pytest.raises(FileNotFoundError):
        hfrt.Model(pathlib.Path("/nonexistent/model"))
    with pytest.raises(hfrt.CompileError, match="nope"):
        hfrt.Model(BALL, object="nope")
    with pytest.raises(ValueError, match="a\\[1\\]"):
        hfrt.Model(BALL, params=[1, 2])
    with pytest.raises(ValueError, match="backend"):
        hfrt.Model(BALL, backend="gpu")
    with pytest.raises(ValueError, match="precision"):
        hfrt.Model(BALL, precision="f16")
    with pytest.raises(TypeError):
        hfrt.Model(42)


def test_warnings_are_diagnostics():
    src = ("my_model(x[4], a[1])\n{\n  array c[3];\n  c = [0, 0, 0];\n"
           "  my_model = hfSphere(x, c, 2);\n}\n")
    m = hfrt.Model(src, name="warn.hf")
    ds = m.diagnostics
    assert ds and ds[0].severity == "warning"
    assert ds[0].file == "warn.hf" and ds[0].line == 5


def test_interp_backend_gives_the_same_values(model):
    m = hfrt.Model(BALL, params=[1.5], backend="interp")
    p = rng_points(100)
    np.testing.assert_array_equal(m.eval(p), model.eval(p))


# ---- eval ----------------------------------------------------------------------------------

@pytest.mark.parametrize("n", [0, 1, 7, 1000, 5000])
def test_eval_f64_matches_numpy(model, n):
    p = rng_points(n)
    f = model.eval(p)
    assert f.shape == (n,) and f.dtype == np.float64
    np.testing.assert_allclose(f, ball(1.5, p), rtol=0, atol=1e-12)


def test_eval_layouts_give_identical_values(model):
    p = rng_points(3001)
    ref = model.eval(p)
    np.testing.assert_array_equal(model.eval(np.asfortranarray(p)), ref)   # SoA, passed as is
    np.testing.assert_array_equal(model.eval(p.tolist()), ref)             # a list of lists
    big = rng_points(6002)
    np.testing.assert_array_equal(model.eval(big[::2]), model.eval(big[::2].copy()))  # strided
    wide = np.zeros((10, 5))
    wide[:, 1:4] = p[:10]
    np.testing.assert_array_equal(model.eval(wide[:, 1:4]), ref[:10])       # column slice


def test_eval_f32_keeps_single_precision(model):
    p = rng_points(1000).astype(np.float32)
    f = model.eval(p)
    assert f.dtype == np.float32
    np.testing.assert_allclose(f, ball(1.5, p), rtol=0, atol=1e-5)


def test_eval_other_dtypes_are_converted(model):
    p = np.array([[1, 0, 0], [0, 1, 1]], dtype=np.int32)
    f = model.eval(p)
    assert f.dtype == np.float64
    np.testing.assert_array_equal(f, [1.25, 0.25])


def test_eval_single_point_and_attributes(model):
    assert model.eval([0.5, 0.25, 0.0]) == ball(1.5, [[0.5, 0.25, 0.0]])[0]
    p = rng_points(50)
    f, s = model.eval(p, attributes=True)
    assert s.shape == (50, 2)
    np.testing.assert_allclose(s[:, 0], p[:, 0] + 2 * p[:, 1], atol=1e-12)
    np.testing.assert_array_equal(s[:, 1], 1.5)
    v, s1 = model.eval([1.0, 1.0, 0.0], attributes=True)
    assert v == 2.25 - 2 and list(s1) == [3.0, 1.5]


def test_eval_shape_errors(model):
    with pytest.raises(ValueError, match="2 columns but the model takes x\\[3\\]"):
        model.eval(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="2 values but the model takes x\\[3\\]"):
        model.eval([1.0, 2.0])
    with pytest.raises(ValueError, match="dimensions"):
        model.eval(np.zeros((2, 2, 3)))
    with pytest.raises((ValueError, TypeError)):
        model.eval([["a", "b", "c"]])


def test_eval_does_not_copy_contiguous_input(model):
    p = rng_points(1_000_000)
    model.eval(p[:10])  # compile/warm up outside the measurement
    for arr in (p, p.astype(np.float32)):
        tracemalloc.start()
        f = model.eval(arr)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        # The result (n values) is allocated; a copy of the (n, 3) input would triple that.
        assert peak < 1.5 * f.nbytes, (arr.dtype, peak, f.nbytes)


def test_nan_where_f_has_no_value():
    m = hfrt.Model("my_model(x[3], a[1]) { my_model = 1 / x[1]; }")
    f = m.eval([[0.0, 0, 0], [2.0, 0, 0]])
    assert math.isnan(f[0]) and f[1] == 0.5


# ---- intervals and gradients ---------------------------------------------------------------

def test_eval_interval_encloses_samples(model):
    rng = np.random.default_rng(5)
    lo = rng.uniform(-2, 2, size=(64, 3))
    hi = lo + rng.uniform(0, 1, size=(64, 3))
    flo, fhi, maybe_nan = model.eval_interval(lo, hi)
    assert flo.shape == fhi.shape == maybe_nan.shape == (64,)
    assert maybe_nan.dtype == np.bool_ and not maybe_nan.any()
    for _ in range(20):
        t = rng.uniform(0, 1, size=(64, 3))
        v = ball(1.5, lo + t * (hi - lo))
        assert np.all(flo <= v) and np.all(v <= fhi)
    lo1, hi1, nan1 = model.eval_interval([0, 0, 0], [1, 1, 1])
    assert lo1 <= ball(1.5, [[1, 1, 1]])[0] and hi1 >= 2.25 and nan1 is False


def test_eval_interval_errors(model):
    with pytest.raises(ValueError, match="lo = 2.000000 is not <= hi = 1.000000"):
        model.eval_interval([[0, 2, 0]], [[1, 1, 1]])
    with pytest.raises(ValueError, match="same shape"):
        model.eval_interval(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="columns"):
        model.eval_interval(np.zeros((2, 2)), np.ones((2, 2)))


@pytest.mark.parametrize("dtype,tol", [(np.float64, 1e-12), (np.float32, 1e-5)])
def test_gradient_is_the_closed_form(model, dtype, tol):
    p = rng_points(777).astype(dtype)
    g = model.gradient(p)
    assert g.shape == (777, 4) and g.dtype == dtype
    q = p.astype(np.float64)
    np.testing.assert_allclose(g[:, 0], ball(1.5, q), atol=tol)
    np.testing.assert_allclose(g[:, 1:], -2 * q, atol=tol)
    one = model.gradient([1.0, 0.0, 0.5])
    np.testing.assert_allclose(one, [2.25 - 1.25, -2, 0, -1], atol=1e-12)


def test_eval_into_out():
    m = hfrt.Model(BALL, params=[2.0])
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    out = np.full(3, -7.0)
    r = m.eval(pts, out=out)
    assert r is out or np.shares_memory(r, out)
    np.testing.assert_array_equal(out, [4.0, 3.0, 0.0])
    out32 = np.zeros(3, dtype=np.float32)
    m.eval(pts.astype(np.float32), out=out32)
    np.testing.assert_array_equal(out32, [4.0, 3.0, 0.0])
    f, s = m.eval(pts, attributes=True, out=out)
    assert np.shares_memory(f, out) and s.shape == (3, 2)
    with pytest.raises(TypeError, match=r"eval: out must have the points' dtype \(float64\)"):
        m.eval(pts, out=out32)
    with pytest.raises(ValueError, match=r"eval: out must have shape \(3,\)"):
        m.eval(pts, out=np.zeros(4))
    with pytest.raises(ValueError, match="eval: out must be contiguous and writable"):
        m.eval(pts, out=np.zeros(6)[::2])
    with pytest.raises(TypeError, match="eval: out must be a NumPy array"):
        m.eval(pts, out=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="eval: out is for arrays of points"):
        m.eval([1.0, 0, 0], out=np.zeros(1))


def test_set_params(model):
    m = hfrt.Model(BALL)
    assert m.params == [0.0]
    m.set_params([2])
    assert m.params == [2.0] and m.eval([1.0, 0, 0]) == 3.0
    m.set_params(np.array([1.0]))
    assert m.eval([1.0, 0, 0]) == 0.0
    with pytest.raises(ValueError, match="set_params: 2 values"):
        m.set_params([1, 2])


# ---- threads and the GIL -------------------------------------------------------------------

def test_concurrent_eval_matches_serial(model):
    pts = [rng_points(20000, seed=s) for s in range(16)]
    serial = [model.eval(p) for p in pts]
    with ThreadPoolExecutor(8) as ex:
        par = list(ex.map(model.eval, pts))
    for a, b in zip(serial, par):
        np.testing.assert_array_equal(a, b)


def test_set_params_beside_concurrent_evals():
    m = hfrt.Model(BALL, params=[1.0])
    p = rng_points(20000)
    r1, r2 = ball(1.0, p), ball(2.0, p)
    stop = threading.Event()
    bad = []

    def worker():
        while not stop.is_set():
            f = m.eval(p)
            if not (np.allclose(f, r1, atol=1e-12, rtol=0) or np.allclose(f, r2, atol=1e-12, rtol=0)):
                bad.append(f)

    ts = [threading.Thread(target=worker) for _ in range(4)]
    for t in ts:
        t.start()
    for i in range(200):
        m.set_params([1.0 if i % 2 else 2.0])
    stop.set()
    for t in ts:
        t.join()
    assert not bad


def _runs_beside(call):
    """How many samples another Python thread took while `call` ran inside hfrt."""
    span = {}
    samples = []
    done = threading.Event()

    def worker():
        span["t0"] = time.perf_counter()
        call()
        span["t1"] = time.perf_counter()
        done.set()

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    try:
        t = threading.Thread(target=worker)
        t.start()
        while not done.is_set():
            samples.append(time.perf_counter())
            time.sleep(0)
        t.join()
    finally:
        sys.setswitchinterval(old)
    t0, t1 = span["t0"], span["t1"]
    assert t1 - t0 > 0.02, "the call is too short to tell"
    # Samples well inside the call (the Python wrapper around it takes microseconds).
    margin = 0.25 * (t1 - t0)
    return sum(t0 + margin < s < t1 - margin for s in samples)


def test_gil_is_released_during_eval():
    m = hfrt.Model("my_model(x[3], a[1]) { my_model = sin(x[1]) * cos(x[2]) + exp(-x[3]*x[3]) - 0.5; }")
    p = rng_points(3_000_000)
    m.eval(p[:8])
    assert _runs_beside(lambda: m.eval(p)) > 10


def test_gil_is_released_during_render(model):
    assert _runs_beside(lambda: hfrt.render(model, size=(384, 384), threads=1)) > 10


# ---- render --------------------------------------------------------------------------------

def test_render_covers_the_disk(model):
    m = hfrt.Model(BALL, params=[1.0])
    img = hfrt.render(m, size=(64, 48), camera={"eye": [0, 0, 10], "look_at": [0, 0, 0],
                                                "ortho": 4}, bbox=2, spp=4)
    assert img.shape == (48, 64, 4) and img.dtype == np.float32
    # A disk of radius 1 in a 4 x 3 view.
    assert abs(img[..., 3].mean() - math.pi / 12) < 0.01
    assert img[0, 0, 3] == 0 and img[24, 32, 3] == 1
    np.testing.assert_allclose(img[0, 0, :3], [0.18, 0.2, 0.24], atol=1e-6)
    img2 = m.render(size=16, background=[1, 0, 0])
    assert img2.shape == (16, 16, 4)


def test_set_time_moves_a_model_in_renders():
    # Time (issue 24): x[4] of the model; eval takes it from the points, renders from set_time.
    m = hfrt.Model("m(x[4], a[1]) { m = 1 - (x[1] - (-2 + 4 * x[4]))^2 - x[2]^2 - x[3]^2; }")
    assert m.time == 0.0
    assert m.eval([1.0, 0, 0, 0.75]) == 1.0
    xs = (np.arange(64) + 0.5) / 8 - 4
    for t in (0.0, 0.75):
        m.set_time(t)
        assert m.time == t
        img = m.render(size=(64, 16), camera={"eye": [0, 0, 10], "look_at": [0, 0, 0],
                                              "ortho": 8}, bbox=[-4, -2, -2, 4, 2, 2])
        a = img[8, :, 3]
        assert abs((a * xs).sum() / a.sum() - (-2 + 4 * t)) < 0.07
    with pytest.raises(ValueError, match="set_time: time is not a finite number"):
        m.set_time(float("nan"))


def test_render_errors(model, tmp_path):
    with pytest.raises(ValueError, match="root"):
        hfrt.render(model, size=8, root="nope")
    with pytest.raises(ValueError, match="camera: unknown key 'zoom'"):
        hfrt.render(model, size=8, camera={"zoom": 2})
    with pytest.raises(ValueError, match="size"):
        hfrt.render(model, size=(0, 8))
    with pytest.raises(ValueError, match="spp"):
        hfrt.render(model, size=8, spp=0)
    with pytest.raises(ValueError, match="bbox"):
        hfrt.render(model, size=8, bbox=[1, 2, 3])
    with pytest.raises(RuntimeError):
        hfrt.render(model, size=8, camera={"eye": [0, 0, 0], "look_at": [0, 0, 0]})
    (tmp_path / "bad.toml").write_text("[render]\nspp = 0\n")
    with pytest.raises(hfrt.CompileError, match="bad.toml:2:7: error"):
        hfrt.render(tmp_path / "bad.toml", size=8)
    with pytest.raises(ValueError, match="scene file sets camera"):
        hfrt.render(tmp_path / "bad.toml", size=8, camera={"fov": 30})
    with pytest.raises(TypeError):
        hfrt.render(3.0)
    m = hfrt.Model("my_model(x[3], a[1])\n{\n  my_model = 1 - sin(x[1]) - x[2]*x[2];\n}\n",
                   name="sin.hf")
    with pytest.raises(hfrt.CompileError, match="sin.hf:3:"):
        hfrt.render(m, size=8, root="analytic")


def test_render_a_scene_file(tmp_path):
    # An emitting ball of a known colour, seen orthographically: the centre pixel has exactly
    # that colour, a corner the scene's background.
    (tmp_path / "ball.hf").write_text(
        "my_model(x[3], a[1]) { my_model = 1 - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }\n")
    (tmp_path / "s.toml").write_text(
        "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\northo = 4\n"
        "[render]\nbackground = [0, 0, 1]\n"
        "[material.lamp]\ncolor = [0.25, 0.5, 0.75]\nambient = 1\ndiffuse = 0\nspecular = 0\n"
        "[[object]]\nfile = \"ball.hf\"\nbbox = [-2, -2, -2, 2, 2, 2]\nmaterial = \"lamp\"\n")
    img = hfrt.render(tmp_path / "s.toml", size=(16, 12), threads=2)
    assert img.shape == (12, 16, 4) and img.dtype == np.float32
    assert np.allclose(img[6, 8], [0.25, 0.5, 0.75, 1.0])
    assert np.allclose(img[0, 0], [0, 0, 1, 0])


def test_render_a_path_and_write_image(tmp_path):
    img = hfrt.render(CORPUS / "models/web/frep_org__hf_objects__Sphere.hf", size=(32, 24))
    assert img.shape == (24, 32, 4) and img[..., 3].max() == 1
    out = tmp_path / "out.png"
    hfrt.write_image(out, img)
    assert out.stat().st_size > 0
    with pytest.raises(ValueError):
        hfrt.write_image(tmp_path / "x.png", np.zeros((4, 4, 3), np.float32))
    with pytest.raises(RuntimeError):
        hfrt.write_image("/nonexistent/dir/x.png", img)


# ---- python3 -m hfrt -----------------------------------------------------------------------

def _py(args, **kw):
    return subprocess.run([sys.executable, "-m", "hfrt"] + args, capture_output=True, text=True,
                          **kw)


def test_main_eval_matches_the_hfrt_executable():
    model = str(CORPUS / "models/web/hyperfun_org__sample_model__superell_torus_soft.hf")
    pts = "".join(f"{a} {b} {c}\n" for a in (-1.5, 0.25, 2 / 3) for b in (0.0, 1.1, -3)
                  for c in (0.5, -0.7))
    ref = subprocess.run([HFRT_EXE, "eval", model], input=pts, capture_output=True, text=True)
    assert ref.returncode == 0, ref.stderr
    got = _py(["eval", model], input=pts)
    assert got.returncode == 0, got.stderr
    assert got.stdout == ref.stdout


def test_main_render_writes_an_image(tmp_path):
    out = tmp_path / "s.png"
    r = _py(["render", str(CORPUS / "models/web/frep_org__hf_objects__Sphere.hf"), "-o", str(out),
             "--size", "40x30", "--eye", "0,0,30", "--look-at", "0,0,0"])
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 0 and "wrote" in r.stderr
    bad = tmp_path / "bad.hf"
    bad.write_text("my_model(x[3], a[1]) { my_model = ; }\n")
    r = _py(["render", str(bad), "-o", str(out)])
    assert r.returncode == 1 and f"{bad}:1:" in r.stderr
    r = _py(["render", str(bad), "-o", str(out), "--size", "big"])
    assert r.returncode == 2 and "--size" in r.stderr


# -- limits on hostile input (docs/limits.md) ---------------------------------------------

ENDLESS = ("my_model(x[3], a[1])\n{\n  i = 0;\n  while x[1] > 0 loop i = i + 1; endloop;\n"
           "  my_model = i;\n}\n")


def test_limits_are_keyword_arguments():
    m = hfrt.Model(ENDLESS, max_loop_iterations=100)
    vals = m.eval(np.array([[1.0, 0, 0], [-1.0, 0, 0]]))
    assert math.isnan(vals[0]) and vals[1] == 0
    counted = ("my_model(x[3], a[1]) { i = 0; while i < x[1] loop i = i + 1; endloop; "
               "my_model = i; }")
    m = hfrt.Model(counted, max_loop_iterations=100)
    assert m.eval([100.0, 0, 0]) == 100
    assert math.isnan(m.eval([101.0, 0, 0]))
    with pytest.raises(hfrt.CompileError, match="more than the limit of 2 elements") as e:
        hfrt.Model("m(x[3], a[1]) { m = 1; }", name="arr.hf", max_array_size=2)
    assert (e.value.line, e.value.column) == (1, 5)
    assert "max_loop_iterations" in hfrt.LIMITS


def test_bad_limits_are_errors():
    with pytest.raises(TypeError, match="max_loops"):
        hfrt.Model(BALL, max_loops=3)
    with pytest.raises(ValueError, match="max_slots must be at least 1"):
        hfrt.Model(BALL, max_slots=0)
    with pytest.raises(ValueError, match="max_loop_iterations must be from 1 to 16777216"):
        hfrt.Model(BALL, max_loop_iterations=1 << 25)
    with pytest.raises(TypeError, match="must be an int"):
        hfrt.Model(BALL, max_mesh_bytes=1.5)
    with pytest.raises(ValueError, match="max_exact_curves must be at least 1"):
        hfrt.Model(BALL, max_exact_curves=0)


def test_dev_zero_mesh_is_a_located_error_that_comes_back_quickly():
    t0 = time.monotonic()
    with pytest.raises(hfrt.CompileError, match="/dev/zero: is not a regular file") as e:
        hfrt.Model('my_model(x[3], a[1]) {\n  my_model = hfMesh(x, "/dev/zero");\n}\n')
    assert (e.value.line, e.value.column) == (2, 14)
    assert time.monotonic() - t0 < 60


def test_max_exact_curves_picks_the_tessellated_patch_field():
    # Below the teapot's 16 open border curves its field goes through the tessellation, off
    # by up to its measured error (~2e-3) near the surface; by default it is exact.
    teapot = pathlib.Path(__file__).resolve().parents[2] / "examples" / "teapot.hf"
    pts = np.array([[1.5, 1.0, 0.4], [0.5, 2.0, 0.3], [-1.2, 0.8, -0.9]])
    exact = hfrt.Model(teapot).eval(pts)
    tessellated = hfrt.Model(teapot, max_exact_curves=8).eval(pts)
    diff = np.max(np.abs(exact - tessellated))
    assert 1e-6 < diff < 3e-3
