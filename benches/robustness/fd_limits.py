#!/usr/bin/env python3
"""Largest axis velocity, acceleration and jerk of a planned motion as shares of the machine's
configured limits, by finite differences of the positions that `interpd plan --out` samples
(the same check as tests/tests/plan_limits.rs, printed as numbers).

    target/release/interpd plan PROGRAM --machine M.toml --period-ms 0.25 --out /tmp/p.csv
    python3 benches/robustness/fd_limits.py /tmp/p.csv M.toml
"""
import csv
import re
import sys


def limits(machine):
    text = open(machine).read()
    axes = re.findall(r"\[\[axis\]\](.*?)(?=\[\[axis\]\]|\Z)", text, re.S)
    get = lambda body, key: float(re.search(key + r"\s*=\s*([0-9.eE+-]+)", body).group(1))
    return [(get(a, "max_vel"), get(a, "max_acc"), get(a, "max_jerk")) for a in axes]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = list(csv.reader(open(sys.argv[1])))
    header, data = rows[0], [[float(x) for x in r] for r in rows[1:]]
    dt = data[1][0] - data[0][0]
    first_axis = header.index("j") + 1
    worst = [0.0, 0.0, 0.0]
    for k, lim in enumerate(limits(sys.argv[2])):
        x = [r[first_axis + k] for r in data]
        for order in range(3):
            x = [(b - a) / dt for a, b in zip(x, x[1:])]
            worst[order] = max(worst[order], max(abs(d) for d in x) / lim[order])
    print("vel %.4f acc %.4f jerk %.4f" % tuple(worst))


if __name__ == "__main__":
    main()
