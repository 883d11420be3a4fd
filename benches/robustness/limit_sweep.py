#!/usr/bin/env python3
"""Motion time against small changes of a machine's limits: each machine's acceleration or
jerk limits scaled by 1 + k * 0.13 % (k = -4 … 4), `interpd plan --json` per step. A planner
whose branches meet by luck jumps here; the figure is the worst slow-down from one step to a
higher limit.

    python3 benches/robustness/limit_sweep.py target/release/interpd PROGRAM MACHINE.toml ...
"""
import json
import pathlib
import re
import subprocess
import sys
import tempfile


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    binary, program, machines = sys.argv[1], sys.argv[2], sys.argv[3:]
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="interpd-sweep-"))
    for machine in machines:
        base = open(machine).read()
        for key in ("max_jerk", "max_acc"):
            times = []
            for k in range(-4, 5):
                f = 1 + k * 1.3e-3
                text = re.sub(r"(%s\s*=\s*)([0-9.]+)" % key, lambda m: m.group(1) + repr(float(m.group(2)) * f), base)
                path = tmp / f"{pathlib.Path(machine).stem}_{key}_{k}.toml"
                path.write_text(text)
                r = subprocess.run([binary, "plan", program, "--machine", str(path), "--json"], capture_output=True, text=True)
                if r.returncode != 0:
                    sys.exit(f"{machine} {key} x{f}: {r.stderr.strip()}")
                times.append(json.loads(r.stdout)["duration_s"])
            worst = max((b - a) / a for a, b in zip(times, times[1:]))
            spread = (max(times) - min(times)) / min(times)
            print("%-28s %-9s worst step %+.3f%% spread %.3f%%" % (pathlib.Path(machine).name, key, 100 * worst, 100 * spread))


if __name__ == "__main__":
    main()
