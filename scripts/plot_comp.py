#!/usr/bin/env python3
"""Draws a program's contour and its cutter-compensated tool path as an SVG.

    scripts/plot_comp.py [PROGRAM] [OUT.svg] [--interpd BIN]

Plans PROGRAM (default examples/ellipse_g06_comp.ngc) twice with `interpd plan --out`: as
written (the tool path) and with its G40/G41/G42 words removed (the programmed contour), and
draws both in the XY plane. Default output docs/cutter_comp.svg. Standard library only.
"""

import csv
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def plan_xy(interpd, program_text, name):
    with tempfile.TemporaryDirectory() as tmp:
        prog = os.path.join(tmp, name)
        out = os.path.join(tmp, "plan.csv")
        with open(prog, "w") as f:
            f.write(program_text)
        subprocess.run([interpd, "plan", prog, "--out", out], check=True, stdout=subprocess.DEVNULL)
        with open(out) as f:
            rows = list(csv.DictReader(f))
    return [(float(r["X"]), float(r["Y"])) for r in rows]


def first_stop(points, text):
    """Index of the sample nearest to the target of the program's first G0 (the approach
    point), so the rapid from the machine origin is left out."""
    m = re.search(r"G0\s*X\s*([-+.\d]+)\s*Y\s*([-+.\d]+)", text, flags=re.I)
    if not m:
        return 0
    x, y = float(m.group(1)), float(m.group(2))
    return min(range(len(points)), key=lambda i: (points[i][0] - x) ** 2 + (points[i][1] - y) ** 2)


def strip_comp(text):
    """The program without cutter compensation: G40/G41/G42 (and their D words) removed."""
    lines = []
    for line in text.splitlines():
        line = re.sub(r"\bG4[12](\.1)?\s*D\s*[-+.\d]+", "", line, flags=re.I)
        line = re.sub(r"\bG40\b", "", line, flags=re.I)
        lines.append(line)
    return "\n".join(lines) + "\n"


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    interpd = os.path.join(ROOT, "target/release/interpd")
    if "--interpd" in sys.argv:
        interpd = sys.argv[sys.argv.index("--interpd") + 1]
        args = [a for a in args if a != interpd]
    program = args[0] if args else os.path.join(ROOT, "examples/ellipse_g06_comp.ngc")
    out = args[1] if len(args) > 1 else os.path.join(ROOT, "docs/cutter_comp.svg")
    text = open(program).read()
    tool = plan_xy(interpd, text, "tool.ngc")
    contour = plan_xy(interpd, strip_comp(text), "contour.ngc")
    # The rapid from the machine origin to the program's first point is not part of the figure.
    tool, contour = tool[first_stop(tool, text) :], contour[first_stop(contour, text) :]
    pts = tool + contour
    x0, x1 = min(p[0] for p in pts) - 3, max(p[0] for p in pts) + 3
    y0, y1 = min(p[1] for p in pts) - 3, max(p[1] for p in pts) + 3
    scale = 8.0  # px per mm
    w, h = (x1 - x0) * scale, (y1 - y0) * scale

    def path(points):
        return " ".join(f"{(x - x0) * scale:.2f},{(y1 - y) * scale:.2f}" for x, y in points[::2] + points[-1:])

    svg = f"""<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h + 40:.0f}" viewBox="0 0 {w:.0f} {h + 40:.0f}">
<rect width="100%" height="100%" fill="white"/>
<polyline points="{path(contour)}" fill="none" stroke="#333" stroke-width="1.5"/>
<polyline points="{path(tool)}" fill="none" stroke="#d04020" stroke-width="1.5" stroke-dasharray="6,3"/>
<text x="10" y="{h + 18:.0f}" font-family="sans-serif" font-size="13" fill="#333">programmed contour ({os.path.basename(program)}, G06, 20 support points)</text>
<text x="10" y="{h + 34:.0f}" font-family="sans-serif" font-size="13" fill="#d04020">tool centre path (cutter radius compensation, planned motion sampled every 4 ms)</text>
</svg>
"""
    with open(out, "w") as f:
        f.write(svg)
    print(f"{out}: {len(tool)} tool path samples, {len(contour)} contour samples")


if __name__ == "__main__":
    main()
