#!/usr/bin/python3
"""Writes the project's notebooks (kept as code here so they review like code).

scripts/notebooks.sh runs this, then executes every notebook headless; the figures land in
notebooks/figures/ next to BENCHMARKS.md's numbers.
"""
import nbformat as nbf

HEADER = """import json, os, subprocess, sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
ROOT = os.path.abspath(os.path.join(os.getcwd(), ".."))
ANISO = os.path.join(ROOT, "build", "aniso")
FIG = os.path.join(ROOT, "notebooks", "figures")
WORK = os.path.join(ROOT, "build", "notebook_work")
os.makedirs(FIG, exist_ok=True); os.makedirs(WORK, exist_ok=True)
def run(*args):
    r = subprocess.run([ANISO, *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(r.stdout + r.stderr)
    return r.stdout
"""


def notebook(path, cells):
    nb = nbf.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbf.v4.new_markdown_cell(c[1]) if c[0] == "md" else nbf.v4.new_code_cell(c[1]) for c in cells]
    nbf.write(nb, path)


notebook("notebooks/bench_pareto.ipynb", [
    ("md", "# Run time against error\nReads `bench/results/bench_all.json` (written by `aniso bench all`) and plots each "
           "sweep: the fit's observations against time and error (ours and SciPy's), the fiber model's accuracy "
           "setting against time per evaluation (the Pareto front), and the bake's table size against error."),
    ("code", HEADER + """
B = json.load(open(os.path.join(ROOT, "bench", "results", "bench_all.json")))
E = B["entries"]
print(len(E), "entries;", sum(1 for e in E if e.get("met") is True), "targets met,",
      sum(1 for e in E if e.get("met") is False), "missed")"""),
    ("code", """fit = [e for e in E if e["name"].startswith("line solve vs SciPy")]
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
obs = [e["observations"] for e in fit]
ax[0].loglog(obs, [e["ours"] for e in fit], "o-", label="aniso (Ceres) solve")
ax[0].loglog(obs, [e["baseline"] for e in fit], "s--", label="SciPy least_squares")
tot = [e for e in E if e["name"].startswith("line fit vs SciPy")]
ax[0].loglog(obs, [e["ours"] for e in tot], "^:", label="aniso total (load, start, solve, covariance)")
ax[0].set_xlabel("observations"); ax[0].set_ylabel("wall time [s]"); ax[0].legend(); ax[0].set_title("line fit: time")
ax[1].loglog([e["ours"] for e in fit], [e["error"] for e in fit], "o-", label="aniso")
ax[1].loglog([e["baseline"] for e in fit], [e["baseline_error"] for e in fit], "s--", label="SciPy")
ax[1].set_xlabel("wall time [s]"); ax[1].set_ylabel("worst parameter error"); ax[1].legend()
ax[1].set_title("run time against error (1 % noise)")
fig.tight_layout(); fig.savefig(os.path.join(FIG, "fit_time_vs_error.png"), dpi=110)"""),
    ("code", """fib = [e for e in E if e["suite"] == "fiber"]
fig, ax = plt.subplots(figsize=(6, 4))
for n in sorted({e["name"].split("n=")[1] for e in fib}, key=int):
    pts = [e for e in fib if e["name"].endswith("n=" + n)]
    ax.loglog([e["ours"] for e in pts], [max(e["error"], 1e-16) for e in pts], "o-", label="n = " + n)
    ax.loglog([pts[0]["baseline"]], [pts[0]["baseline_error"]], "kx")
ax.axhline(1e-4, color="gray", lw=0.8); ax.set_xlabel("time per evaluation [ns]"); ax.set_ylabel("max relative error of S")
ax.set_title("fiber model: accuracy setting (x: brute force)"); ax.legend()
fig.tight_layout(); fig.savefig(os.path.join(FIG, "fiber_pareto.png"), dpi=110)"""),
    ("code", """bk = [e for e in E if e["suite"] == "bake"]
fig, ax = plt.subplots(figsize=(6, 4))
for idx, ls in (("angle", "-"), ("cosine", "--")):
    for n in (10, 100, 1000, 10000):
        pts = sorted([e for e in bk if e["index"] == idx and e["n"] == n], key=lambda e: e["size"])
        if pts:
            ax.loglog([e["size"] for e in pts], [e["error"] for e in pts], "o" + ls, label=f"{idx}, n={n}")
ax.set_xlabel("table size N (N x N)"); ax.set_ylabel("max abs error vs direct evaluation")
ax.set_title("bake: table size against error"); ax.legend(fontsize=7, ncol=2)
fig.tight_layout(); fig.savefig(os.path.join(FIG, "bake_error.png"), dpi=110)"""),
    ("code", """rows = [e for e in E if e["suite"] in ("capture", "preview", "skips")]
for e in rows:
    print(f'{e["suite"]:8s} {e["name"][:70]:70s} ours {e["ours"]:.4g} base {e["baseline"]} ratio {e["ratio"]} {e.get("met", "")}')"""),
])

notebook("notebooks/fit_quality.ipynb", [
    ("md", "# Fit quality\nRecovered against true parameters over seeded random materials (1 % noise), and a "
           "residual map of one fit (`aniso verify --residuals`)."),
    ("code", HEADER + """
truth, fitted, sig = [], [], []
for seed in range(1, 13):
    d = os.path.join(WORK, f"rand{seed}")
    run("synth", "random", d, "--seed", seed, "--views", 8, "--size", "64x64", "--noise", 0.01)
    run("fit", d, "--out", d + ".json")
    t, f = json.load(open(os.path.join(d, "truth.json"))), json.load(open(d + ".json"))
    truth.append(t); fitted.append(f)"""),
    ("code", """fig, ax = plt.subplots(1, 4, figsize=(14, 3.4))
for a, key, lab in zip(ax, ["kd", "ks", "n", "fiber_angle_deg"], ["k_d (red)", "k_s (red)", "n", "psi [deg]"]):
    tv = [t[key][0] if isinstance(t[key], list) else t[key] for t in truth]
    fv = [f[key][0] if isinstance(f[key], list) else f[key] for f in fitted]
    uv = [f["uncertainty"].get(key) for f in fitted]
    uv = [(u[0] if isinstance(u, list) else u) or 0 for u in uv]
    a.errorbar(tv, fv, yerr=3 * np.array(uv), fmt="o", ms=4)
    lo, hi = min(tv + fv), max(tv + fv); a.plot([lo, hi], [lo, hi], "k-", lw=0.6)
    a.set_xlabel("true " + lab); a.set_ylabel("recovered")
    if key == "n": a.set_xscale("log"); a.set_yscale("log")
fig.suptitle("recovered against true (error bars: 3 reported sigma), 12 random materials, 1 % noise")
fig.tight_layout(); fig.savefig(os.path.join(FIG, "recovered_vs_true.png"), dpi=110)"""),
    ("code", """import cv2
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
d = os.path.join(WORK, "torus")
run("synth", "silk-torus", d, "--views", 4, "--size", "128x128", "--noise", 0.005)
run("fit", d, "--model", "fiber", "--out", d + ".json")
run("verify", d, d + ".json", "--residuals", d + "_res")
r = cv2.imread(os.path.join(d + "_res", "residual_000.exr"), cv2.IMREAD_UNCHANGED)
img = cv2.imread(os.path.join(d, "images", "000.exr"), cv2.IMREAD_UNCHANGED)
fig, ax = plt.subplots(1, 2, figsize=(9, 4))
ax[0].imshow(np.clip(img[..., ::-1] / img.max() * 1.5, 0, 1) ** (1 / 2.2)); ax[0].set_title("captured (silk torus)")
m = ax[1].imshow(r[..., 1], cmap="RdBu", vmin=-0.05, vmax=0.05); ax[1].set_title("residual, green (model - image)")
plt.colorbar(m, ax=ax[1]); [a.axis("off") for a in ax]
fig.tight_layout(); fig.savefig(os.path.join(FIG, "residual_map.png"), dpi=110)"""),
])

notebook("notebooks/models_and_tables.ipynb", [
    ("md", "# The two models and their tables\nPolar plots of the line and fiber models (via `aniso eval` on a "
           "sample table), and the error map of a baked lookup table against direct evaluation."),
    ("code", HEADER + """
import pandas as pd
phis = np.arange(0, 360, 2.0)
rows = [(45.0, 0.0, 45.0, p) for p in phis]
pd.DataFrame(rows, columns=["theta_i_deg", "phi_i_deg", "theta_o_deg", "phi_o_deg"]).to_csv(os.path.join(WORK, "polar.csv"), index=False)
mats = {}
for name, extra in (("line", {}), ("fiber s=0", {"model": "fiber", "topology": {"s": 0.0}}),
                    ("fiber s=0.5", {"model": "fiber", "topology": {"s": 0.5}})):
    m = {"format": "aniso-material", "version": 1, "model": "line", "kd": 0.2, "ks": 0.6, "n": 30, "fiber_angle_deg": 0}
    m.update(extra)
    p = os.path.join(WORK, name.replace(" ", "_").replace("=", "") + ".json")
    json.dump(m, open(p, "w"))
    out = p + ".csv"
    run("eval", p, "--table", os.path.join(WORK, "polar.csv"), "--out", out)
    mats[name] = pd.read_csv(out)"""),
    ("code", """fig = plt.figure(figsize=(6, 6)); ax = fig.add_subplot(projection="polar")
for name, df in mats.items():
    ax.plot(np.radians(df.phi_o_deg), df.r, label=name)
ax.set_title("reflectance vs view azimuth (light at 45 deg along T, view at 45 deg)"); ax.legend(loc="lower left")
fig.savefig(os.path.join(FIG, "polar_models.png"), dpi=110)"""),
    ("code", """os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2
m = {"format": "aniso-material", "version": 1, "model": "line", "kd": 0.2, "ks": 0.6, "n": 200, "fiber_angle_deg": 0}
json.dump(m, open(os.path.join(WORK, "n200.json"), "w"))
maps = {}
for idx in ("angle", "cosine"):
    out = os.path.join(WORK, "bake_" + idx)
    run("bake", os.path.join(WORK, "n200.json"), "--out", out, "--size", 64, "--index", idx)
    maps[idx] = cv2.imread(os.path.join(out, "specular.exr"), cv2.IMREAD_UNCHANGED)
    maps[idx] = maps[idx][..., 2] if maps[idx].ndim == 3 else maps[idx]
# Direct evaluation on a fine grid and bilinear lookup of each table.
g = np.linspace(-1, 1, 401); A, Bv = np.meshgrid(g, g)
def S(a, b, n=200.0):
    x = np.sqrt(1 - a * a) * np.sqrt(1 - b * b) - a * b
    return np.where(x > 0, np.exp(n * np.log(np.maximum(x, 1e-300))), 0)
def coord(a, idx, N=64):
    return np.arccos(-a) / np.pi * (N - 1) if idx == "angle" else (a + 1) / 2 * (N - 1)
from scipy.ndimage import map_coordinates
fig, ax = plt.subplots(1, 2, figsize=(10, 4.3))
for a_, idx in zip(ax, ("angle", "cosine")):
    look = map_coordinates(maps[idx], [coord(Bv, idx), coord(A, idx)], order=1)
    err = np.abs(look - S(A, Bv))
    im = a_.imshow(err, extent=[-1, 1, -1, 1], origin="lower", vmin=0, vmax=0.5, cmap="magma")
    a_.set_title(f"{idx} index, 64^2, n=200: max {err.max():.3f}"); a_.set_xlabel("a = <L,T>"); a_.set_ylabel("b = <V,T>")
plt.colorbar(im, ax=ax); fig.savefig(os.path.join(FIG, "table_error_maps.png"), dpi=110)"""),
])
print("wrote notebooks/bench_pareto.ipynb, notebooks/fit_quality.ipynb, notebooks/models_and_tables.ipynb")
