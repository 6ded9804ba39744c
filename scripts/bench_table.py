#!/usr/bin/env python3
"""BENCHMARKS.md's opening table from the saved results (bench/results/*.json): one row per measure
with a target (ours, the baseline, the ratio, the target, met or not), each from the newest file
that holds its suite, with that file's date (its last commit) and machine. Prints Markdown.

  scripts/bench_table.py [bench/results]
"""
import json, os, subprocess, sys

root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "bench", "results")
files = [f for f in os.listdir(root) if f.startswith("bench_") and f.endswith(".json")]

def date(path):
    r = subprocess.run(["git", "log", "-1", "--format=%ad", "--date=short", "--", path],
                       capture_output=True, text=True, cwd=os.path.dirname(path) or ".")
    return r.stdout.strip() or "not committed"

# The newest file per suite (a suite's own run before the whole set's).
best = {}
for f in files:
    path = os.path.join(root, f)
    j = json.load(open(path))
    d = date(path)
    threads = j.get("machine", {}).get("hardware_threads", "?")
    machine = "H200 machine, 16 cores" if "h200" in f else f"dev machine, {threads} cores"
    suites = {e["suite"] for e in j["entries"]}
    for s in suites:
        key = (s, "h200" in f)
        own = f != "bench_all.json"
        if key not in best or (d, own) > (best[key][1], best[key][3]):
            best[key] = (path, d, machine, own)

def num(x):
    if isinstance(x, (int, float)):
        return f"{x:.4g}"
    return "" if x is None else str(x)

print("| suite | measure | ours | baseline | ratio | target | met | date | machine |")
print("|---|---|---|---|---|---|---|---|---|")
met = missed = 0
for (suite, _), (path, d, machine, _) in sorted(best.items()):
    for e in json.load(open(path))["entries"]:
        if e["suite"] != suite or "target" not in e:
            continue
        ok = bool(e.get("met"))
        met += ok
        missed += not ok
        unit = e.get("unit", "")
        print(f"| {suite} | {e['name']} | {num(e.get('ours'))} {unit} | {num(e.get('baseline'))} {unit} | "
              f"{num(e.get('ratio'))} | {e['target']} | {'met' if ok else 'missed'} | {d} | {machine} |")
print(f"\n{met} targets met, {missed} missed.")
