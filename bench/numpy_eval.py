"""numpy peer for `brdf bench eval`: the six-parameter model (eq. 3) evaluated with numpy's
vectorised arithmetic over the same N^3 grid. Prints the best-of-7 nanoseconds per point and
the sum of the values; with a fourth argument, writes the values as raw little-endian f64 so
that the benchmark can measure numpy's error against the same reference as every other path.

    python3 numpy_eval.py [N [MAX_THETA_DEG [kb,kr,b,a,kd,c [VALUES_FILE]]]]

Written the way a numpy user would write it: whole-array operations, float64, one thread.
"""
import sys
import time

import numpy as np

KHAKI = (0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2)


def grid(n, max_theta):
    k = (np.arange(n) + 0.5) / n
    zen = np.deg2rad(k * max_theta)
    phi = np.deg2rad(k * 360.0)
    ti, tr, ph = np.meshgrid(zen, zen, phi, indexing="ij")
    return ti.ravel(), tr.ravel(), ph.ravel()


def six(p, ti, tr, phi):
    kb, kr, b, a, kd, c = p
    ci, cr = np.cos(ti), np.cos(tr)
    si, sr = np.sin(ti), np.sin(tr)
    cos2g = 0.5 * (ci * cr + si * sr * np.cos(phi) + 1.0)
    cg = np.sqrt(cos2g)
    ca = (ci + cr) / (2.0 * cg)
    kr2 = kr * kr
    facet = kr2 * ca / (1.0 + (kr2 - 1.0) * ca)
    lobe = np.exp(-abs(b) * np.maximum(1.0 - cg, 0.0) ** a)
    m = ci * cr
    return kb / (np.pi * np.log(2.0)) * facet * lobe * np.log1p(m) + kd / np.pi * m**c


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    max_theta = float(sys.argv[2]) if len(sys.argv) > 2 else 90.0
    p = tuple(float(v) for v in sys.argv[3].split(",")) if len(sys.argv) > 3 else KHAKI
    ti, tr, ph = grid(n, max_theta)
    best = float("inf")
    f = None
    for _ in range(7):
        t = time.perf_counter()
        f = six(p, ti, tr, ph)
        best = min(best, time.perf_counter() - t)
    print(f"{best * 1e9 / ti.size:.3f} {float(f.sum())!r}")
    if len(sys.argv) > 4:
        f.astype("<f8").tofile(sys.argv[4])


if __name__ == "__main__":
    main()
