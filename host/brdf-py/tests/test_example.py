"""The example script runs as a user runs it and writes what it says it writes."""

import subprocess
import sys


def test_fit_and_plot_runs(cli, root, tmp_path):
    script = root / "examples" / "python" / "fit_and_plot.py"
    p = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "wrote" in p.stdout
    # The plot is a PNG; the blob is what `brdf pack` writes for the fit the script saved.
    assert (tmp_path / "fit.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    cli("pack", tmp_path / "fit.json", "-o", tmp_path / "cli.bin")
    assert (tmp_path / "params.bin").read_bytes() == (tmp_path / "cli.bin").read_bytes()
