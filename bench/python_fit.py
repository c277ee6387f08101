"""`brdf.fit` (the Python package, host/brdf-py) against scipy's least_squares from 32 random
starts (bench/scipy_fit.py: same parameter box, relative residuals) on the same dataset, in
one process. Prints each one's best-of-3 wall time and RMS relative error, and the ratio.

    python3 bench/python_fit.py [DATA.csv]     # default data/khaki-synthetic-inplane.csv
"""
import os
import pathlib
import sys

import numpy as np
from scipy.optimize import least_squares

import brdf

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from python_eval import best_of  # noqa: E402
from scipy_fit import HI, LO, load, make_model  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]


def scipy_32(ti, tr, phi, y):
    f = make_model(ti, tr, phi)

    def resid(q):
        return (f(q) - y) / y

    rng = np.random.default_rng(12345)
    best = None
    for _ in range(32):
        r = least_squares(resid, LO + (HI - LO) * rng.random(6), bounds=(LO, HI), method="trf")
        if best is None or r.cost < best.cost:
            best = r
    return float(np.sqrt(np.mean(resid(best.x) ** 2)))


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "data" / "khaki-synthetic-inplane.csv")
    ti, tr, phi, y = load(path)
    data = {"theta_i": np.degrees(ti), "theta_r": np.degrees(tr), "phi": np.degrees(phi), "brdf": y}
    t_brdf, r = best_of(3, lambda: brdf.fit(data, seed=1))
    t_sp, sp_rms = best_of(3, lambda: scipy_32(ti, tr, phi, y))
    print(f"dataset {path} ({len(y)} points)")
    print(f"brdf.fit                 {t_brdf:8.3f} s, RMS relative {100 * r.metrics['rms_rel']:.4f}%")
    print(f"scipy least_squares x32  {t_sp:8.3f} s, RMS relative {100 * sp_rms:.4f}%")
    print(f"scipy / brdf.fit time ratio {t_sp / t_brdf:.2f}")


if __name__ == "__main__":
    main()
