"""scipy peers for `brdf-bench fit`: the six-parameter model fitted to the same dataset,
in the same parameter box (kb, ln kr, |b|, a, kd, c), with relative residuals.

Prints one JSON object: for each method its wall time in seconds and final RMS relative
error. Methods: least_squares (trf) from 32 random starts, and dual_annealing.
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import dual_annealing, least_squares

LO = np.array([0.0, np.log(0.01), 0.0, 0.05, 0.0, 0.0])
HI = np.array([100.0, np.log(1000.0), 200.0, 4.0, 10.0, 5.0])


def load(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    ti = np.deg2rad(data["theta_i"])
    ts = data["theta_s"]
    tr = np.deg2rad(np.abs(ts))
    phi = np.where(ts > 0, np.pi, 0.0)
    return ti, tr, phi, data["brdf"]


def make_model(ti, tr, phi):
    ci, cr = np.cos(ti), np.cos(tr)
    si, sr = np.sin(ti), np.sin(tr)
    cos2g = 0.5 * (ci * cr + si * sr * np.cos(phi) + 1.0)
    cg = np.sqrt(cos2g)
    ca = (ci + cr) / (2.0 * cg)
    x = np.maximum(1.0 - cg, 0.0)
    m = ci * cr
    l1p = np.log1p(m)

    def f(q):
        kb, lkr, beta, a, kd, c = q
        kr2 = np.exp(2.0 * lkr)
        facet = kr2 * ca / (1.0 + (kr2 - 1.0) * ca)
        lobe = np.exp(-beta * x**a)
        return kb / (np.pi * np.log(2.0)) * facet * lobe * l1p + kd / np.pi * m**c

    return f


def main():
    ti, tr, phi, y = load(sys.argv[1])
    f = make_model(ti, tr, phi)

    def resid(q):
        return (f(q) - y) / y

    def rms(q):
        return float(np.sqrt(np.mean(resid(q) ** 2)))

    rng = np.random.default_rng(12345)
    t = time.perf_counter()
    best = None
    for _ in range(32):
        x0 = LO + (HI - LO) * rng.random(6)
        r = least_squares(resid, x0, bounds=(LO, HI), method="trf")
        if best is None or r.cost < best.cost:
            best = r
    ls_time = time.perf_counter() - t
    ls_err = rms(best.x)

    t = time.perf_counter()
    da = dual_annealing(lambda q: 0.5 * float(np.sum(resid(q) ** 2)), list(zip(LO, HI)), seed=12345)
    da_time = time.perf_counter() - t
    print(
        json.dumps(
            {
                "least_squares_32": {"seconds": ls_time, "rms_rel": ls_err, "x": best.x.tolist()},
                "dual_annealing": {"seconds": da_time, "rms_rel": rms(da.x), "x": da.x.tolist()},
            }
        )
    )


if __name__ == "__main__":
    main()
