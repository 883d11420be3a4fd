#!/usr/bin/python3
"""The hard CAM family (benches/cam/family.py) through `interpd plan`: per program and per
family, the figures issue 41 asks for, printed, not asserted.

    cargo build --release -p interpd
    /usr/bin/python3 benches/cam/family_bench.py target/release/interpd [--count 70] [--seed 1]
        [--step-mm 0.02] [--period-ms 1] [--baseline OTHER_BIN] [--kinds cusp,raster] [--keep DIR]

Per program, from `interpd plan --json --period-ms P --out CSV` on benches/cam/family_machine.toml:
motion time and its ratio to the acceleration-only bound on the unrounded curve (family.py),
and to the better of that and the per-axis jerk-limited bound between reversals (`/best`,
family.axis_jerk_bound: what the jerk limit costs at U-turns and cusps, which the
acceleration-only bound does not see);
the largest distance of the setpoints from the unrounded curve (the programmed points for the
outlier and wander families) minus the tolerance; the axis velocity, acceleration and jerk by
finite differences of the setpoints against the limits, beside the planner's own `max_ratio`;
forced stops, exact-stop fallbacks, the longest plan() call and look-ahead step; smoothing +
planning against the motion time (x real time). Per family: the worst of each.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import family  # noqa: E402
from cam_bench import max_distance  # noqa: E402  (the grid-binned polyline distance)

MACHINE = os.path.join(HERE, "family_machine.toml")


def run(binary, base, period_ms, limits):
    desc = json.load(open(base + ".json"))
    curve = np.load(base + ".curve.npy")
    csv = base + ".csv"
    t0 = time.time()
    r = subprocess.run([binary, "plan", base + ".ngc", "--machine", MACHINE, "--json", "--period-ms",
                        str(period_ms), "--out", csv], capture_output=True, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        return dict(desc, error=(r.stdout + r.stderr).strip().splitlines()[-1:])
    j = json.loads(r.stdout)
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    os.remove(csv)
    dt = period_ms * 1e-3
    pos = data[:, 5:8]
    fd = [0.0, 0.0, 0.0]
    for k in range(3):
        x = pos[:, k]
        for order in range(3):
            x = np.diff(x) / dt
            fd[order] = max(fd[order], float(np.abs(x).max()) / limits[k][order])
    # Only the smoothed part: from the first setpoint at the program's first G64 point.
    start = int(np.argmax(np.sqrt(((pos - curve[0]) ** 2).sum(axis=1)) < 1e-3))
    # The motion along the family's curve: from where the G0 approach ends.
    duration = float(data[-1, 0] - data[start, 0])
    dev = max_distance(curve, pos[start:]) - family.TOL_MM
    s = j["prep"]["stats"]
    work_s = (j["prep"]["wall_ms"] + j["plan_ms"]) * 1e-3
    mr = j.get("max_ratio", {})
    return dict(desc, duration_s=duration, dev_um=dev * 1e3, fd=fd,
                reported=[mr.get("vel", math.nan), mr.get("acc", math.nan), mr.get("jerk", math.nan)],
                forced=j.get("forced_stops", 0), exact=s["fallback_exact"], smaller=s["fallback_smaller"],
                looser=s["fallback_looser"], call_max_ms=j["plan_call_max_ms"],
                step_max_ms=j.get("step_max_ms", math.nan), rt=j["duration_s"] / max(work_s, 1e-9), wall_s=wall)


def fmt_ratio(r):
    if r.get("bound_s") in (None, 0):
        return "     -"
    return f"{r['duration_s'] / r['bound_s']:6.3f}"


def best_bound_s(r):
    """The tighter of the two lower bounds: acceleration-only on the curve, and the per-axis
    jerk-limited one between reversals (family.axis_jerk_bound); either may be missing."""
    return max(r.get("bound_s") or 0.0, r.get("jerk_bound_s") or 0.0)


def fmt_jratio(r):
    b = best_bound_s(r)
    return f"{r['duration_s'] / b:7.3f}" if b > 0 else "      -"


def table(results):
    print(f"{'program':<22} {'moves':>6} {'motion s':>9} {'/bound':>6} {'/best':>7} {'cusps':>5} {'dev-tol um':>10} "
          f"{'fd v/a/j':>17} {'reported j':>10} {'forced':>6} {'exact':>5} {'call ms':>8} {'step ms':>8} {'x rt':>6}")
    for r in results:
        name = f"{r['kind']}-{r['seed']}"
        if "error" in r:
            print(f"{name:<22} ERROR {r['error']}")
            continue
        fd = "/".join(f"{x:.2f}" for x in r["fd"])
        print(f"{name:<22} {r['moves']:>6} {r['duration_s']:>9.3f} {fmt_ratio(r)} {fmt_jratio(r)} {r['true_cusps']:>5} "
              f"{r['dev_um']:>10.2f} {fd:>17} {r['reported'][2]:>10.3f} {r['forced']:>6} {r['exact']:>5} "
              f"{r['call_max_ms']:>8.1f} {r['step_max_ms']:>8.1f} {r['rt']:>6.1f}")


def summary(results):
    print(f"\n{'family':<8} {'n':>3} {'err':>3} {'worst /bound':>12} {'worst /best':>11} {'excess s':>8} {'dev-tol um':>10} {'fd v':>6} "
          f"{'fd a':>6} {'fd j':>6} {'forced':>6} {'exact':>6} {'call ms':>8} {'min x rt':>8}")
    for kind in family.KINDS:
        rs = [r for r in results if r["kind"] == kind]
        if not rs:
            continue
        ok = [r for r in rs if "error" not in r]
        if not ok:
            print(f"{kind:<8} {len(rs):>3} {len(rs):>3}")
            continue
        bounded = [r for r in ok if r.get("bound_s")]
        worst = max((r["duration_s"] / r["bound_s"] for r in bounded), default=math.nan)
        best = [r for r in ok if best_bound_s(r) > 0]
        worst_best = max((r["duration_s"] / best_bound_s(r) for r in best), default=math.nan)
        # Beyond 1.05 x bound + 0.1 s per true cusp (the target), s.
        excess = max((r["duration_s"] - (1.05 * r["bound_s"] + 0.1 * r["true_cusps"]) for r in bounded),
                     default=math.nan)
        print(f"{kind:<8} {len(rs):>3} {len(rs) - len(ok):>3} {worst:>12.3f} {worst_best:>11.3f} {excess:>8.3f} "
              f"{max(r['dev_um'] for r in ok):>10.2f} {max(r['fd'][0] for r in ok):>6.3f} "
              f"{max(r['fd'][1] for r in ok):>6.3f} {max(r['fd'][2] for r in ok):>6.3f} "
              f"{sum(r['forced'] for r in ok):>6} {sum(r['exact'] for r in ok):>6} "
              f"{max(r['call_max_ms'] for r in ok):>8.1f} {min(r['rt'] for r in ok):>8.1f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--baseline")
    ap.add_argument("--count", type=int, default=len(family.KINDS))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--step-mm", type=float, default=0.02)
    ap.add_argument("--period-ms", type=float, default=1.0)
    ap.add_argument("--kinds", default=",".join(family.KINDS))
    ap.add_argument("--keep", help="write the programs here and keep them")
    ap.add_argument("--json", help="write every result to this file")
    a = ap.parse_args()
    limits = family.load_machine(MACHINE)
    d = a.keep or tempfile.mkdtemp(prefix="interpd-family-")
    bases = family.write(d, a.seed, a.count, a.step_mm, MACHINE, a.kinds.split(","))
    all_results = {}
    for label, binary in [("this build", a.binary)] + ([("baseline", a.baseline)] if a.baseline else []):
        print(f"\n== {label}: {binary} ({len(bases)} programs, step {a.step_mm} mm, {a.period_ms} ms samples)")
        results = [run(binary, b, a.period_ms, limits) for b in bases]
        table(results)
        summary(results)
        all_results[label] = results
    if a.json:
        with open(a.json, "w") as f:
            json.dump(all_results, f, indent=1)


if __name__ == "__main__":
    main()
