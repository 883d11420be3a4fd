#!/usr/bin/python3
"""Smoothing + planning speed of Haas's two methods on the CAM benchmark programs: the
weighted B-spline (`[prep] method = "bspline"`, Haas 2012 §4.6) against the Hermite pieces
(§4.5), measured in the same run, interleaved, so that both see the same load.

    cargo build --release -p interpd
    /usr/bin/python3 benches/cam/method_speed.py target/release/interpd [--repeat 5] [--quick]
        [--only dense20 troch23] [--instructions] [--machine FILE]

Per program (cam_bench.py's PROGRAMS, generated the same way) and method, `interpd plan
--json` runs `--repeat` times, the methods alternating run by run. Printed per method: the
motion time, x real time (motion time / (smoothing + planning wall time), the figure the
issue asks for) as median, min and max of the runs, the median CPU time of the whole command
(user + system, reading the program included), the B-spline windows and the spans that fell
back to Hermite pieces, the exact-stop fallbacks. Then the B-spline / Hermite ratio of the
median x real time and of the median CPU time.

`--instructions` also runs each program once per method under valgrind's cachegrind (no cache
simulation) and prints the instructions executed: a count that does not depend on the load of
a shared machine, unlike the times (`interpd plan` applies no wall-clock limit to the window
solves unless told to, so valgrind's 50 x slowdown changes nothing planned). They are slow, so
use --quick or --only.

Compare instruction counts only within one build. With the release profile's 16 codegen units,
the code of clarabel's generic solver is compiled into interpd-motion (monomorphised there) and
its inlining follows how that crate's code falls into units, so a change anywhere in
interpd-motion can move both methods' counts by about 3 % (measured on troch23: 6,147 M and
6,344 M instructions for the Hermite method in two builds that differ only in
motion/src/prep/bspline/). A build with one codegen unit for that crate does not move
(6,153,379,033 and 6,153,381,866 for the same two sources):

    cargo build --release -p interpd --config 'profile.release.package.interpd-motion.codegen-units=1'
"""
import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cam_bench  # noqa: E402  (PROGRAMS and their generation)

METHODS = ("hermite", "bspline")


def machine_file(tmp, base, method):
    """`base` with `[prep] method` set; refuses a base that already has a [prep] table, since
    a second one would be a TOML error rather than an override."""
    text = open(base).read()
    if re.search(r"^\[prep\]", text, re.M):
        sys.exit(f"{base} already has a [prep] table; give a machine file without one")
    path = os.path.join(tmp, f"machine-{method}.toml")
    with open(path, "w") as f:
        f.write(text + f'\n[prep]\nmethod = "{method}"\n')
    return path


def run_once(binary, program, machine):
    """One `interpd plan --json`: the figures of its JSON."""
    t0 = time.time()
    r = subprocess.run([binary, "plan", program, "--json", "--machine", machine], capture_output=True, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        return {"error": (r.stdout + r.stderr).strip().splitlines()[-1:]}
    j = json.loads(r.stdout)
    work_s = (j["prep"]["wall_ms"] + j["plan_ms"]) * 1e-3
    s = j["prep"]["stats"]
    return {"duration_s": j["duration_s"], "rt": j["duration_s"] / work_s, "work_s": work_s,
            "wall_s": wall, "windows": s.get("bspline_windows", 0), "to_hermite": s.get("bspline_to_hermite", 0),
            "exact": s["fallback_exact"], "forced": j.get("forced_stops", 0)}


def cpu_time(binary, program, machine):
    """One run and its CPU time (user + system, s), from the children's resource usage."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = run_once(binary, program, machine)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if "error" not in r:
        r["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return r


def instructions(binary, program, machine, tmp):
    out = os.path.join(tmp, "cachegrind.out")
    r = subprocess.run(["valgrind", "--tool=cachegrind", "--cache-sim=no", f"--cachegrind-out-file={out}",
                        binary, "plan", program, "--json", "--machine", machine],
                       capture_output=True, text=True)
    if os.path.exists(out):
        os.remove(out)
    if r.returncode != 0:
        sys.exit(f"interpd plan under valgrind failed: {r.stderr.strip().splitlines()[-1:]}")
    m = re.search(r"I\s+refs:\s+([\d,]+)", r.stderr)
    return int(m.group(1).replace(",", "")) if m else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="a tenth of the moves")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--instructions", action="store_true", help="also count instructions under valgrind")
    ap.add_argument("--machine", default=os.path.join(cam_bench.ROOT, "config", "machines", "xyz.toml"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        machines = {m: machine_file(tmp, args.machine, m) for m in METHODS}
        programs = cam_bench.generate(tmp, args.quick)
        print(f"{'program':<9} {'method':<8} {'motion_s':>9} {'x_rt med':>8} {'min':>6} {'max':>6} {'cpu_s med':>9} "
              f"{'windows':>7} {'to_herm':>7} {'exact':>5} {'forced':>6}" + ("    instructions" if args.instructions else ""))
        ratios = []
        for name, path in programs.items():
            if args.only and name not in args.only:
                continue
            runs = {m: [] for m in METHODS}
            for _ in range(args.repeat):
                for m in METHODS:
                    runs[m].append(cpu_time(args.binary, path, machines[m]))
            med = {}
            for m in METHODS:
                bad = [r for r in runs[m] if "error" in r]
                if bad:
                    print(f"{name:<9} {m:<8} ERROR {bad[0]['error']}")
                    continue
                rt = [r["rt"] for r in runs[m]]
                cpu = statistics.median(r["cpu_s"] for r in runs[m])
                last = runs[m][-1]
                med[m] = (statistics.median(rt), cpu)
                ins = ""
                if args.instructions:
                    n = instructions(args.binary, path, machines[m], tmp)
                    med[m] = med[m] + (n,)
                    ins = f" {n:>15,}" if n else "               ?"
                print(f"{name:<9} {m:<8} {last['duration_s']:>9.4f} {med[m][0]:>8.1f} {min(rt):>6.1f} {max(rt):>6.1f} "
                      f"{cpu:>9.3f} {last['windows']:>7} {last['to_hermite']:>7} {last['exact']:>5} {last['forced']:>6}"
                      + ins)
            if len(med) == 2:
                h, b = med["hermite"], med["bspline"]
                line = f"{name}: B-spline / Hermite x real time {b[0] / h[0]:.3f}, CPU time {b[1] / h[1]:.3f}"
                if args.instructions and h[2] and b[2]:
                    line += f", instructions {b[2] / h[2]:.3f}"
                ratios.append(line)
        print()
        for line in ratios:
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
