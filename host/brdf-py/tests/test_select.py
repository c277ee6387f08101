"""`brdf.select`: the choice `brdf select --json` prints, the blob `brdf select -o` writes,
its warnings and its errors."""

import json
import warnings

import numpy as np
import pytest

import brdf

KHAKI = "data/khaki-synthetic-inplane.csv"


def without_timings(v):
    """The selection with its timings (`host_ns`, `seconds`: measured in each run) removed."""
    if isinstance(v, dict):
        return {k: without_timings(x) for k, x in v.items() if k not in ("host_ns", "seconds")}
    if isinstance(v, list):
        return [without_timings(x) for x in v]
    return v


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        ([], {}),
        (["--max-theta", "40", "--budget", "1%"], {"max_theta": 40, "budget": 0.01}),
        (["--max-theta-r", "60", "--allow-nonphysical", "--seed", "3"], {"max_theta_r": 60, "allow_nonphysical": True, "seed": 3}),
    ],
)
def test_the_cli_choice_and_blob(cli, root, tmp_path, flags, kwargs):
    out = tmp_path / "chosen.bin"
    want = json.loads(cli("select", root / KHAKI, "--json", "-o", out, "--sequence", "7", *flags).stdout)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = brdf.select(str(root / KHAKI), sequence=7, **kwargs)
    assert without_timings(json.loads(s.to_json())) == without_timings(want)
    assert s.chosen == want["chosen"] and s.reason == want["reason"]
    assert s.blob == out.read_bytes()
    # Each candidate is the fit report `brdf fit --json` prints over the same domain.
    assert [c.model for c in s.candidates] == [c["model"] for c in want["candidates"]]
    for c, w in zip(s.candidates, want["candidates"]):
        assert without_timings(json.loads(c.to_json())) == without_timings(w)


def test_the_left_out_points_warn_as_the_cli_prints(cli, root):
    stderr = cli("select", root / KHAKI, "--max-theta", "40").stderr.strip()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        brdf.select(str(root / KHAKI), max_theta=40)
    assert [str(x.message) for x in w] == [stderr]
    assert "left out 114 of 213 points" in stderr


def test_arrays_select_as_the_file(root):
    d = brdf.read(str(root / KHAKI))[0]
    from_file = brdf.select(str(root / KHAKI))
    from_arrays = brdf.select(d, name=from_file.dataset)
    # The arrays hold the file's angles in degrees: converted back to radians they differ
    # from the file's in the last bit, so the fits agree to rounding, not bit for bit.
    assert (from_arrays.chosen, from_arrays.reason) == (from_file.chosen, from_file.reason)
    assert from_arrays.n == from_file.n == 213
    for a, f in zip(from_arrays.candidates, from_file.candidates):
        assert a.model == f.model
        for k, v in f.params.items():
            assert a.params[k] == pytest.approx(v, rel=1e-6, abs=1e-9), (f.model, k)
    assert len(from_arrays.blob) == len(from_file.blob)


def test_nothing_within_the_budget(cli, root):
    s = brdf.select(str(root / KHAKI), budget=1e-5)
    want = json.loads(cli("select", root / KHAKI, "--json", "--budget", "1e-5").stdout)
    # The most accurate by held-out error is chosen, and said to miss the budget.
    assert s.chosen == want["chosen"] and s.chosen is not None
    assert not s.within_budget and not want["within_budget"]
    best = min(
        (
            r for r in s.representations
            if r["fits_blob"] and r["reciprocal"] and r["bounded"] and r["cv_rms_rel"] is not None
        ),
        key=lambda r: r["cv_rms_rel"],
    )
    assert s.chosen == best["name"]
    assert s.blob is not None
    assert s.chosen_fit is not None and s.chosen_fit.model == best["model"]
    assert s.reason == want["reason"] and s.reason.startswith("nothing meets the 0.00% budget")
    assert s.reason.endswith(f"chosen as the most accurate: {s.chosen}")


def test_errors_are_the_cli_messages(cli, root, tmp_path):
    p = cli("select", root / KHAKI, "--max-theta", "5", check=False)
    assert p.returncode != 0
    with pytest.warns(UserWarning), pytest.raises(ValueError) as e:
        brdf.select(str(root / KHAKI), max_theta=5)
    assert str(e.value) in p.stderr
    assert "only 5 points" in str(e.value)
    # A file of two samples: select works on one dataset.
    lines = (root / KHAKI).read_text().splitlines()
    two = tmp_path / "two.csv"
    two.write_text("\n".join([lines[0] + ",sample"] + [f"{l},{'ab'[k % 2]}" for k, l in enumerate(lines[1:])]) + "\n")
    p = cli("select", two, check=False)
    assert p.returncode != 0
    with pytest.raises(ValueError) as e:
        brdf.select(str(two))
    assert str(e.value) in p.stderr and "holds 2 datasets" in str(e.value)
    for bad in ({"budget": 0}, {"budget": float("nan")}, {"max_theta": 91}, {"max_theta_i": -1}):
        with pytest.raises(ValueError):
            brdf.select(str(root / KHAKI), **bad)
    with pytest.raises(TypeError):
        brdf.select([str(root / KHAKI), str(root / KHAKI)])


def test_a_budget_above_one_is_refused_saying_how_to_write_a_percentage(cli, root):
    # Before: budget=2 meant 200%, as `brdf select --budget 2` did.
    p = cli("select", root / KHAKI, "--budget", "2", check=False)
    assert p.returncode != 0 and "write 2%" in p.stderr
    calls = (
        lambda b: brdf.select(str(root / KHAKI), budget=b),
        lambda b: brdf.select_scene(str(root / "data/scenes/target.toml"), budget=b),
    )
    for call in calls:
        with pytest.raises(ValueError, match=r"budget 2 is a fraction, 200%.* give 0\.02"):
            call(2)
        with pytest.raises(ValueError, match=r"budget 1\.5 is a fraction, 150%"):
            call(1.5)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        # Before: allow_nonphysical="no" allowed them, budget="0.02" was read as a number.
        ({"allow_nonphysical": "no"}, "allow_nonphysical must be True or False, not 'no'"),
        ({"budget": "0.02"}, "budget must be a number, not '0.02'"),
        ({"max_theta": "40"}, "max_theta_i must be a number, not '40'"),
    ],
)
def test_options_of_the_wrong_type_are_refused(root, kwargs, match):
    with pytest.raises(TypeError, match=match):
        brdf.select(str(root / KHAKI), **kwargs)


def test_a_chosen_fitted_table_evaluates_as_the_cli(cli, root, tmp_path):
    # MERL's aluminium: the fitted table is chosen; `chosen_fit` carries it (it used to be
    # the bare base fit, which eval_fit would have evaluated without the table).
    data = tmp_path / "al.csv"
    cli("import", "merl-inplane", root / "data/measured/merl-aluminium-inplane/aluminum_brdf.csv", "-o", data)
    chosen = tmp_path / "chosen.json"
    cli("select", data, "--budget", "0.1%", "--chosen", chosen)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = brdf.select(str(data), budget=0.001)
    assert s.chosen == "ggx + table"
    assert json.loads(s.chosen_fit.to_json())["fitted_table"] == json.loads(chosen.read_text())["fitted_table"]
    # Its repr says a table is attached (it showed the bare base's error as the fit's).
    assert "ggx + fitted table " in repr(s.chosen_fit) and "base rms_rel" in repr(s.chosen_fit)
    angles = tmp_path / "angles.csv"
    angles.write_text("theta_i,theta_r,phi\n30,30,180\n30,31,180\n60,20,90\n10,70,0\n")
    p = cli("eval", "--fit", chosen, angles)
    want = [float(l.split(",")[-1]) for l in p.stdout.split()[1:]]
    ti, tr, phi = [30, 30, 60, 10], [30, 31, 20, 70], [180, 180, 90, 0]
    # (60, 20, 90) is out of the plane MERL's slice measured: the table extrapolates there,
    # which both say (before, with exit 0 and no word), with the same count.
    assert "1 of 4 directions (the first on line 4 of" in p.stderr, p.stderr
    with pytest.warns(UserWarning, match=r"^1 of 4 directions \(the first at index \[2\]\) lie outside the fitted table's coverage"):
        got = brdf.eval_fit(s.chosen_fit, ti, tr, phi)
    assert list(got) == want
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        in_plane = brdf.eval_fit(str(chosen), [30, 30, 10], [30, 31, 70], [180, 180, 0])
    assert list(in_plane) == [want[0], want[1], want[3]]
    with pytest.warns(UserWarning, match="outside the fitted table's coverage"):
        assert list(brdf.eval_fit(str(chosen), ti, tr, phi)) == want
    base = brdf.eval("ggx", s.chosen_fit.params, ti, tr, phi)
    assert abs(got[0] / base[0] - 1) > 0.05, "the table corrects the base at the mirror"
    with pytest.warns(UserWarning, match="outside the fitted table's coverage"):
        f32 = brdf.eval_fit(s.chosen_fit, ti, tr, phi, precision="f32")
    assert f32.dtype.name == "float32" and all(abs(a / b - 1) < 1e-2 for a, b in zip(f32, want))


def test_arrays_warn_of_radians_and_refuse_shared_bands_as_a_file(tmp_path):
    # Before: arrays in radians were selected over as degrees without the file's warning, and
    # bands='shared' was taken and ignored (a selection is of one dataset, never the bands of
    # a measurement; each band of a file is selected on its own).
    ti, tr = (a.ravel() for a in np.meshgrid([0.0, 20.0, 40.0], [0.0, 15.0, 30.0, 45.0, 60.0]))
    data = {"theta_i": np.radians(ti), "theta_r": np.radians(tr), "phi": np.zeros(ti.size), "brdf": np.full(ti.size, 0.15)}
    f = tmp_path / "radians.csv"
    f.write_text("theta_i,theta_r,phi,brdf\n" + "\n".join(",".join(map(str, r)) for r in zip(*data.values())) + "\n")
    said = []
    for given, name in ((str(f), None), (data, str(f))):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            brdf.select(given, name=name) if name else brdf.select(given)
        said.append([str(w.message) for w in caught if "look like radians" in str(w.message)])
    assert said[0] == said[1] and len(said[0]) == 1 and said[0][0].startswith(f"{f}: every theta_i")
    for given in (str(f), data):
        # The radians warning comes first, as the file's rows are read before the refusal.
        with pytest.raises(ValueError, match=r"^bands shared: no two datasets are bands of one measurement .* it would be ignored"):
            with pytest.warns(UserWarning, match="look like radians"):
                brdf.select(given, bands="shared")
