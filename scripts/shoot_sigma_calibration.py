#!/usr/bin/env python3
"""Is the fit's whole uncertainty honest on a photo shoot? Over many simulated shoots (each its own
seed, lamps written off by N(0, 2 cm), intensities unknown) it imports and fits each, and prints
err/sigma of psi, n and k_d per shoot and their RMS over all (an honest sigma gives about 1; the
goal is 0.5 to 2), for the whole sigma and for the images' noise alone. With --brdf ggx the
shoots are rendered with an anisotropic GGX BRDF the fit does not have (synth --photos --brdf):
there only psi has a truth to compare with (the fit's n and k_d are the line model's best stand-ins),
and the question is whether psi's error stays within 3 sigma with sigma under 1 degree.

  scripts/shoot_sigma_calibration.py [--aniso build/aniso] [--seeds 20] [--views 12] [--brdf ggx]
                                     [--work DIR]
"""
import argparse, json, math, os, statistics, subprocess, sys, tempfile

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--aniso", default=os.path.join(os.path.dirname(__file__), "..", "build", "aniso"))
ap.add_argument("--seeds", type=int, default=20)
ap.add_argument("--first-seed", type=int, default=1)
ap.add_argument("--views", type=int, default=12)
ap.add_argument("--preset", default="brushed-metal")
ap.add_argument("--lamp-error", default="0.02")
ap.add_argument("--brdf", default="truth", choices=["truth", "ggx"])
ap.add_argument("--vignetting", default="0", help="synth --photos --vignetting (the lens's falloff)")
ap.add_argument("--work", default=None, help="folder for the shoots (default: a temporary one); "
                "a shoot already imported there is fitted again, not made again")
ap.add_argument("--fit-args", default="", help="more options for aniso fit, e.g. --lamps-as-imported or \"--psi-from-symmetry never\"")
a = ap.parse_args()
work = a.work or tempfile.mkdtemp(prefix="aniso_sigma_")

def run(*args):
    r = subprocess.run([a.aniso, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"aniso {' '.join(args)} failed:\n{r.stdout}{r.stderr}")

def make_shoot(d, seed):
    run("synth", "--photos", a.preset, d + "/shoot", "--views", str(a.views), "--walk", "upright",
        "--lamp-error", a.lamp_error, "--hide-intensity", "--seed", str(seed), "--brdf", a.brdf,
        "--vignetting", a.vignetting, "--force")
    run("import", d + "/shoot/shoot.json", "--out", d + "/cap", "--no-overlays", "--quiet", "--force")

rows = {"whole": [], "noise": []}
psi_err, psi_sigma, by_symmetry = [], [], 0
print(f"{'seed':>4} {'psi err':>9} {'sigma':>7} {'psi/sig':>8} {'n err %':>8} {'n/sig':>7} {'kd err %':>9} {'kd/sig':>7}  (whole sigma; noise-only in brackets)")
for seed in range(a.first_seed, a.first_seed + a.seeds):
    d = os.path.join(work, f"s{seed}")
    if not os.path.exists(d + "/cap/capture.json"):
        make_shoot(d, seed)
    run("fit", d + "/cap", "--out", d + "/m.json", "--force", *a.fit_args.split())
    truth = json.load(open(d + "/shoot/material.json"))
    m = json.load(open(d + "/m.json"))
    err = {"psi": (m["fiber_angle_deg"] - truth["fiber_angle_deg"] + 90) % 180 - 90,
           "n": m["n"] - truth["n"], "kd": m["kd"][1] - truth["kd"][1]}
    line = f"{seed:4d}"
    for kind, unc in (("whole", m["uncertainty"]), ("noise", m["report"].get("uncertainty_noise_only", m["uncertainty"]))):
        sig = {"psi": unc["fiber_angle_deg"], "n": unc["n"], "kd": unc["kd"]["g"] if isinstance(unc["kd"], dict) else unc["kd"][1]}
        # A sigma that is not given (the number undetermined, as the isotropic part's n may be) is nan.
        rows[kind].append({k: err[k] / sig[k] if sig[k] else float("nan") for k in err})
    psi_err.append(err["psi"])
    psi_sigma.append(m["uncertainty"].get("fiber_angle_deg") or float("nan"))
    by_symmetry += bool(m["report"].get("psi_from_symmetry", {}).get("used"))
    w, n = rows["whole"][-1], rows["noise"][-1]
    print(f"{seed:4d} {err['psi']:9.4f} {m['uncertainty']['fiber_angle_deg'] or float('nan'):7.4f} {w['psi']:8.2f} {100 * err['n'] / truth['n']:8.3f} {w['n']:7.2f} "
          f"{100 * err['kd'] / truth['kd'][1]:9.3f} {w['kd']:7.2f}  [{n['psi']:.1f} {n['n']:.1f} {n['kd']:.1f}]", flush=True)
for kind in ("whole", "noise"):
    rms = {}
    for k in ("psi", "n", "kd"):
        v = [r[k] for r in rows[kind] if math.isfinite(r[k])]
        rms[k] = math.sqrt(sum(x * x for x in v) / len(v)) if v else float("nan")
    print(f"RMS err/sigma over {len(rows[kind])} shoots, {kind:5s} sigma: psi {rms['psi']:.2f}, n {rms['n']:.2f}, k_d {rms['kd']:.2f}")
    worst = max((abs(r["psi"]) for r in rows[kind] if math.isfinite(r["psi"])), default=float("nan"))
    print(f"  largest |psi err| / sigma: {worst:.2f}")
known = sorted(s for s in psi_sigma if math.isfinite(s))
print(f"psi error RMS {math.sqrt(sum(e * e for e in psi_err) / len(psi_err)):.3f} deg, largest "
      f"{max(abs(e) for e in psi_err):.3f}; sigma median "
      f"{statistics.median(known) if known else float('nan'):.3f} deg, at most 1 deg in "
      f"{sum(s <= 1 for s in known)} of {len(psi_sigma)}; psi from the highlight's symmetry in "
      f"{by_symmetry}")
