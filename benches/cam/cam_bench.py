#!/usr/bin/env python3
"""Noisy CAM programs through smoothing and planning: the figures, printed, not asserted.

    cargo build --release -p interpd
    python3 benches/cam/cam_bench.py target/release/interpd                      # figures
    python3 benches/cam/cam_bench.py target/release/interpd --baseline OTHER_BIN # and OTHER's, same run
    python3 benches/cam/cam_bench.py target/release/interpd --quick              # 10x fewer moves

Programs (scripts/gen-examples.py, G64 P0.01, coordinates rounded to 4 decimals, a zero-length
move every 200-400 lines; the default 3-axis machine, config/machines/xyz.toml):

  dense20    the dense example's curve, 10 000 moves of 20 um  (199 mm)
  dense2     the same 199 mm of curve, 100 000 moves of 2 um
  dense20w   the whole curve, 100 000 moves of 20 um           (2 000 mm)
  troch23    trochoidal pocket path, 30 000 moves of ~23 um      (690 mm)
  troch2     the same kind of path, 100 000 moves of ~2.3 um    (230 mm)

Per program, from `interpd plan --json --period-ms 0.25 --out CSV --export-nodes JSON`:
motion time; its ratio to the acceleration-only lower bound on the planner's nodes
(benches/reference/optimum.py --no-ipopt); the largest distance of the 0.25 ms setpoints from
the programmed polyline minus the tolerance; the axis velocity, acceleration and jerk by finite
differences at 0.25 ms against the configured limits; smoothing + planning wall time against
the motion time (x real time); the longest single plan() call (plan_call_max_ms); exact-stop
fallbacks, forced stops, merged moves. dense2 is also compared with dense20 (same curve).

Memory (streaming): the dense curve at 2 um with 100 000 and 1 000 000 moves through
`interpd plan --json` alone (no CSV, no node export, which keep the whole problem): peak
resident memory (wait4 ru_maxrss), smoothing + planning against the motion time, and the
longest look-ahead step (step_max_ms: one element read, smoothed and planned), each the best
of --repeat runs (default 3: on a shared host the slower runs lost the CPU for part of the
time). Skipped with --quick.
"""
import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
MACHINE = os.path.join(ROOT, "config", "machines", "xyz.toml")
# `interpd plan` arguments that choose the machine file (--machine: e.g. one with
# `[prep] method = "bspline"`; the limits checked are that file's).
MACHINE_ARGS = []
TOL_MM = 0.01
PERIOD_MS = 0.25

# name, generator options (moves, then the file, then the step for --trochoid)
PROGRAMS = [
    ("dense20", "--cam-dense", "0.02", 10000),
    ("dense2", "--cam-dense", "0.002", 100000),
    ("dense20w", "--cam-dense", "0.02", 100000),
    ("troch23", "--trochoid", None, 30000),
    ("troch2", "--trochoid", "0.0023", 100000),
]


def load_module(rel, name):
    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, rel))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def generate(tmp, quick):
    out = {}
    for name, option, step, moves in PROGRAMS:
        path = os.path.join(tmp, name + ".ngc")
        moves = str(max(1000, moves // 10) if quick else moves)
        if option == "--cam-dense":
            args = [option, step, moves, path]
        else:
            args = [option, moves, path] + ([step] if step else [])
        subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "gen-examples.py")] + args,
                       check=True, stdout=subprocess.DEVNULL)
        out[name] = path
    return out


def polyline(path):
    """The programmed G1 points (absolute X Y Z lines) of a generated program."""
    pts, cur = [], {"X": 0.0, "Y": 0.0, "Z": 0.0}
    for line in open(path):
        if line.startswith("(") or line.startswith("M"):
            continue
        words = line.split()
        moved = False
        for w in words:
            if w[0] in "XYZ":
                cur[w[0]] = float(w[1:])
                moved = True
        if moved:
            pts.append((cur["X"], cur["Y"], cur["Z"]))
    return np.array(pts)


def max_distance(points, samples, cell=0.05):
    """Largest distance of `samples` from the polyline through `points` (segments binned in a
    grid of `cell` mm over x, y; distances beyond a cell are not needed here)."""
    a, b = points[:-1], points[1:]
    lo = np.floor((np.minimum(a, b)[:, :2] - cell) / cell).astype(np.int64)
    hi = np.floor((np.maximum(a, b)[:, :2] + cell) / cell).astype(np.int64)
    grid = {}
    for i in range(len(a)):
        for cx in range(lo[i, 0], hi[i, 0] + 1):
            for cy in range(lo[i, 1], hi[i, 1] + 1):
                grid.setdefault((cx, cy), []).append(i)
    ab = b - a
    len2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
    worst = 0.0
    for p in samples:
        idx = grid.get((int(np.floor(p[0] / cell)), int(np.floor(p[1] / cell))))
        if not idx:
            return float("inf")
        idx = np.array(idx)
        t = np.clip(((p - a[idx]) * ab[idx]).sum(axis=1) / len2[idx], 0.0, 1.0)
        d = np.sqrt((((a[idx] + t[:, None] * ab[idx]) - p) ** 2).sum(axis=1)).min()
        worst = max(worst, d)
    return worst


def run(binary, name, program, tmp, fd_limits, optimum):
    csv = os.path.join(tmp, f"{name}.csv")
    nodes = os.path.join(tmp, f"{name}.nodes.json")
    t0 = time.time()
    r = subprocess.run([binary, "plan", program, "--json", "--period-ms", str(PERIOD_MS), "--out", csv,
                        "--export-nodes", nodes] + MACHINE_ARGS, capture_output=True, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        return {"error": (r.stdout + r.stderr).strip().splitlines()[-1:]}
    j = json.loads(r.stdout)
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    first_axis = 5
    lim = fd_limits.limits(MACHINE)
    dt = PERIOD_MS * 1e-3
    ratios = [0.0, 0.0, 0.0]
    for k, l in enumerate(lim):
        x = data[:, first_axis + k]
        for order in range(3):
            x = np.diff(x) / dt
            ratios[order] = max(ratios[order], np.abs(x).max() / l[order])
    # Setpoints on the smoothed path, measured against the programmed polyline (the G0
    # approach and the Z plunge are not smoothed, so only samples in the G64 part count).
    pts = polyline(program)
    smoothed = data[:, first_axis:first_axis + 3]
    xy0 = pts[0]
    start = np.argmax(np.sqrt(((smoothed - xy0) ** 2).sum(axis=1)) < 1e-9) if len(smoothed) else 0
    dev = max_distance(pts, smoothed[start:])
    bound = optimum_bound(optimum, nodes)
    s = j["prep"]["stats"]
    # Smoothing and planning; reading the program is not counted (the baseline read it whole
    # before, outside these figures).
    work_s = (j["prep"]["wall_ms"] + j["plan_ms"]) * 1e-3
    os.remove(csv)
    os.remove(nodes)
    return {
        "duration_s": j["duration_s"], "bound_s": bound, "dev_mm": dev, "fd": ratios,
        "work_s": work_s, "rt": j["duration_s"] / work_s, "call_max_ms": j["plan_call_max_ms"],
        "prep_ms": j["prep"]["wall_ms"], "plan_ms": j["plan_ms"], "exact": s["fallback_exact"],
        "smaller": s["fallback_smaller"], "looser": s["fallback_looser"],
        "forced": j.get("forced_stops", 0), "merged": s.get("moves_merged", 0), "moves": s.get("moves_in", 0),
        "wall_s": wall,
    }


def plan_memory(binary, program):
    """Peak RSS (MB, GNU time's %M: the process's own, not the forking Python's) and the
    --json figures of `interpd plan PROGRAM --json`: smoothing + planning against the motion
    time, and the same with the reading of the program counted too."""
    r = subprocess.run(["/usr/bin/time", "-f", "%M", binary, "plan", program, "--json"] + MACHINE_ARGS, capture_output=True,
                       text=True)
    if r.returncode != 0:
        return {"error": r.stderr.strip().splitlines()[-1:]}
    j = json.loads(r.stdout)
    rss_kb = float(r.stderr.strip().splitlines()[-1])
    work_s = (j["prep"]["wall_ms"] + j["plan_ms"]) * 1e-3
    read_s = j.get("read_ms", 0.0) * 1e-3
    return {"rss_mb": rss_kb / 1024.0, "duration_s": j["duration_s"], "rt": j["duration_s"] / work_s,
            "rt_read": j["duration_s"] / (work_s + read_s),
            "step_max_ms": j.get("step_max_ms", float("nan")), "call_max_ms": j["plan_call_max_ms"],
            "max_ratio": j["max_ratio"]}


def best_of(binary, program, repeat):
    """`plan_memory` `repeat` times: the fastest run's times (the others lost the shared CPU
    for part of the time), the largest peak memory and step."""
    runs = [plan_memory(binary, program) for _ in range(repeat)]
    if any("error" in f for f in runs):
        return next(f for f in runs if "error" in f)
    best = dict(max(runs, key=lambda f: f["rt"]))
    best["rss_mb"] = max(f["rss_mb"] for f in runs)
    best["rt_read"] = max(f["rt_read"] for f in runs)
    best["step_max_ms"] = min(f["step_max_ms"] for f in runs)
    best["call_max_ms"] = min(f["call_max_ms"] for f in runs)
    return best


def memory_section(bins, tmp, repeat):
    progs = []
    for moves in (100_000, 1_000_000):
        path = os.path.join(tmp, f"dense2_{moves}.ngc")
        subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "gen-examples.py"), "--cam-dense", "0.002",
                        str(moves), path], check=True, stdout=subprocess.DEVNULL)
        progs.append((moves, path))
    print(f"\nbest of {repeat} runs; x_real: smoothing + planning, x_read: with the reading of the program")
    print("binary    moves      peak_MB  motion_s  x_real  x_read  step_max_ms  call_max_ms  vel    acc    jerk")
    for label, b in bins:
        rss = {}
        for moves, path in progs:
            f = best_of(b, path, repeat)
            if "error" in f:
                print(f"{label:9s} {moves:9d} FAILED: {f['error']}")
                continue
            rss[moves] = f["rss_mb"]
            r = f["max_ratio"]
            print(f"{label:9s} {moves:9d} {f['rss_mb']:8.1f} {f['duration_s']:9.3f} {f['rt']:7.1f} {f['rt_read']:7.1f} "
                  f"{f['step_max_ms']:12.2f} {f['call_max_ms']:12.2f}  {r['vel']:.4f} {r['acc']:.4f} {r['jerk']:.4f}")
        if len(rss) == 2:
            print(f"{label}: peak memory 1 000 000 / 100 000 moves {rss[1_000_000] / rss[100_000]:.3f} "
                  f"(target <= 1.5, and <= 300 MB)")


def optimum_bound(optimum, nodes):
    r = subprocess.run([sys.executable, optimum, "--no-ipopt", nodes], capture_output=True, text=True)
    for part in r.stdout.split(","):
        if "acceleration-only bound" in part:
            return float(part.split()[-2])
    return float("nan")


def show(label, name, f):
    if "error" in f:
        print(f"{label:9s} {name:9s} FAILED: {f['error']}")
        return
    fd = f["fd"]
    print(f"{label:9s} {name:9s} {f['duration_s']:10.4f} {f['duration_s'] / f['bound_s']:7.4f} "
          f"{(f['dev_mm'] - TOL_MM) * 1e3:+8.3f} {fd[0]:6.4f} {fd[1]:6.4f} {fd[2]:6.4f} "
          f"{f['prep_ms']:9.0f} {f['plan_ms']:8.0f} {f['rt']:8.1f} {f['call_max_ms']:8.1f} "
          f"{f['exact']:5d} {f['forced']:6d} {f['merged']:7d}/{f['moves']}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary", help="interpd binary (release build)")
    ap.add_argument("--baseline", help="another interpd binary, measured in the same run")
    ap.add_argument("--quick", action="store_true", help="a tenth of the moves")
    ap.add_argument("--only", nargs="*", help="program names to run")
    ap.add_argument("--repeat", type=int, default=3, help="runs per program of the memory section (best taken)")
    ap.add_argument("--machine", help="machine file for interpd plan (default: config/machines/xyz.toml, "
                    "the built-in default)")
    args = ap.parse_args()
    if args.machine:
        global MACHINE
        MACHINE = os.path.abspath(args.machine)
        MACHINE_ARGS.extend(["--machine", MACHINE])
    fd_limits = load_module("benches/robustness/fd_limits.py", "fd_limits")
    optimum = os.path.join(ROOT, "benches", "reference", "optimum.py")
    bins = [("this", args.binary)] + ([("baseline", args.baseline)] if args.baseline else [])
    with tempfile.TemporaryDirectory() as tmp:
        programs = generate(tmp, args.quick)
        print("binary    program    motion_s  /bound  dev-tol_um  vel    acc    jerk    prep_ms  plan_ms  x_real  "
              "call_ms exact forced merged/moves")
        results = {}
        for name, path in programs.items():
            if args.only and name not in args.only:
                continue
            for label, b in bins:
                f = run(b, name, path, tmp, fd_limits, optimum)
                results[(label, name)] = f
                show(label, name, f)
        for label, _ in bins:
            a, b = results.get((label, "dense2")), results.get((label, "dense20"))
            if a and b and "error" not in a and "error" not in b:
                print(f"{label}: dense2 / dense20 motion time {a['duration_s'] / b['duration_s']:.4f} (target <= 1.05)")
        if not args.quick and (not args.only or "memory" in args.only):
            memory_section(bins, tmp, args.repeat)
        if args.baseline:
            for name in programs:
                a, b = results.get(("this", name)), results.get(("baseline", name))
                if a and b and "error" not in a and "error" not in b:
                    print(f"{name}: motion time this / baseline {a['duration_s'] / b['duration_s']:.4f}, "
                          f"smoothing + planning {a['work_s'] / b['work_s']:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
