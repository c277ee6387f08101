"""`brdf.eval` (the Python package, host/brdf-py) against numpy's vectorised six-parameter
model (bench/numpy_eval.py) on the same points in one process. Prints the best-of-7 time
per point of each, their ratio and the largest relative difference.

    python3 bench/python_eval.py [POINTS]        # default 1,000,000

Both take degrees (numpy converts with np.deg2rad inside the timed call); both are float64.
brdf.eval runs the core's batch path (the GIL released) on one thread (`threads=1`, the
figure compared with numpy, which runs on one) and on all cores (its default).
"""
import os
import sys
import time

import numpy as np

import brdf

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_eval import KHAKI, six  # noqa: E402

PARAMS = dict(zip(("kb", "kr", "b", "a", "kd", "c"), KHAKI))


def best_of(k, f):
    best, out = float("inf"), None
    for _ in range(k):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    rng = np.random.default_rng(1)
    ti = rng.uniform(0, 89, n)
    tr = rng.uniform(0, 89, n)
    ph = rng.uniform(0, 360, n)
    t_brdf, f_brdf = best_of(7, lambda: brdf.eval("six", PARAMS, ti, tr, ph, threads=1))
    t_all, f_all = best_of(7, lambda: brdf.eval("six", PARAMS, ti, tr, ph))
    assert f_all.tobytes() == f_brdf.tobytes()
    t_np, f_np = best_of(7, lambda: six(KHAKI, np.deg2rad(ti), np.deg2rad(tr), np.deg2rad(ph)))
    rel = float(np.max(np.abs(f_brdf - f_np) / np.abs(f_np)))
    print(f"points {n}")
    print(f"brdf.eval, one thread  {t_brdf * 1e9 / n:8.3f} ns/point")
    print(f"brdf.eval, {os.cpu_count()} cores    {t_all * 1e9 / n:8.3f} ns/point")
    print(f"numpy                  {t_np * 1e9 / n:8.3f} ns/point")
    print(f"numpy / brdf.eval time ratio: one thread {t_np / t_brdf:.2f}, all cores {t_np / t_all:.2f}; "
          f"max relative difference {rel:.2e}")


if __name__ == "__main__":
    main()
