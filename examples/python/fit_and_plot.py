"""Fit the six-parameter model to a measured dataset, plot it, and pack the fit for the device.

    python examples/python/fit_and_plot.py [OUT_DIR]

Reads the bundled MERL aluminium in-plane slice (data/measured/merl-aluminium-inplane, the
`merl-inplane` import), fits it as `brdf fit --format merl-inplane` does, draws measured and
fitted in-plane curves per incidence with matplotlib (`fit.png`), writes `fit.json` (the
text `brdf fit --json` prints) and packs the fit into the device's parameter blob
`params.bin` (the bytes `brdf pack fit.json -o params.bin` writes), ready for
`brdf flash --chip STM32F407VGTx params.bin`.
"""
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import brdf  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "measured" / "merl-aluminium-inplane" / "aluminum_brdf.csv"


def main():
    out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    out.mkdir(parents=True, exist_ok=True)
    r = brdf.fit(str(DATA), "six", seed=1, format="merl-inplane")
    print(r)
    for name, why in r.undetermined.items():
        print(f"  {name} is not determined by the data: {why}")
    (out / "fit.json").write_text(r.to_json() + "\n")
    # The device's parameter blob: one material, checked against the model's ranges.
    blob = brdf.pack(r)
    (out / "params.bin").write_bytes(blob)

    # Measured points come back through the same importer, as arrays in degrees.
    d = brdf.read(DATA, format="merl-inplane")[0]
    ti, tr, phi, f = d["theta_i"], d["theta_r"], d["phi"], d["brdf"]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, inc in enumerate(np.unique(ti)[::3]):
        sel = ti == inc
        signed = np.where(np.cos(np.radians(phi[sel])) < 0, tr[sel], -tr[sel])
        ax.semilogy(signed, f[sel], ".", color=f"C{k}", ms=3, label=f"measured, {inc:.0f}°")
        ts = np.linspace(-89, 89, 357)
        model = brdf.eval("six", r.params, inc, np.abs(ts), np.where(ts > 0, 180.0, 0.0))
        ax.semilogy(ts, model, "-", color=f"C{k}", lw=1)
    ax.set_xlabel("signed viewing zenith (deg, > 0 forward)")
    ax.set_ylabel("BRDF (1/sr)")
    ax.set_title(f"{DATA.parent.name}: six-parameter fit, RMS relative {100 * r.metrics['rms_rel']:.1f}%")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "fit.png", dpi=120)
    print(f"wrote {out / 'fit.json'}, {out / 'fit.png'} and {out / 'params.bin'} ({len(blob)} bytes)")


if __name__ == "__main__":
    main()
