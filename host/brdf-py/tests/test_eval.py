"""`brdf.eval` and friends: the CLI's values bit for bit, broadcasting, dtypes, errors."""

import csv
import os
import re
import time
import io

import numpy as np
import pytest

import brdf

KHAKI = "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2"
KHAKI_DICT = {"kb": 0.2545, "kr": 21.8031, "b": -27.5721, "a": 0.6705, "kd": 0.3676, "c": 1.2}


def grid(root):
    rows = list(csv.DictReader(open(root / "data" / "angles-grid.csv")))
    return [np.array([float(r[k]) for r in rows]) for k in ("theta_i", "theta_r", "phi")]


def cli_values(cli, root, precision):
    out = cli("eval", "--model", "six", "--params", KHAKI, "--precision", precision,
              root / "data" / "angles-grid.csv").stdout
    return [r["brdf"] for r in csv.DictReader(io.StringIO(out))]


@pytest.mark.parametrize("precision,dtype", [("f64", np.float64), ("f32", np.float32)])
def test_values_equal_the_cli_bit_for_bit(cli, root, precision, dtype):
    ti, tr, phi = grid(root)
    got = brdf.eval("six", KHAKI, ti, tr, phi, precision=precision)
    assert got.dtype == dtype
    want = np.array([float(t) for t in cli_values(cli, root, precision)], dtype=dtype)
    # 17 (f64) and 9 (f32) significant digits name the value exactly.
    assert got.tobytes() == want.tobytes()


def test_dict_params_equal_string_params(root):
    ti, tr, phi = grid(root)
    a = brdf.eval("six", KHAKI, ti, tr, phi)
    b = brdf.eval("six", KHAKI_DICT, ti, tr, phi)
    assert a.tobytes() == b.tobytes()


def test_broadcasting_follows_numpy():
    ti = np.array([0.0, 30.0, 60.0])[:, None]
    tr = np.linspace(0, 80, 5)[None, :]
    out = brdf.eval("six", KHAKI, ti, tr, 180.0)
    assert out.shape == (3, 5)
    for i in range(3):
        for j in range(5):
            assert out[i, j] == brdf.eval("six", KHAKI, ti[i, 0], tr[0, j], 180.0)


def test_zero_d_inputs_give_a_scalar():
    v = brdf.eval("six", KHAKI, 10, 20, 180)
    assert np.ndim(v) == 0 and np.isfinite(v)


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.int32, np.int64, np.uint8])
def test_every_real_dtype_is_read_as_float64(dtype):
    ti = np.array([0, 10, 45], dtype=dtype)
    want = brdf.eval("six", KHAKI, ti.astype(np.float64), 30.0, 180.0)
    assert brdf.eval("six", KHAKI, ti, 30.0, 180.0).tobytes() == want.tobytes()


def test_non_contiguous_and_reversed_views():
    base = np.linspace(0, 89, 40)
    view = base[::3]
    rev = base[::-1][::2]
    assert not view.flags.c_contiguous
    got = brdf.eval("six", KHAKI, view, view[::-1], 170.0)
    want = brdf.eval("six", KHAKI, view.copy(), view[::-1].copy(), 170.0)
    assert got.tobytes() == want.tobytes()
    f = np.asfortranarray(np.stack([rev[:10], rev[10:]]))
    assert brdf.eval("six", KHAKI, f, 0, 0).tobytes() == brdf.eval("six", KHAKI, f.copy(order="C"), 0, 0).tobytes()


@pytest.mark.parametrize("bad", [np.array([1 + 2j]), np.array(["10"]), np.array([None], dtype=object)])
def test_non_real_dtypes_raise_clearly(bad):
    with pytest.raises(TypeError, match="theta_i: dtype .* is not a real number type"):
        brdf.eval("six", KHAKI, bad, 0, 0)


def test_a_bad_angle_is_located_by_index():
    ti = np.zeros((2, 3))
    ti[1, 2] = 95
    with pytest.raises(ValueError, match=r"index \[1, 2\]: column theta_i: zenith 95 deg is outside \[0, 90\]"):
        brdf.eval("six", KHAKI, ti, 0, 0)
    with pytest.raises(ValueError, match=r"index \[1\]: column phi: `NaN` is not finite"):
        brdf.eval("six", KHAKI, 0, 0, [0, np.nan])


def test_the_cli_rejects_the_same_zenith(cli, tmp_path):
    f = tmp_path / "a.csv"
    f.write_text("theta_i,theta_r,phi\n0,0,0\n95,0,0\n")
    p = cli("eval", "--model", "six", "--params", KHAKI, f, check=False)
    assert p.returncode != 0
    assert "line 3: column theta_i: zenith 95 deg is outside [0, 90]" in p.stderr


def test_model_and_parameter_errors_carry_the_cli_message(cli, tmp_path):
    with pytest.raises(ValueError, match="unknown model `sx`"):
        brdf.eval("sx", KHAKI, 0, 0, 0)
    f = tmp_path / "a.csv"
    f.write_text("theta_i,theta_r,phi\n0,0,0\n")
    p = cli("eval", "--model", "six", "--params", "kb=0.2", f, check=False)
    msg = p.stderr.strip().splitlines()[-1].split(": ", 1)[1]
    with pytest.raises(ValueError) as e:
        brdf.eval("six", "kb=0.2", 0, 0, 0)
    assert str(e.value) == msg


def test_shapes_that_do_not_broadcast_raise():
    with pytest.raises(ValueError, match="shapes do not broadcast"):
        brdf.eval("six", KHAKI, np.zeros(3), np.zeros(4), 0)


def test_cosines_and_vectors_agree_with_angles():
    ti, tr, phi = np.array([10.0, 40.0]), np.array([20.0, 70.0]), np.array([180.0, 30.0])
    a = brdf.eval("six", KHAKI, ti, tr, phi)
    r = np.radians
    c = brdf.eval_cosines("six", KHAKI, np.cos(r(ti)), np.cos(r(tr)), np.cos(r(phi)))
    wi = np.stack([np.sin(r(ti)), np.zeros(2), np.cos(r(ti))], axis=-1)
    wr = np.stack([np.sin(r(tr)) * np.cos(r(phi)), np.sin(r(tr)) * np.sin(r(phi)), np.cos(r(tr))], axis=-1)
    v = brdf.eval_vectors("six", KHAKI, wi, wr)
    assert c.shape == v.shape == (2,)
    # Three input forms of the batch path (brdf_core::tolerance::BATCH_F64_REL).
    np.testing.assert_allclose(c, a, rtol=brdf._brdf.BATCH_F64_REL)
    np.testing.assert_allclose(v, a, rtol=brdf._brdf.BATCH_F64_REL)


def test_vectors_need_three_components_and_unit_length():
    with pytest.raises(ValueError, match="last axis must hold x, y, z"):
        brdf.eval_vectors("six", KHAKI, [0, 1], [0, 0, 1])
    with pytest.raises(ValueError, match=r"index \[1\]"):
        brdf.eval_vectors("six", KHAKI, [[0, 0, 1], [0, 0, 2]], [0, 0, 1])


def test_the_gil_is_released_while_the_core_runs():
    import threading
    import time

    n = 3_000_000
    ti = np.full(n, 30.0)
    stamps = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    time.sleep(0.02)
    t0 = time.perf_counter()
    brdf.eval("six", KHAKI, ti, 40.0, 180.0)
    t1 = time.perf_counter()
    stop.set()
    t.join()
    inside = [s for s in stamps if t0 <= s <= t1]
    # With the GIL held the other thread could not run at all during the call.
    assert t1 - t0 > 0.02 and len(inside) >= 3, (t1 - t0, len(inside))


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_all_cores_give_one_threads_values_bit_for_bit(precision):
    # 100,003 directions: 13 parallel chunks of 8,192 and a ragged tail.
    rng = np.random.default_rng(7)
    n = 100_003
    ti, tr, phi = rng.uniform(0, 89, n), rng.uniform(0, 89, n), rng.uniform(-360, 360, n)
    one = brdf.eval("six", KHAKI, ti, tr, phi, precision=precision, threads=1)
    assert brdf.eval("six", KHAKI, ti, tr, phi, precision=precision).tobytes() == one.tobytes()
    # A pool of its own size: three threads on any machine.
    assert brdf.eval("six", KHAKI, ti, tr, phi, precision=precision, threads=3).tobytes() == one.tobytes()
    c = [np.cos(np.deg2rad(x)) for x in (ti, tr, phi)]
    one = brdf.eval_cosines("six", KHAKI, *c, precision=precision, threads=1)
    assert brdf.eval_cosines("six", KHAKI, *c, precision=precision).tobytes() == one.tobytes()
    assert brdf.eval_cosines("six", KHAKI, *c, precision=precision, threads=2).tobytes() == one.tobytes()
    # The first bad element is still the one named, wherever its chunk runs.
    ti[n - 5] = 95
    ti[50_000] = 91
    with pytest.raises(ValueError, match=r"index \[50000\]: column theta_i: zenith 91 deg"):
        brdf.eval("six", KHAKI, ti, tr, phi, precision=precision)


def test_eval_fit_is_the_cli_eval_fit(cli, root, tmp_path):
    """`brdf.eval_fit` and `FitResult.eval` give the values of `brdf eval --fit`, bit for bit."""
    r = brdf.fit(str(root / "data/khaki-synthetic-inplane.csv"))
    path = tmp_path / "fit.json"
    path.write_text(r.to_json() + "\n")
    ti, tr, ph = [0.0, 10.0, 30.0, 60.0], [0.0, 10.0, 40.0, 85.0], [0.0, 0.0, 180.0, 90.0]
    angles = tmp_path / "a.csv"
    angles.write_text("theta_i,theta_r,phi\n" + "".join(f"{a},{b},{c}\n" for a, b, c in zip(ti, tr, ph)))
    for precision, dtype in (("f64", np.float64), ("f32", np.float32)):
        out = cli("eval", "--fit", path, "--precision", precision, angles).stdout.splitlines()[1:]
        want = np.array([float(line.split(",")[-1]) for line in out], dtype=dtype)
        np.testing.assert_array_equal(brdf.eval_fit(path, ti, tr, ph, precision=precision), want)
        np.testing.assert_array_equal(r.eval(ti, tr, ph, precision=precision), want)


def test_eval_fit_errors_are_the_cli_messages(cli, tmp_path):
    batch = tmp_path / "batch.json"
    batch.write_text('[{"model": "lambert", "params": {"rho0": 0.25}}, {"model": "minnaert", "params": {"rho0": 0.5, "k": 0.9}}]')
    angles = tmp_path / "a.csv"
    angles.write_text("theta_i,theta_r,phi\n10,20,30\n")
    np.testing.assert_array_equal(
        brdf.eval_fit(batch, 10, 20, 30, index=0), brdf.eval("lambert", "rho0=0.25", 10, 20, 30)
    )
    for index in (None, 2):
        args = ["eval", "--fit", batch, angles] + ([] if index is None else ["--index", str(index)])
        p = cli(*args, check=False)
        assert p.returncode != 0
        with pytest.raises(ValueError) as e:
            brdf.eval_fit(batch, 10, 20, 30, index=index)
        assert str(e.value) in p.stderr, (str(e.value), p.stderr)
    with pytest.raises(ValueError, match="index: `-1` is not a whole number >= 0"):
        brdf.eval_fit(batch, 10, 20, 30, index=-1)


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="counts threads through /proc")
def test_many_thread_counts_leave_one_pool():
    def threads():
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("Threads:"))

    x = np.linspace(0.0, 80.0, 20_000)
    brdf.eval("lambert", "rho0=0.5", x, x, x, threads=3)
    before = threads()
    # Each size replaced the last: a pool kept per size started 2 + ... + 60 = 1,829 threads.
    for n in range(2, 61):
        brdf.eval("lambert", "rho0=0.5", x, x, x, threads=n)
    time.sleep(0.5)  # replaced pools' threads end
    assert threads() <= before + 60, (before, threads())


def test_albedo_panels_outside_their_range_are_refused_by_name():
    # Before: 65535 panels ran for about an hour per incidence and 10**6 raised OverflowError.
    with pytest.raises(ValueError, match=r"panels 1 is outside 2\.\.=(\d+)") as e:
        brdf.albedo("lambert", "rho0=0.5", [0.0], panels=1)
    most = int(re.search(r"\.\.=(\d+)", str(e.value)).group(1))
    for bad in (most + 1, 65535, 10**6, 2**64 - 1):
        with pytest.raises(ValueError, match=rf"panels {bad} is outside 2\.\.={most} \(the quadrature's cost"):
            brdf.albedo("lambert", "rho0=0.5", [0.0], panels=bad)
    with pytest.raises(ValueError, match="panels"):
        brdf.albedo("lambert", "rho0=0.5", [0.0], panels=10**30)
    # The smallest count is accepted.
    assert np.isfinite(brdf.albedo("lambert", "rho0=0.5", [0.0], panels=2)).all()


def test_flags_and_counts_of_the_wrong_type_are_refused():
    # Before: panels=2.9 ran with 2 panels, parallel="no" ran in parallel.
    with pytest.raises(TypeError, match="panels must be a whole number, not 2.9"):
        brdf.albedo("lambert", "rho0=0.5", [0.0], panels=2.9)
    for bad in ("no", True, 2.0):
        with pytest.raises(TypeError, match="threads must be None or a whole number"):
            brdf.eval("lambert", "rho0=0.5", 0, 0, 0, threads=bad)
    for bad in (0, -1, 257):
        with pytest.raises(ValueError, match=f"threads {bad}: give 1 to 256"):
            brdf.eval("lambert", "rho0=0.5", 0, 0, 0, threads=bad)


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_azimuths_beyond_two_turns_are_refused(precision):
    # 1e20 deg was evaluated as 280 deg in f64 (its phase lost); 1e300 overflowed f32 and was
    # blamed on the model.
    assert brdf.eval("lambert", "rho0=0.5", 30, 30, [-720, 720], precision=precision).shape == (2,)
    for phi in (1e20, 1e300, 720.5):
        with pytest.raises(ValueError, match=r"theta_i/theta_r/phi at index \[1\]: column phi: azimuth .* outside \[-720, 720\]"):
            brdf.eval("lambert", "rho0=0.5", 30, 30, [10, phi], precision=precision)


def test_masked_arrays_are_refused_not_unmasked():
    # np.asarray dropped the mask, so masked elements were evaluated and fitted.
    m = np.ma.masked_array([10.0, 20.0], mask=[False, True])
    with pytest.raises(TypeError, match="theta_r: a masked array"):
        brdf.eval("lambert", {"rho0": 0.5}, 10.0, m, 0.0)
    data = {"theta_i": [10.0, 20.0], "theta_r": m, "phi": [0.0, 0.0], "brdf": [0.1, 0.1]}
    with pytest.raises(TypeError, match="masked array"):
        brdf.fit(data, model="lambert")


SPECTRAL = (
    '[{"dataset": "p.csv[wavelength=0.6]", "model": "lambert", "params": {"rho0": 0.5}},'
    ' {"dataset": "p.csv[wavelength=0.5]", "model": "six", "params": '
    '{"kb": 0.2545, "kr": 21.8031, "b": -27.5721, "a": 0.6705, "kd": 0.3676, "c": 1.2}}]'
)


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_eval_fit_of_a_spectral_fit_is_the_cli_at_each_wavelength(cli, tmp_path, precision):
    """Bands picked or blended per element, as `brdf eval --fit` does per row, bit for bit."""
    fits = tmp_path / "fits.json"
    fits.write_text(SPECTRAL)
    ti, tr, ph = [30.0, 30.0, 10.0, 60.0], [40.0, 40.0, 20.0, 85.0], [180.0, 180.0, 90.0, 0.0]
    um = [0.5, 0.575, 0.6, 0.55]
    angles = tmp_path / "a.csv"
    angles.write_text(
        "theta_i,theta_r,phi,wavelength\n" + "".join(f"{a},{b},{c},{w}\n" for a, b, c, w in zip(ti, tr, ph, um))
    )
    out = cli("eval", "--fit", fits, "--precision", precision, angles).stdout.splitlines()[1:]
    dtype = np.float64 if precision == "f64" else np.float32
    want = np.array([float(line.split(",")[-1]) for line in out], dtype=dtype)
    got = brdf.eval_fit(fits, ti, tr, ph, wavelength=um, precision=precision)
    assert got.dtype == dtype
    np.testing.assert_allclose(got, want, rtol=1e-15 if precision == "f64" else 1e-6)
    # A scalar wavelength broadcasts; one band is `eval` of that band bit for bit.
    np.testing.assert_array_equal(
        brdf.eval_fit(fits, ti, tr, ph, wavelength=0.6, precision=precision),
        brdf.eval("lambert", "rho0=0.5", ti, tr, ph, precision=precision),
    )


def test_eval_fit_of_a_spectral_fit_refuses_what_the_cli_refuses(cli, tmp_path):
    fits = tmp_path / "fits.json"
    fits.write_text(SPECTRAL)
    angles = tmp_path / "a.csv"
    angles.write_text("theta_i,theta_r,phi\n10,20,30\n")
    # No wavelength for two bands: the CLI's words.
    p = cli("eval", "--fit", fits, angles, check=False)
    assert p.returncode != 0 and "holds 2 bands of p.csv (0.5–0.6 µm)" in p.stderr
    with pytest.raises(ValueError, match=r"holds 2 bands of p.csv \(0.5–0.6 µm\): give wavelength="):
        brdf.eval_fit(fits, 10, 20, 30)
    # Outside the bands (no extrapolation), not a wavelength, or a grey fit: refused.
    with pytest.raises(ValueError, match="outside the bands of p.csv: its 2 bands span 0.5–0.6 µm"):
        brdf.eval_fit(fits, [10, 10], 20, 30, wavelength=[0.55, 0.7])
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match=r"wavelength at index \[1\]: .* is not a wavelength above 0"):
            brdf.eval_fit(fits, [10, 10], 20, 30, wavelength=[0.55, bad])
    # A fit without bands is the same at every wavelength (as the CLI and scenes take it).
    grey = tmp_path / "grey.json"
    grey.write_text('{"model": "lambert", "params": {"rho0": 0.5}}')
    np.testing.assert_array_equal(
        brdf.eval_fit(grey, 10, 20, [30, 40], wavelength=[0.5, 7.0]), brdf.eval("lambert", "rho0=0.5", 10, 20, [30, 40])
    )
    # index picks one fit, as the CLI's --index.
    np.testing.assert_array_equal(brdf.eval_fit(fits, 10, 20, 30, index=0), brdf.eval("lambert", "rho0=0.5", 10, 20, 30))


def test_read_and_fit_carry_each_bands_wavelength(root):
    sets = brdf.read(root / "data/measured/cornell-spectral/garnet_red.astm", "cornell")
    assert len(sets) == 31
    assert [d["wavelength"] for d in sets[:3]] == [0.4, 0.41, 0.42]
    assert brdf.read(root / "data/khaki-synthetic-inplane.csv")[0]["wavelength"] is None
    r = brdf.fit(root / "data/measured/cornell-spectral/garnet_red.astm", format="cornell", band=0.55)
    assert r.wavelength == 0.55
    # A dataset of `read` fits as its band; arrays with a wavelength are named after it.
    assert brdf.fit(sets[15]).wavelength == 0.55
    arrays = {k: sets[15][k] for k in ("theta_i", "theta_r", "phi", "brdf")}
    assert brdf.fit({**arrays, "wavelength": 1.064}).dataset == "arrays[wavelength=1.064]"
    with pytest.raises(ValueError, match=r"wavelength 0.6 µm, but the name .* is of the band 0.55 µm"):
        brdf.fit({**sets[15], "wavelength": 0.6})
    with pytest.raises(ValueError, match="not a wavelength above 0"):
        brdf.fit({**arrays, "wavelength": -1.0})
    # A list of results evaluates at a wavelength between its bands.
    both = brdf.fit(root / "data/measured/cornell-spectral/garnet_red.astm", format="cornell", band=0.56)
    mid = brdf.eval_fit([r, both], 30, 30, 180, wavelength=0.555)
    np.testing.assert_allclose(mid, 0.5 * (r.eval(30, 30, 180) + both.eval(30, 30, 180)), rtol=1e-14)


def test_zenith_cosines_below_zero_are_refused_as_zeniths_beyond_90_deg_are():
    # Before: the docstring said zenith cosines lie in [0, 1], yet -0.1 (a zenith below the
    # horizon, which brdf.eval refuses in degrees) gave 0.0 without a word.
    names = r"cos_theta_i/cos_theta_r/cos_phi at index "
    for precision in ("f64", "f32"):
        with pytest.raises(ValueError, match=names + r"\[1\]: cos_theta_r = -0.1 is outside \[0, 1\]"):
            brdf.eval_cosines("six", KHAKI, [1.0, 0.5], [1.0, -0.1], [1.0, 1.0], precision=precision)
    with pytest.raises(ValueError, match=names + r"\[0, 1\]: cos_theta_i = -1 is outside \[0, 1\]"):
        brdf.eval_cosines("six", KHAKI, [[1.0, -1.0]], 1.0, 1.0)
    # The first bad element is the one named, whichever check it fails.
    with pytest.raises(ValueError, match=names + r"\[0\]: cos_phi is not finite"):
        brdf.eval_cosines("six", KHAKI, [1.0, -0.5], [1.0, 1.0], [np.nan, 1.0])
    with pytest.raises(ValueError, match=names + r"\[0\]: cos_theta_i = -0.5 is outside \[0, 1\]"):
        brdf.eval_cosines("six", KHAKI, [-0.5, 1.0], [1.0, 1.0], [1.0, np.nan])
    # The horizon (0, as 90 deg) and every azimuth cosine are taken, as brdf.eval takes them.
    got = brdf.eval_cosines("six", KHAKI, [0.0, -0.0, 0.5], [1.0, 1.0, 0.5], [-1.0, -1.0, -1.0])
    want = brdf.eval("six", KHAKI, [90.0, 90.0, 60.0], [0.0, 0.0, 60.0], [180.0, 180.0, 180.0])
    np.testing.assert_allclose(got, want, rtol=brdf._brdf.BATCH_F64_REL)
