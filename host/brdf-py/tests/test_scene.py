"""`brdf.scene_lrcs` and `brdf.scene_domain`: what `brdf scene lrcs --json` and `brdf scene
domain` print, as arrays, and the command's errors."""

import csv
import io
import json

import numpy as np
import pytest

import brdf

SCENE = "data/scenes/target.toml"
# The bundled scene's materials are all six-parameter; the sweep's JSON lists their values
# in this order.
SIX = ["kb", "kr", "b", "a", "kd", "c"]


def test_lrcs_is_the_cli_sweep(cli, root):
    want = json.loads(cli("scene", "lrcs", "--json", root / SCENE).stdout)
    got = brdf.scene_lrcs(root / SCENE)
    report = json.loads(got.to_json())
    assert report.pop("seconds") >= 0 and want.pop("seconds") >= 0
    assert report == want
    aspects = want["aspects"]
    assert len(got.lrcs) == len(aspects) == 216
    assert got.azimuth.tolist() == [a["azimuth"] for a in aspects]
    assert got.elevation.tolist() == [a["elevation"] for a in aspects]
    assert got.lrcs.tolist() == [a["lrcs"] for a in aspects]
    assert got.by_material.tolist() == [a["by_material"] for a in aspects]
    assert got.facets_seen.tolist() == [a["facets_seen"] for a in aspects]
    assert got.parts == [m["part"] for m in want["materials"]] == ["hull", "caps", "fin"]
    assert got.by_material.shape == (216, 3)
    # sigma is the sum of the materials' shares, and something is seen at every aspect.
    np.testing.assert_allclose(got.by_material.sum(axis=1), got.lrcs, rtol=brdf._brdf.F64_REFORMULATION_REL)
    assert (got.lrcs > 0).all()


def test_lrcs_by_area_is_the_cli_sweep_with_its_bounds(cli, root):
    want = json.loads(cli("scene", "lrcs", "--json", "--visibility", "area", root / SCENE).stdout)
    got = brdf.scene_lrcs(root / SCENE, visibility="area")
    report = json.loads(got.to_json())
    assert report.pop("seconds") >= 0 and want.pop("seconds") >= 0
    assert report == want
    assert got.sampling_bound.tolist() == [a["sampling_bound"] for a in want["aspects"]]
    assert (got.sampling_bound > 0).all()
    assert brdf.scene_lrcs(root / SCENE).sampling_bound is None
    # The resolution given reaches the sweep: the bound shrinks with the pixel size.
    fine = brdf.scene_lrcs(root / SCENE, visibility="area", pixels=2 * brdf.SWEEP_PIXELS, supersample=brdf.SUPERSAMPLE)
    assert fine.sampling_bound.max() < got.sampling_bound.max()
    for kwargs, error in [
        ({"visibility": "Area"}, ValueError),
        ({"visibility": 1}, ValueError),
        ({"pixels": 64}, ValueError),
        ({"visibility": "area", "pixels": 64.0}, TypeError),
        ({"visibility": "area", "pixels": True}, TypeError),
        ({"visibility": "area", "supersample": 0}, ValueError),
        ({"visibility": "area", "pixels": 5000}, ValueError),
        ({"visibility": "area", "pixels": 2**64}, ValueError),
        ({"visibility": "area", "supersample": 2**70}, ValueError),
    ]:
        with pytest.raises(error):
            brdf.scene_lrcs(root / SCENE, **kwargs)


def test_domain_is_the_cli_file(cli, root):
    rows = list(csv.DictReader(io.StringIO(cli("scene", "domain", root / SCENE).stdout)))
    got = brdf.scene_domain(root / SCENE)
    assert len(rows) == len(got["theta_i"]) == 221321
    for key in ("azimuth", "elevation", "theta_i", "theta_r", "phi", "weight"):
        # The CLI writes the shortest decimal that reads back as the same f64.
        assert got[key].tolist() == [float(r[key]) for r in rows], key
    for key in ("material", "facet"):
        assert got[key].tolist() == [int(r[key]) for r in rows], key
    assert got["part"] == [r["part"] for r in rows]
    # sigma at each aspect is the sum of weight * brdf over its queries: the domain and the
    # sweep agree for the scene's own models.
    lr = brdf.scene_lrcs(root / SCENE)
    scene_models = json.loads(lr.to_json())["materials"]
    f = np.empty_like(got["weight"])
    for k, m in enumerate(scene_models):
        sel = got["material"] == k
        assert m["model"] == "six"
        params = dict(zip(SIX, m["params"]))
        f[sel] = brdf.eval(m["model"], params, got["theta_i"][sel], got["theta_r"][sel], got["phi"][sel])
    sigma = {}
    for a, e, w, v in zip(got["azimuth"], got["elevation"], got["weight"], f):
        sigma[(a, e)] = sigma.get((a, e), 0.0) + w * v
    want = {(a, e): s for a, e, s in zip(lr.azimuth, lr.elevation, lr.lrcs)}
    assert sigma.keys() == want.keys()
    worst = max(abs(sigma[k] - want[k]) / want[k] for k in want)
    print(f"sigma from the domain against the sweep: worst relative difference {worst:.2e}")
    assert worst <= brdf._brdf.F64_REFORMULATION_REL


def test_errors_are_the_cli_messages(cli, root, tmp_path):
    missing = tmp_path / "none.toml"
    bad = tmp_path / "bad.toml"
    bad.write_text("bad = [")
    for path in (missing, bad):
        stderr = cli("scene", "lrcs", path, check=False).stderr.strip()
        assert stderr.startswith("error: cannot use scene")
        for fn in (brdf.scene_lrcs, brdf.scene_domain):
            with pytest.raises(ValueError) as e:
                fn(path)
            assert "error: " + str(e.value) == stderr


@pytest.mark.parametrize("flags,kwargs", [([], {}), (["--budget", "1%", "--seed", "3"], {"budget": 0.01, "seed": 3})])
def test_select_scene_is_the_cli_choice_and_blob(cli, root, tmp_path, flags, kwargs):
    out = tmp_path / "scene.bin"
    text = cli("select", "--scene", root / SCENE, "--json", *flags).stdout
    cli("select", "--scene", root / SCENE, "-o", out, "--sequence", "5", *flags)
    s = brdf.select_scene(root / SCENE, sequence=5, **kwargs)
    assert s.to_json() + "\n" == text
    want = json.loads(text)
    assert s.chosen == [m["candidates"][m["chosen"]]["name"] for m in want["materials"]]
    assert s.blob == out.read_bytes() and s.blob_note is None
    # Every choice is within the budget and no cheaper candidate is.
    budget = kwargs.get("budget", 0.02)
    for m in s.materials:
        c = m["candidates"][m["chosen"]]
        assert c["worst_sigma_error"] <= budget and c["fits_blob"]
        assert all(not (d["within_budget"] and d["fits_blob"]) for d in m["candidates"][: m["chosen"]])


def test_select_scene_refuses_a_bad_budget_and_scene(tmp_path):
    with pytest.raises(ValueError, match="budget 0 is not a finite fraction"):
        brdf.select_scene("data/scenes/target.toml", budget=0)
    with pytest.raises(ValueError, match="cannot use scene"):
        brdf.select_scene(tmp_path / "none.toml")


def test_ctrl_c_interrupts_a_long_sweep(root, tmp_path):
    """Ctrl-C raises KeyboardInterrupt during `brdf.scene_lrcs` at once (it was honoured only
    when the sweep ended). The sweep below takes tens of seconds; the child must be gone
    within a few seconds of the signal."""
    import signal
    import subprocess
    import sys
    import time

    text = (root / SCENE).read_text()
    text = text.replace('mesh = "target.obj"', f'mesh = "{root / "data/scenes/target.obj"}"')
    text = text.replace("azimuth_deg = [0, 360, 5]", "azimuth_deg = [0, 360, 0.1]")
    text = text.replace("elevation_deg = [0, 31, 15]", "elevation_deg = [0, 90, 1]")
    scene = tmp_path / "long.toml"
    scene.write_text(text)
    code = (
        "import brdf\n"
        "print('started', flush=True)\n"
        f"brdf.scene_lrcs({str(scene)!r})\n"
        "print('finished', flush=True)\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert child.stdout.readline().strip() == "started"
    time.sleep(1.0)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=120)
    took = time.monotonic() - sent
    assert child.returncode != 0 and "KeyboardInterrupt" in err, (out, err)
    assert "finished" not in out
    assert took < 5.0, f"{took:.1f} s after Ctrl-C"


def test_a_list_of_wavelengths_gives_sigma_at_each(cli, root, tmp_path):
    # Lambertian bands at 0.5 and 0.7 um on every part of the bundled target.
    fits = [
        {"dataset": "p.csv[wavelength=0.5]", "model": "lambert", "params": {"rho0": 0.2}},
        {"dataset": "p.csv[wavelength=0.7]", "model": "lambert", "params": {"rho0": 0.6}},
    ]
    (tmp_path / "fits.json").write_text(json.dumps(fits))
    (tmp_path / "target.obj").write_bytes((root / "data/scenes/target.obj").read_bytes())
    scene = tmp_path / "s.toml"
    scene.write_text(
        'mesh = "target.obj"\n[[material]]\npart = "*"\nfit = "fits.json"\n[sensor]\nmode = "monostatic"\n'
        "wavelength_um = [0.5, 0.6, 0.7]\nazimuth_deg = [0, 360, 45]\nelevation_deg = [0, 31, 30]\n"
    )
    got = brdf.scene_lrcs(scene)
    assert got.wavelengths.tolist() == [0.5, 0.6, 0.7]
    assert got.by_wavelength.shape == (16, 3)
    assert got.by_wavelength[:, 0].tolist() == got.lrcs.tolist()
    # sigma is linear in rho: 0.4 at 0.6 um, 0.6 at 0.7 um.
    np.testing.assert_allclose(got.by_wavelength[:, 1], 2 * got.lrcs, rtol=1e-12)
    np.testing.assert_allclose(got.by_wavelength[:, 2], 3 * got.lrcs, rtol=1e-12)
    rows = list(csv.reader(io.StringIO(cli("scene", "lrcs", scene).stdout)))
    assert rows[0] == ["azimuth", "elevation", "lrcs_0.5um", "lrcs_0.6um", "lrcs_0.7um"]
    assert [[float(x) for x in r[2:]] for r in rows[1:]] == got.by_wavelength.tolist()
    one = brdf.scene_lrcs(root / SCENE)
    assert one.wavelengths is None and one.by_wavelength is None
    with pytest.raises(ValueError, match="lists 3 wavelengths"):
        brdf.select_scene(scene)


def test_profile_is_the_cli_file(cli, root):
    rows = list(csv.DictReader(io.StringIO(cli("scene", "profile", root / SCENE, "--bin-m", "0.1", "--pulse-m", "0.2").stdout)))
    got = brdf.scene_profile(root / SCENE, 0.1, pulse_m=0.2)
    assert len(rows) == len(got["lrcs"]) > 216
    for key in ("azimuth", "elevation", "lrcs"):
        assert got[key].tolist() == [float(r[key]) for r in rows], key
    np.testing.assert_allclose(got["range_m"], [float(r["range_m"]) for r in rows], atol=1e-9)
    # Each aspect's bins sum to its sigma.
    lr = brdf.scene_lrcs(root / SCENE)
    for a, e, s in zip(lr.azimuth, lr.elevation, lr.lrcs):
        sel = (got["azimuth"] == a) & (got["elevation"] == e)
        np.testing.assert_allclose(got["lrcs"][sel].sum(), s, rtol=1e-9)
    with pytest.raises(ValueError, match="not a length above 0"):
        brdf.scene_profile(root / SCENE, 0.0)
    with pytest.raises(TypeError, match="bin_m: str"):
        brdf.scene_profile(root / SCENE, "0.1")
    with pytest.raises(TypeError, match="bin_m: bool"):
        brdf.scene_profile(root / SCENE, np.bool_(True))
    # A numpy scalar is a length (a float32 bin was refused).
    assert brdf.scene_profile(root / SCENE, np.float32(0.25))["lrcs"].size > 216


def test_image_is_the_cli_csv(cli, root, tmp_path):
    out = tmp_path / "i.csv"
    cli("scene", "image", root / SCENE, "--aspect", "30,20", "--pixels", "64", "-o", tmp_path / "i.png", "--csv", out)
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    got = brdf.scene_image(root / SCENE, 30, 20, pixels=64)
    h, w = got["sigma"].shape
    assert len(rows) == h * w
    assert got["sigma"].ravel().tolist() == [float(r["lrcs"]) for r in rows]
    rng = [float(r["range_m"]) if r["range_m"] else np.nan for r in rows]
    np.testing.assert_array_equal(got["range_m"].ravel(), rng)
    assert got["lrcs"] > 0 and got["bound"] < got["lrcs"]
    with pytest.raises(ValueError, match="azimuth and elevation together"):
        brdf.scene_image(root / SCENE, 30)
    with pytest.raises(ValueError, match="--pixels 5000"):
        brdf.scene_image(root / SCENE, pixels=5000)
    with pytest.raises(TypeError, match="pixels: float"):
        brdf.scene_image(root / SCENE, pixels=64.5)
