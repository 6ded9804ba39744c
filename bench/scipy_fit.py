#!/usr/bin/python3
"""The plain alternative a user would script: SciPy's least_squares on the line model.

Reads the observations written by `aniso bench fit` (float64 rows of
Vu Vw Vn Lu Lw Ln Er Eg Eb yr yg yb smath mapv), starts from the given point
(kd[3] ks[3] log n psi) and prints a JSON line with the solution, the solve's wall time and
the time it took to read the rows.
Usage: scipy_fit.py OBS.bin START_JSON
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares


def main():
    t_load = time.perf_counter()
    obs = np.fromfile(sys.argv[1], dtype="<f8").reshape(-1, 14)
    x0 = np.array(json.loads(sys.argv[2]), dtype=float)
    V, L, E, y = obs[:, 0:3], obs[:, 3:6], obs[:, 6:9], obs[:, 9:12]
    load = time.perf_counter() - t_load

    def residuals(x):
        kd, ks, n, psi = x[0:3], x[3:6], np.exp(x[6]), x[7]
        c, s = np.cos(psi), np.sin(psi)
        a = np.clip(c * L[:, 0] + s * L[:, 1], -1, 1)
        b = np.clip(c * V[:, 0] + s * V[:, 1], -1, 1)
        sl, sv = np.sqrt(1 - a * a), np.sqrt(1 - b * b)
        g = sl * sv - a * b
        spec = np.where(g > 0, np.exp(n * np.log(np.maximum(g, 1e-300))), 0.0)
        f = L[:, 2:3] * (kd[None, :] * sl[:, None] + ks[None, :] * spec[:, None])
        return (E * f - y).ravel()

    lo = [0, 0, 0, 0, 0, 0, 0.0, -np.inf]
    hi = [100, 100, 100, 100, 100, 100, np.log(1e4), np.inf]
    t0 = time.perf_counter()
    r = least_squares(residuals, x0, bounds=(lo, hi))
    dt = time.perf_counter() - t0
    print(json.dumps({"x": r.x.tolist(), "seconds": dt, "seconds_load": load, "nfev": int(r.nfev), "status": int(r.status),
                      "cost": float(r.cost), "rows": int(obs.shape[0])}))


if __name__ == "__main__":
    main()
