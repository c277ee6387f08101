"""numpy peer for brdf-bench: the six-parameter model (eq. 3, khaki) evaluated with numpy's
vectorised arithmetic over the same N^3 grid as host/brdf-bench. Prints the best-of-7
nanoseconds per point and the sum of the values (the checksum brdf-bench compares).

Written the way a numpy user would write it: whole-array operations, float64.
"""
import sys
import time

import numpy as np

KB, KR, B, A, KD, C = 0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2


def grid(n):
    k = (np.arange(n) + 0.5) / n
    zen = np.deg2rad(k * 90.0)
    phi = np.deg2rad(k * 360.0)
    ti, tr, ph = np.meshgrid(zen, zen, phi, indexing="ij")
    return ti.ravel(), tr.ravel(), ph.ravel()


def six(ti, tr, phi):
    ci, cr = np.cos(ti), np.cos(tr)
    si, sr = np.sin(ti), np.sin(tr)
    cos2g = 0.5 * (ci * cr + si * sr * np.cos(phi) + 1.0)
    cg = np.sqrt(cos2g)
    ca = (ci + cr) / (2.0 * cg)
    kr2 = KR * KR
    facet = kr2 * ca / (1.0 + (kr2 - 1.0) * ca)
    lobe = np.exp(-abs(B) * np.maximum(1.0 - cg, 0.0) ** A)
    m = ci * cr
    return KB / (np.pi * np.log(2.0)) * facet * lobe * np.log1p(m) + KD / np.pi * m**C


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    ti, tr, ph = grid(n)
    best = float("inf")
    total = 0.0
    for _ in range(7):
        t = time.perf_counter()
        f = six(ti, tr, ph)
        best = min(best, time.perf_counter() - t)
        total = float(f.sum())
    print(f"{best * 1e9 / ti.size:.3f} {total!r}")


if __name__ == "__main__":
    main()
