"""`brdf.fit`: the report `brdf fit --json` prints, from files and from arrays."""

import collections
import collections.abc
import csv
import dataclasses
import json
import types
import warnings

import numpy as np
import pytest

import brdf

KHAKI = "data/khaki-synthetic-inplane.csv"


def without_time(text):
    """A report without its wall time, the one field that differs between runs."""
    r = json.loads(text)
    r.pop("seconds")
    return r


def test_to_json_equals_the_cli(cli, root):
    path = root / KHAKI
    want = cli("fit", "--json", "--seed", "1", path).stdout.rstrip("\n")
    got = brdf.fit(str(path), seed=1).to_json()
    assert without_time(got) == without_time(want)
    # Byte for byte once the time is equal.
    seconds = json.loads(want)["seconds"]
    lines = [l for l in got.splitlines() if not l.lstrip().startswith('"seconds"')]
    wlines = [l for l in want.splitlines() if not l.lstrip().startswith('"seconds"')]
    assert lines == wlines and seconds > 0


def test_result_fields(root):
    r = brdf.fit(str(root / KHAKI))
    assert list(r.params) == ["kb", "kr", "b", "a", "kd", "c"]
    assert set(r.std_errors) == set(r.params)
    assert isinstance(r.undetermined, collections.abc.Mapping)
    assert r.metrics["rms_rel"] < 0.01
    assert "albedo" in r.energy


def test_arrays_fit_like_the_file(root):
    rows = list(csv.DictReader(open(root / KHAKI)))
    ts = np.array([float(x["theta_s"]) for x in rows])
    data = {
        "theta_i": np.array([float(x["theta_i"]) for x in rows]),
        "theta_r": np.abs(ts),
        "phi": np.where(ts > 0, 180.0, 0.0),
        "brdf": np.array([float(x["brdf"]) for x in rows]),
    }
    a = brdf.fit(data)
    f = brdf.fit(str(root / KHAKI))
    assert a.params == f.params
    assert a.metrics == f.metrics


def test_bad_rows_are_located():
    data = {"theta_i": [10, 20, 30], "theta_r": [10, 95, 30], "phi": [0, 0, 0], "brdf": [0.1, 0.3, 0.2]}
    with pytest.raises(ValueError, match=r"data at index \[1\]: column theta_r: 95 is outside \[0, 90\)"):
        brdf.fit(data)
    data = {"theta_i": [10, 20, 30], "theta_r": [10, 20, 30], "phi": [0, 0, 0], "brdf": [0.1, -1e101, 0.2]}
    with pytest.raises(ValueError, match=r"data at index \[1\]: column brdf: .* in magnitude"):
        brdf.fit(data)
    with pytest.raises(ValueError, match="missing `brdf`"):
        brdf.fit({"theta_i": [1], "theta_r": [1], "phi": [1]})


def test_file_errors_carry_the_cli_message(cli, tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("theta_i,theta_r,phi,brdf\n10,20,0,0.1\n10,95,0,0.1\n")
    p = cli("fit", f, check=False)
    assert p.returncode != 0
    with pytest.raises(ValueError) as e:
        brdf.fit(str(f))
    assert str(e.value) in p.stderr
    assert "line 3: column theta_r" in str(e.value)


def test_a_known_column_in_another_case_is_refused_as_the_cli(cli, tmp_path):
    # Before: `Sample` was ignored and two samples 1e4 apart were fitted as one.
    f = tmp_path / "cap.csv"
    rows = [f"{ti},{tr},0,{v},{s}" for s, v, ti in (("A", 0.15, 0), ("B", 1.5e3, 10)) for tr in (0, 20, 40)]
    f.write_text("theta_i,theta_r,phi,brdf,Sample\n" + "\n".join(rows) + "\n")
    p = cli("fit", "--model", "lambert", f, check=False)
    assert p.returncode != 0
    with pytest.raises(ValueError, match="line 1: column `Sample` must be spelt `sample`") as e:
        brdf.fit(str(f), model="lambert")
    assert str(e.value) in p.stderr


def test_zeniths_that_look_like_radians_warn_as_the_cli(cli, tmp_path):
    # Before: radians in the degree columns were fitted without a word, 35% off.
    zeniths = np.linspace(0.0, 1.5, 6)
    for name, scale, warned in (("radians.csv", 1.0, True), ("degrees.csv", np.degrees(1.0), False)):
        f = tmp_path / name
        rows = [f"{ti * scale},{tr * scale},0,0.15" for ti in zeniths[:3] for tr in zeniths]
        f.write_text("theta_i,theta_r,phi,brdf\n" + "\n".join(rows) + "\n")
        stderr = cli("fit", "--model", "lambert", f).stderr
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            brdf.fit(str(f), model="lambert")
        said = [str(w.message) for w in caught if "look like radians" in str(w.message)]
        assert bool(said) == warned and ("look like radians" in stderr) == warned
        assert all(m in stderr for m in said)


def test_imported_zeniths_that_look_like_radians_warn_as_the_cli(cli, tmp_path):
    # Before: only CSV files were checked; a MERL or NIST file in radians was read as degrees
    # without a word.
    f = tmp_path / "radians.merl"
    rows = [f"{ti} 180 {tr} 0 0.15" for ti in (0.0, 0.3, 0.6) for tr in (-1.2, -0.6, 0.3, 0.9, 1.5)]
    f.write_text("# phi_in theta_in phi_out theta_out brdf\n" + "\n".join(rows) + "\n")
    stderr = cli("fit", "--model", "lambert", "--format", "merl-inplane", f).stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        brdf.fit(str(f), model="lambert", format="merl-inplane")
    said = [str(w.message) for w in caught if "look like radians" in str(w.message)]
    assert len(said) == 1 and said[0] in stderr


def test_unknown_options_raise():
    with pytest.raises(TypeError, match="unknown option"):
        brdf.fit({}, chainz=3)


@pytest.mark.parametrize(
    "kwargs,error,match",
    [
        # Before: seed=1.7 ran with seed 1, brightening="no" searched brightening,
        # chains=True ran one chain, loss_scale="0.1" was read as a number.
        ({"seed": 1.7}, TypeError, "seed must be a whole number, not 1.7"),
        ({"chains": True}, TypeError, "chains must be a whole number, not True"),
        ({"hops": 2.0}, TypeError, "hops must be a whole number, not 2.0"),
        ({"agree": -1}, ValueError, "agree: `-1` is not a whole number >= 0"),
        ({"brightening": "no"}, TypeError, "brightening must be True or False, not 'no'"),
        ({"skip_invalid": 1}, TypeError, "skip_invalid must be True or False, not 1"),
        ({"loss_scale": "0.1"}, TypeError, "loss_scale must be a number, not '0.1'"),
        ({"residual": None}, TypeError, "residual must be a string, not None"),
    ],
)
def test_options_of_the_wrong_type_are_refused_not_coerced(root, kwargs, error, match):
    with pytest.raises(error, match=match):
        brdf.fit(str(root / KHAKI), **kwargs)


def test_read_gives_the_datasets_fit_uses(root):
    path = root / "data" / "measured" / "merl-aluminium-inplane" / "aluminum_brdf.csv"
    (d,) = brdf.read(path, format="merl-inplane")
    assert d["theta_i"].dtype == np.float64 and len(d["brdf"]) == len(d["phi"]) > 100
    assert np.all(d["brdf"] > 0) and np.all((d["theta_r"] >= 0) & (d["theta_r"] < 90))
    a = brdf.fit({k: d[k] for k in ("theta_i", "theta_r", "phi", "brdf")})
    f = brdf.fit(str(path), format="merl-inplane")
    assert a.params == f.params
    # The figure README.md quotes for this dataset.
    assert round(100 * f.metrics["rms_rel"], 1) == 58.3


def strip_seconds(text):
    return "\n".join(l for l in text.splitlines() if not l.lstrip().startswith('"seconds"'))


def test_several_datasets_equal_the_cli_array(cli, root, tmp_path):
    a = root / KHAKI
    b = tmp_path / "copy.csv"
    b.write_text(a.read_text())
    want = cli("fit", "--json", a, b).stdout.rstrip("\n")
    got = brdf.fit([str(a), str(b)])
    assert isinstance(got, list) and len(got) == 2
    assert strip_seconds(brdf.to_json(got)) == strip_seconds(want)


def test_imported_files_equal_the_cli_and_warn_its_rejects(cli, root):
    path = root / "data" / "measured" / "ptfe-germer-nist" / "PTFE.data.random.csv"
    p = cli("fit", "--json", "--format", "nist", path)
    with warnings.catch_warnings(record=True) as notes:
        warnings.simplefilter("always")
        got = brdf.fit(str(path), format="nist")
    rejected = [l for l in p.stderr.splitlines() if ": rejected line " in l]
    assert [str(n.message) for n in notes] == rejected
    assert strip_seconds(got.to_json()) == strip_seconds(p.stdout.rstrip("\n"))


def test_albedo_equals_the_reports_energy_check(root):
    r = brdf.fit(str(root / KHAKI))
    rows = list(csv.DictReader(open(root / KHAKI)))
    # The measured incidences and the report's fixed ones to 89.99 degrees.
    fixed = {0.0, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0, 89.0, 89.9, 89.99}
    incidences = sorted({float(x["theta_i"]) for x in rows} | fixed)
    assert [a["theta_i"] for a in r.energy["albedo"]] == pytest.approx(incidences, abs=1e-9)
    got = brdf.albedo("six", r.params, incidences)
    assert list(got) == [a["albedo"] for a in r.energy["albedo"]]
    with pytest.raises(ValueError, match=r"theta_i at index \[1\]: theta_i: zenith 91 deg is outside \[0, 90\]"):
        brdf.albedo("six", r.params, [0, 91])
    # By default the report's rule: for a narrow microfacet peak at grazing incidence, more
    # panels than 8 (which miss 82% of it at alpha = 1/1024, 89 degrees).
    narrow = {"ks": 1.0, "alpha": 1 / 1024, "f0": 1.0, "kd": 0.0}
    default = brdf.albedo("ggx", narrow, [89.0])
    assert list(default) == list(brdf.albedo("ggx", narrow, [89.0], panels=256))
    assert abs(default[0] - 1) < 0.01 and brdf.albedo("ggx", narrow, [89.0], panels=8)[0] < 0.5
    # A Lambertian surface of reflectance rho0 reflects rho0 at every incidence.
    lambert = brdf.albedo("lambert", "rho0=0.5", [0, 45, 80])
    np.testing.assert_allclose(lambert, 0.5, rtol=brdf._brdf.ALBEDO_DEFAULT_REL)


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        (["--engine", "embedded", "--budget-evals", "5000"], {"engine": "embedded", "budget_evals": 5000}),
        (["--residual", "log", "--seed", "7", "--hops", "2"], {"residual": "log", "seed": 7, "hops": 2}),
        (["--loss", "huber", "--loss-scale", "0.05", "--chains", "3", "--agree", "2"],
         {"loss": "huber", "loss_scale": 0.05, "chains": 3, "agree": 2}),
    ],
)
def test_options_map_to_the_cli_flags(cli, root, flags, kwargs):
    path = root / KHAKI
    want = cli("fit", "--json", *flags, path).stdout.rstrip("\n")
    assert strip_seconds(brdf.fit(str(path), **kwargs).to_json()) == strip_seconds(want)


@pytest.mark.parametrize(
    "flags,kwargs",
    [
        # The embedded engine refuses what it would ignore.
        (["--engine", "embedded", "--residual", "log"], {"engine": "embedded", "residual": "log"}),
        (["--engine", "embedded", "--loss", "cauchy"], {"engine": "embedded", "loss": "cauchy"}),
        (["--engine", "embedded", "--brightening"], {"engine": "embedded", "brightening": True}),
        # Names outside the vocabulary, with the "expected one of" list.
        (["--model", "sixx"], {"model": "sixx"}),
        (["--residual", "rel"], {"residual": "rel"}),
        (["--loss", "l2"], {"loss": "l2"}),
        (["--engine", "fast"], {"engine": "fast"}),
        (["--format", "astm"], {"format": "astm"}),
        (["--channel", "x"], {"channel": "x"}),
        # Ranges, at the first value outside each end.
        (["--chains", "0"], {"chains": 0}),
        (["--agree", "65"], {"agree": 65}),
        (["--hops", "65"], {"hops": 65}),
        (["--anneal-evals", "0"], {"anneal_evals": 0}),
        (["--engine", "embedded", "--budget-evals", "64"], {"engine": "embedded", "budget_evals": 64}),
        # More agreeing searches than chains could never converge.
        (["--agree", "10", "--chains", "4"], {"agree": 10, "chains": 4}),
        # Options the engine or the loss would ignore.
        (["--engine", "embedded", "--chains", "4"], {"engine": "embedded", "chains": 4}),
        (["--budget-evals", "5000"], {"budget_evals": 5000}),
        (["--loss-scale", "0.05"], {"loss_scale": 0.05}),
    ],
)
def test_bad_options_carry_the_cli_message(cli, root, flags, kwargs):
    p = cli("fit", *flags, root / KHAKI, check=False)
    assert p.returncode != 0
    with pytest.raises(ValueError) as e:
        brdf.fit(str(root / KHAKI), **kwargs)
    assert str(e.value) in p.stderr, (str(e.value), p.stderr)


def test_file_options_are_refused_for_arrays(root):
    (d,) = brdf.read(str(root / KHAKI))
    arrays = {k: d[k] for k in ("theta_i", "theta_r", "phi", "brdf")}
    for kwargs in ({"format": "cornell"}, {"skip_invalid": True}):
        with pytest.raises(ValueError, match="apply to files; arrays are used as given"):
            brdf.fit(arrays, **kwargs)
    with pytest.raises(ValueError, match="channel g applies to the cornell format only"):
        brdf.fit(arrays, channel="g")


def test_array_data_is_taken_as_given_or_refused(root):
    (d,) = brdf.read(str(root / KHAKI))
    cols = {k: d[k] for k in ("theta_i", "theta_r", "phi", "brdf")}
    # Before: (N, 1) beside (N,) broadcast to N^2 points and fitted.
    bad = dict(cols, theta_i=cols["theta_i"][:, None])
    with pytest.raises(ValueError, match=r"the columns differ in shape \(theta_i \(\d+, 1\)"):
        brdf.fit(bad)
    # Before: a misspelt key was ignored, and the fit ran without the uncertainties.
    with pytest.raises(ValueError, match="data: column `sigmas` must be spelt `sigma`"):
        brdf.fit(dict(cols, sigmas=np.full_like(cols["brdf"], 0.01)))
    # Before: a bytes path was misread.
    with pytest.raises(TypeError, match="not bytes"):
        brdf.fit(str(root / KHAKI).encode())
    # What `read` returns fits as it is, under its own name.
    r = brdf.fit(d)
    assert r.dataset == d["name"]


def test_repr_of_an_absolute_residual_fit_with_a_zero_reading(root):
    (d,) = brdf.read(str(root / KHAKI))
    d["brdf"][0] = 0.0
    r = brdf.fit(d, residual="absolute", model="lambert", noise_floor=0)
    # Before: repr raised TypeError (the relative error is null where a reading is 0 and no
    # noise floor gives it a scale).
    assert r.metrics["rms_rel"] is None
    assert repr(r).endswith("rms_rel undefined)")


def test_dark_readings_are_kept_and_weighed_with_a_noise_floor(root):
    (d,) = brdf.read(str(root / KHAKI))
    d["brdf"][3] = -1e-3
    d["brdf"][7] = 0.0
    r = brdf.fit(d)
    floor = r.report["noise_floor"]
    assert (floor["source"], floor["at_or_below_zero"]) == ("estimated", 2)
    assert floor["value"] == pytest.approx(floor["sigma_a"] / floor["relative_noise"], rel=1e-12)
    assert r.metrics["rms_rel"] is not None and r.metrics["log_rmse"] is None
    given = brdf.fit(d, noise_floor=0.01)
    assert given.report["noise_floor"]["source"] == "given"
    # The rules of the CLI: no floor leaves relative residuals no scale; log residuals refuse.
    with pytest.raises(ValueError, match="line 4: brdf -0.001 is at or below zero"):
        brdf.fit(d, noise_floor=0)
    with pytest.raises(ValueError, match="logarithm"):
        brdf.fit(d, residual="log")
    with pytest.raises(ValueError, match="noise_floor"):
        brdf.fit(d, noise_floor=-1.0)
    # A floor of 1e200 made every residual underflow: a grid node "converged" at 0.000%.
    with pytest.raises(ValueError, match=r"within \[1e-100, 1e100\]"):
        brdf.fit(d, noise_floor=1e200)
    # A given floor above most readings is doubted as an estimated one is.
    with pytest.warns(UserWarning, match="given noise floor 100 1/sr lies above 100% of the readings"):
        high = brdf.fit(d, noise_floor=100.0)
    assert "lies above 100% of the readings" in high.report["noise_floor"]["note"]
    with pytest.raises(TypeError, match="noise_floor must be a number"):
        brdf.fit(d, noise_floor="0.1")


def test_a_result_cannot_be_edited_into_a_silent_wrong_answer(root):
    r = brdf.fit(str(root / KHAKI), model="lambert")
    before = r.eval(10.0, 20.0, 30.0)
    # Before: the edit was taken, and eval, pack and to_json went on using the fitted text.
    with pytest.raises(TypeError):
        r.params["rho0"] = 2 * r.params["rho0"]
    with pytest.raises(TypeError):
        r.report["params"]["rho0"] = 0.0
    with pytest.raises(AttributeError, match="read-only"):
        r.params = {"rho0": 1.0}
    with pytest.raises(AttributeError, match="read-only"):
        del r.converged
    assert r.eval(10.0, 20.0, 30.0) == before
    # An editable copy evaluates as its values say.
    p = dict(r.params)
    p["rho0"] *= 2
    assert brdf.eval("lambert", p, 10.0, 20.0, 30.0) == pytest.approx(2 * before, rel=1e-12)


def test_skip_invalid_leaves_out_a_dataset_it_cannot_fit_as_the_cli(cli, root, tmp_path):
    one = tmp_path / "one-direction.csv"
    one.write_text("theta_i,theta_r,phi,brdf\n" + "".join(f"20,35,30,{0.1 + 0.001 * k}\n" for k in range(8)))
    good = root / KHAKI
    p = cli("fit", "--json", "--skip-invalid", good, one)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = brdf.fit([str(good), str(one)], skip_invalid=True)
    assert strip_seconds(r.to_json()) == strip_seconds(p.stdout.rstrip("\n"))
    skipped = [str(w.message) for w in caught if "skipped dataset" in str(w.message)]
    assert len(skipped) == 1 and skipped[0] in p.stderr, (skipped, p.stderr)
    with pytest.raises(ValueError, match="no dataset left to fit: all 1 were skipped"):
        brdf.fit(str(one), skip_invalid=True)


@pytest.mark.parametrize("call", ["fit", "select"])
def test_ctrl_c_interrupts_a_long_fit(root, call):
    """Ctrl-C raises KeyboardInterrupt during a fit or a selection (it was honoured only when
    the fit ended, minutes later with `anneal_evals` 1e8), and the work stops with it: in the
    second after the interrupt the process uses almost no CPU (the fit ran on in the
    background, a full core or two, before the fitter looked for a stop). The 60 s limit only
    stops a hung test: the work itself would run for minutes."""
    import signal
    import subprocess
    import sys
    import time

    code = (
        "import sys, time, brdf\n"
        "print('started', flush=True)\n"
        "try:\n"
        f"    brdf.{call}({str(root / KHAKI)!r}, anneal_evals=100_000_000, chains=64)\n"
        "    print('finished', flush=True)\n"
        "except KeyboardInterrupt:\n"
        "    time.sleep(0.3)\n"
        "    t0 = time.process_time(); time.sleep(1.0)\n"
        "    print(f'busy {time.process_time() - t0:.3f}', flush=True)\n"
        "    raise\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert child.stdout.readline().strip() == "started"
    time.sleep(1.0)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode != 0, out
    assert "KeyboardInterrupt" in err, err
    assert "finished" not in out
    busy = float(out.split("busy ")[1])
    # CPU seconds in one second of sleep after the interrupt: ~1 or 2 if the work ran on.
    assert busy < 0.25, f"the work went on after Ctrl-C: {busy} CPU s in 1 s"


def test_a_hand_written_result_is_read_and_a_wrong_one_refused_by_field(cli, root, tmp_path):
    # Before: the hand-written form `brdf pack` takes raised KeyError: 'dataset', an array
    # AttributeError, and "converged": "no" came back as the truthy string 'no'.
    text = '{"model":"lambert","params":{"rho0":0.5}}'
    r = brdf.FitResult(text)
    assert (r.model, dict(r.params)) == ("lambert", {"rho0": 0.5})
    assert (r.dataset, r.wavelength, r.metrics, r.energy, r.converged) == (None,) * 5
    assert dict(r.std_errors) == {} and dict(r.undetermined) == {} and "rho0=0.5" in repr(r)
    x = np.array([10.0, 40.0])
    assert list(r.eval(x, x, 0.0)) == list(brdf.eval("lambert", {"rho0": 0.5}, x, x, 0.0))
    # The blob is the one `brdf pack` writes from the same text.
    f = tmp_path / "hand.json"
    f.write_text(text)
    cli("pack", f, "-o", tmp_path / "hand.blob")
    assert brdf.pack([r]) == (tmp_path / "hand.blob").read_bytes()

    full = json.loads(brdf.fit(str(root / KHAKI), model="lambert").to_json())
    for edit, field in (
        ({"converged": "no"}, "field `converged` must be true or false, not a string"),
        ({"metrics": [1, 2]}, "field `metrics` must be an object, not an array"),
        ({"dataset": 3}, "field `dataset` must be a string, not a number"),
    ):
        with pytest.raises(ValueError, match=field):
            brdf.FitResult(json.dumps({**full, **edit}))
    for bad, match in (
        (json.dumps([full]), "one fit result is a JSON object, not an array"),
        ("3", "not a number"),
        ("{", "not JSON"),
        ('{"model":"lambert","params":{"rho0":"half"}}', "field `params.rho0` must be a number, not a string"),
        ('{"model":"lambert","params":{"kb":0.5}}', "kb"),
        ('{"model":"lambert","params":{"rho0":0.5},"colour":"red"}', "unknown field `colour`"),
        ('{"params":{"rho0":0.5}}', "model"),
    ):
        with pytest.raises(ValueError, match=match):
            brdf.FitResult(bad)


def test_a_result_with_a_parameter_outside_its_range_is_refused_by_field(cli, root, tmp_path):
    # Before: FitResult took kb = -1 (or an edited report's rho0 = -0.5) and only `brdf pack`
    # refused it later. The rule is the libraries' (`brdf_core::ranges`), the field named.
    negative = {"model": "six", "params": {"kb": -1, "kr": 21.8, "b": -27.5, "a": 0.67, "kd": 0.37, "c": 1.2}}
    f = tmp_path / "negative.json"
    f.write_text(json.dumps(negative))
    p = cli("pack", f, "-o", tmp_path / "x.bin", check=False)
    assert p.returncode != 0 and "parameter kb = -1 is out of range" in p.stderr
    with pytest.raises(ValueError, match=r"FitResult: field `params.kb`: parameter kb = -1 is out of range"):
        brdf.FitResult(json.dumps(negative))
    full = json.loads(brdf.fit(str(root / KHAKI), model="lambert").to_json())
    edited = {**full, "params": {"rho0": -0.5}}
    with pytest.raises(ValueError, match=r"field `params.rho0`: parameter rho0 = -0.5 is out of range"):
        brdf.FitResult(json.dumps(edited))
    # A fit's own report that lists the parameter in `outside_ranges` says so itself, as
    # `brdf fit` prints it (uncalibrated data fit weights no device takes): read, and refused
    # by pack as the CLI refuses it.
    from_fit = {**edited, "outside_ranges": ["rho0 = -0.5 is not in [0, 100]"]}
    assert brdf.FitResult(json.dumps(from_fit)).params["rho0"] == -0.5
    with pytest.raises(ValueError, match="field `params.rho0`"):
        brdf.FitResult(json.dumps({**edited, "outside_ranges": ["rho0 = 3 is not in [0, 100]"]}))
    with pytest.raises(ValueError, match="refused"):
        brdf.pack([brdf.FitResult(json.dumps(from_fit))])


def tiny(level=0.15, scale=1.0):
    """Fifteen in-plane points of a Lambertian surface (a fit takes milliseconds); `scale`
    multiplies the zeniths (pi / 180: the same angles in radians)."""
    ti, tr = (a.ravel() for a in np.meshgrid([0.0, 20.0, 40.0], [0.0, 15.0, 30.0, 45.0, 60.0]))
    n = ti.size
    return {"theta_i": ti * scale, "theta_r": tr * scale, "phi": np.zeros(n), "brdf": np.full(n, level)}


def tiny_csv(path, data, extra=None):
    """`data` (and the columns of `extra`) written as a CSV file `brdf fit` reads."""
    cols = dict(data, **(extra or {}))
    rows = zip(*cols.values())
    path.write_text(",".join(cols) + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return path


class FrameLike:
    """What the dataset reader sees of a pandas or polars data frame: ``columns`` (a property
    of the class) and a column by name."""

    def __init__(self, cols):
        self._cols = dict(cols)

    @property
    def columns(self):
        return list(self._cols)

    def __getitem__(self, key):
        return self._cols[key]


def test_an_object_dataset_has_its_fields_checked_as_a_dict_has_its_keys(tmp_path):
    # Before: an object's fields beyond the six columns were ignored: a `sample` column
    # merged two materials 1e4 apart into one fit reported converged, and `Sigma` (for
    # `sigma`) dropped the uncertainties without a word.
    a, b = tiny(0.15), tiny(1.5e3)
    both = {k: np.concatenate([a[k], b[k]]) for k in a}
    sample = np.array(["A"] * a["brdf"].size + ["B"] * b["brdf"].size)
    rec = np.rec.fromarrays([sample, *both.values()], names=["sample", *both])
    f = tiny_csv(tmp_path / "two.csv", both, {"sample": sample})
    from_csv = np.genfromtxt(f, delimiter=",", names=True, dtype=None, encoding="utf-8").view(np.recarray)
    # A file splits them by sample, as `brdf fit` does; arrays are one dataset, so a sample
    # column is refused with the way to fit each (the dict path refused it as unknown).
    assert [r.dataset for r in brdf.fit(str(f), model="lambert")] == [f"{f}[sample=A]", f"{f}[sample=B]"]
    for data in (rec, from_csv, types.SimpleNamespace(**both, sample=sample), FrameLike(dict(both, sample=sample)), dict(both, sample=sample)):
        with pytest.raises(ValueError, match=r"data: `sample`: .* fit each sample on its own .* or pass the path of a CSV file"):
            brdf.fit(data, model="lambert")
    with pytest.raises(ValueError, match=r"data: `sample`"):
        brdf.select(rec)
    sigma = np.full(a["brdf"].size, 0.01)
    for data, match in (
        (types.SimpleNamespace(**a, Sigma=sigma), r"data: column `Sigma` must be spelt `sigma`"),
        (FrameLike(dict(a, sigmas=sigma)), r"data: column `sigmas` must be spelt `sigma`"),
        (np.rec.fromarrays([*a.values(), sigma], names=[*a, "Sigma"]), r"data: column `Sigma` must be spelt `sigma`"),
    ):
        with pytest.raises(ValueError, match=match):
            brdf.fit(data, model="lambert")
    # The known fields fit as the dict does, whichever object holds them (a structured array
    # by its fields too: they are not attributes), `sigma` used.
    want = brdf.fit(dict(a, sigma=sigma), model="lambert")
    structured = np.zeros(sigma.size, dtype=[(k, "f8") for k in (*a, "sigma")])
    for k, v in dict(a, sigma=sigma).items():
        structured[k] = v
    Measured = dataclasses.make_dataclass("Measured", [*a, "sigma"])
    Rows = collections.namedtuple("Rows", [*a, "sigma"])
    for data in (
        types.SimpleNamespace(**a, sigma=sigma),
        Measured(**a, sigma=sigma),
        Rows(**a, sigma=sigma),
        structured,
        structured.view(np.recarray),
        FrameLike(dict(a, sigma=sigma)),
    ):
        got = brdf.fit(data, model="lambert")
        assert (got.params, got.std_errors) == (want.params, want.std_errors), type(data)
    # Slots are fields read by name, as attributes are.
    class Slotted:
        __slots__ = tuple(a)

    slotted = Slotted()
    for k, v in a.items():
        setattr(slotted, k, v)
    assert brdf.fit(slotted, model="lambert").params == brdf.fit(a, model="lambert").params
    # A name is a string, whatever holds it (a number was ignored).
    with pytest.raises(TypeError, match="data: `name` must be a string"):
        brdf.fit(dict(a, name=5), model="lambert")
    assert brdf.fit(types.SimpleNamespace(**a, name="plate"), model="lambert").dataset == "plate"
    # A wavelength per point (a file's column) is refused as `sample` is; one number is the band.
    per_point = types.SimpleNamespace(**a, wavelength=np.full(sigma.size, 0.55))
    with pytest.raises(ValueError, match=r"data: `wavelength` holds a value per point.* fit each band on its own"):
        brdf.fit(per_point, model="lambert")
    one_band = types.SimpleNamespace(**a, wavelength=0.55)
    assert brdf.fit(one_band, model="lambert").wavelength == 0.55
    # A file's datasets are named by the file: `name=` with a path was ignored.
    with pytest.raises(ValueError, match="name names an array dataset"):
        brdf.fit(str(f), model="lambert", name="plate")


def test_array_zeniths_that_look_like_radians_warn_as_a_file(tmp_path):
    # Before: only files were checked; radians given as arrays were fitted as degrees
    # without a word.
    said = lambda caught: [str(w.message) for w in caught if "look like radians" in str(w.message)]  # noqa: E731
    for scale, warned in ((np.pi / 180, True), (1.0, False)):
        data = tiny(scale=scale)
        f = tiny_csv(tmp_path / f"at{scale}.csv", data)
        with warnings.catch_warnings(record=True) as from_file:
            warnings.simplefilter("always")
            brdf.fit(str(f), model="lambert")
        with warnings.catch_warnings(record=True) as from_arrays:
            warnings.simplefilter("always")
            brdf.fit(data, model="lambert", name=str(f))
        assert said(from_arrays) == said(from_file) and len(said(from_file)) == warned
    with pytest.warns(UserWarning, match=r"^arrays: every theta_i and theta_r is below 1.5710 \(pi/2\)"):
        brdf.fit(types.SimpleNamespace(**tiny(scale=np.pi / 180)), model="lambert")


def test_shared_bands_are_refused_for_arrays_as_for_a_file(cli, tmp_path):
    # Before: arrays (always one dataset, never the bands of a measurement) took
    # bands='shared' and ignored it.
    data = tiny()
    f = tiny_csv(tmp_path / "one.csv", data)
    p = cli("fit", "--model", "lambert", "--bands", "shared", f, check=False)
    assert p.returncode != 0
    for given in (str(f), data):
        with pytest.raises(ValueError) as e:
            brdf.fit(given, model="lambert", bands="shared")
        assert str(e.value) in p.stderr and str(e.value).startswith("bands shared: no two datasets")


def test_a_dataset_s_fields_follow_the_csv_column_rule():
    # Before: every field beyond the known ones was refused, so a data frame with its
    # `index` or `Unnamed: 0` column, an `operator` column or a dataclass with a `units`
    # field could not be fitted, though a CSV file's reader ignores such columns; and an
    # object whose columns were properties was refused as having no fields.
    a = tiny(0.15)
    want = brdf.fit(a, model="lambert").params

    @dataclasses.dataclass
    class WithUnits:
        theta_i: np.ndarray
        theta_r: np.ndarray
        phi: np.ndarray
        brdf: np.ndarray
        units: str = "deg"

    class Properties:
        def __init__(self, cols):
            self._cols = cols

        @property
        def theta_i(self):
            return self._cols["theta_i"]

        @property
        def theta_r(self):
            return self._cols["theta_r"]

        @property
        def phi(self):
            return self._cols["phi"]

        @property
        def brdf(self):
            return self._cols["brdf"]

        def weights(self):
            # A method is no field, whatever its name.
            return None

    index = np.arange(a["brdf"].size)
    for data in (
        FrameLike(dict(a, index=index)),
        FrameLike({"Unnamed: 0": index, **a}),
        FrameLike(dict(a, operator=np.array(["bob"] * index.size))),
        WithUnits(**a),
        Properties(a),
        dict(a, units="deg", sample2=index, phi_m=index),
        # Beside `sigma`, `sigma_note` is an annotation, as in a file.
        dict(a, sigma=np.full(index.size, 0.01), sigma_note=index),
    ):
        got = brdf.fit(data, model="lambert")
        assert got.params["rho0"] == pytest.approx(want["rho0"], rel=1e-12), type(data)
    # Near misses are refused as in a file, with the same message (one rule, the library's).
    for field, match in (
        ("sample_id", r"data: column `sample_id` is not read, and its name begins with that of the optional column `sample`"),
        ("wavelength_nm", r"data: column `wavelength_nm` is not read: the wavelength column is `wavelength`, in µm \(divide nm by 1000"),
        ("weights", r"data: column `weights` must be spelt `weight`"),
        ("sigma_rel", r"e\.g\. `x_sigma_rel`"),
    ):
        for data in (dict(a, **{field: index}), FrameLike(dict(a, **{field: index})), types.SimpleNamespace(**a, **{field: index})):
            with pytest.raises(ValueError, match=match):
                brdf.fit(data, model="lambert")
    # The signed in-plane column is a file's: refused for arrays rather than ignored.
    with pytest.raises(ValueError, match="data: `theta_s`: arrays take theta_r and phi"):
        brdf.fit(dict(a, theta_s=a["theta_r"]), model="lambert")


def test_a_weight_on_the_embedded_search_bound_is_warned_of():
    # Before: `brdf fit --engine embedded` warned on standard error of a weight left on the
    # engine's search bound, and brdf.fit said nothing. Data near grazing only, where
    # (cos ti cos tr)^c is small, need kd far beyond the bound (10 times the largest reading).
    ti, tr, ph = np.meshgrid([70.0, 75.0], np.arange(70.0, 87.6, 2.5), np.arange(0.0, 180.1, 45.0), indexing="ij")
    ti, tr, ph = ti.ravel(), tr.ravel(), ph.ravel()
    params = {"kb": 0.0, "kr": 21.8, "b": -27.6, "a": 0.67, "kd": 0.5, "c": 4.0}
    data = dict(theta_i=ti, theta_r=tr, phi=ph, brdf=brdf.eval("six", params, ti, tr, ph))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = brdf.fit(data, "six", engine="embedded")
    notes = [str(w.message) for w in caught if "search bound" in str(w.message)]
    assert notes == [f"arrays: {n}" for n in r.report["search"]["on_search_box"]] and notes, [str(w.message) for w in caught]
    assert notes[0].startswith("arrays: kd = ") and "the full engine has no such bound" in notes[0], notes
