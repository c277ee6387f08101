"""`brdf.pack`: the bytes `brdf pack` writes, its warnings and its errors."""

import json
import logging
import warnings

import pytest

import brdf

KHAKI = "data/khaki-synthetic-inplane.csv"
# kb + kd = 1.3: packed, with a warning that energy conservation is not guaranteed.
HOT = {"model": "six", "params": {"kb": 0.8, "kr": 21.8, "b": -27.5, "a": 0.67, "kd": 0.5, "c": 1.2}}
# kb = -1 is outside its range: refused.
NEGATIVE = {"model": "six", "params": {"kb": -1, "kr": 21.8, "b": -27.5, "a": 0.67, "kd": 0.37, "c": 1.2}}


@pytest.fixture(scope="module")
def khaki_fit(cli, root, tmp_path_factory):
    """The CLI's fit of khaki (seed 1) as a file, and the same fit from Python."""
    path = tmp_path_factory.mktemp("pack") / "khaki.json"
    path.write_text(cli("fit", "--json", "--seed", "1", root / KHAKI).stdout)
    return path, brdf.fit(str(root / KHAKI), seed=1)


def cli_pack(cli, tmp_path, *args):
    out = tmp_path / "out.bin"
    p = cli("pack", *args, "-o", out)
    return out.read_bytes(), p.stderr


@pytest.mark.parametrize("table_nodes", [None, 256])
def test_bytes_equal_the_cli(cli, tmp_path, khaki_fit, table_nodes):
    path, result = khaki_fit
    flags = [] if table_nodes is None else ["--table-nodes", table_nodes]
    want, _ = cli_pack(cli, tmp_path, path, *flags)
    assert brdf.pack(str(path), table_nodes) == want
    # The fit made in Python packs to the same bytes as the CLI's fit file.
    assert brdf.pack(result, table_nodes=table_nodes) == want
    assert len(want) == (48 if table_nodes is None else 48 + 3072)


def test_several_results_and_the_sequence(cli, tmp_path, khaki_fit):
    path, result = khaki_fit
    hot = tmp_path / "hot.json"
    hot.write_text(json.dumps(HOT))
    want, _ = cli_pack(cli, tmp_path, path, hot, path, "--sequence", 9, "--table-nodes", 64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = brdf.pack([result, str(hot), path], table_nodes=64, sequence=9)
    assert got == want


def test_warnings_and_notes_are_the_cli_stderr(cli, tmp_path, caplog):
    hot = tmp_path / "hot.json"
    hot.write_text(json.dumps(HOT))
    _, stderr = cli_pack(cli, tmp_path, hot, "--table-nodes", 256)
    # Every line but the last ("wrote <file> ...", which names the CLI's output file).
    want = stderr.splitlines()[:-1]
    with caplog.at_level(logging.INFO, logger="brdf"), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        brdf.pack(str(hot), table_nodes=256)
    warned = [str(x.message) for x in w]
    logged = [r.getMessage() for r in caplog.records if r.name == "brdf"]
    assert warned == [want[0]] and want[0].startswith(f"warning: {hot}: fit 0 (six): energy bound 1.3 > 1")
    assert logged == want[1:] and len(logged) == 2


def test_results_are_named_in_messages(khaki_fit):
    path, _ = khaki_fit
    # A Lambertian brighter than 1/pi reflects more than it receives.
    bright = brdf.fit({"theta_i": [0, 10, 20, 30, 40, 50, 60], "theta_r": [5, 15, 25, 35, 45, 55, 65],
                       "phi": [180] * 7, "brdf": [0.5] * 7}, "lambert")
    with pytest.warns(UserWarning, match=r"^warning: results\[1\]: fit 0 \(lambert\): energy bound"):
        brdf.pack([path, bright])
    with pytest.warns(UserWarning, match=r"^warning: results: fit 0 \(lambert\): energy bound"):
        brdf.pack(bright)


@pytest.mark.parametrize(
    "fits, table_nodes",
    [
        ([NEGATIVE], None),
        ([NEGATIVE], 256),
        ([{"model": "six", "params": {"kb": 0.5}}], None),
        ([HOT] * 9, None),
        ([HOT] * 2, 256),
    ],
)
def test_bad_input_raises_the_cli_message(cli, tmp_path, fits, table_nodes):
    paths = []
    for k, f in enumerate(fits):
        paths.append(tmp_path / f"f{k}.json")
        paths[-1].write_text(json.dumps(f))
    flags = [] if table_nodes is None else ["--table-nodes", table_nodes]
    p = cli("pack", *paths, *flags, "-o", tmp_path / "x.bin", check=False)
    assert p.returncode != 0
    want = p.stderr.splitlines()[-1].removeprefix("error: ")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError) as e:
            brdf.pack([str(q) for q in paths], table_nodes)
    assert str(e.value) == want


def test_missing_file_and_wrong_types(cli, tmp_path):
    missing = tmp_path / "none.json"
    p = cli("pack", missing, "-o", tmp_path / "x.bin", check=False)
    with pytest.raises(ValueError) as e:
        brdf.pack(missing)
    assert "error: " + str(e.value) == p.stderr.strip()
    with pytest.raises(TypeError, match=r"results\[1\]: int is not a FitResult or a path"):
        brdf.pack([str(missing), 3])
    with pytest.raises(ValueError, match="no fits to pack"):
        brdf.pack([])
    with pytest.raises(ValueError, match="table nodes: outside"):
        brdf.pack(missing, table_nodes=100_000)


def test_the_bands_of_a_spectral_fit_are_one_material(cli, root, tmp_path):
    """`brdf.pack(brdf.fit(spectral file))` (one FitResult per band) makes the same single
    banded material as `brdf pack` of the CLI's fit file."""
    data = root / "data/measured/cornell-spectral/garnet_red.astm"
    fits = brdf.fit(str(data), format="cornell", model="ggx")
    assert len(fits) == 31
    got = brdf.pack(fits)
    path = tmp_path / "fits.json"
    path.write_text(cli("fit", "--json", "--format", "cornell", "--model", "ggx", data).stdout)
    want, err = cli_pack(cli, tmp_path, path)
    assert "material 0: 31 bands of" in err
    assert got == want
    # A 31-band blob in one slot: 872 bytes of bands (header, 4 + 16 + 31 x 4 + 30 x 16).
    assert len(got) == 16 + 4 + 16 + 31 * 4 + 30 * 16 + 4
