#!/usr/bin/env python3
"""Generates the example programs under examples/ (standard library only).

    scripts/gen-examples.py            # writes every example
    scripts/gen-examples.py --dense N  # only the dense CAM-like program with N segments

Noisy CAM programs for the smoothing and planning benchmark (written to FILE, not examples/):

    scripts/gen-examples.py --cam-dense STEP_MM MOVES FILE   # the dense curve at any step
    scripts/gen-examples.py --trochoid MOVES FILE [STEP_MM]  # a trochoidal pocket path

Both start with G64 P0.01, round the coordinates to 4 decimals (0.1 µm, as CAM post-processors
do) and repeat the previous point (a zero-length move) every 200 to 400 lines.

The shapes are the test geometries of the sources:
  circle_r10.ngc        Kopp et al. 2019, §2.4: circle R = 10 mm from the origin, clockwise
  corner_90.ngc         Haas 2012: 90° corner with 100 mm legs
  line_arc_line.ngc     Haas 2012 "GKG": line, tangent 90° arc, line (G¹, curvature jumps)
  staircase.ngc         Haas 2012 "Treppe": 5 × 90° turns, 160 mm
  zigzag.ngc            Haas 2012: zigzag
  two_arcs.ngc          Haas 2012: two arcs with a finite curvature jump
  ellipse_g06.ngc       Huan: ellipse from 20 support points as G06 with tangents
  ellipse_natural.ngc   the same points as a natural spline (G06 without tangents)
  five_axis_table.csv   Kopp et al. 2019, §4: 5-axis path table (x, y, z, A, B), ~292 rows, 529.5 mm,
                        corner at s ≈ 408.1 mm
  dense_freeform.ngc    CAM output: >= 100 000 short G1 segments on a smooth free-form curve
"""
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "examples")


def write(name, text):
    path = os.path.join(OUT, name)
    with open(path, "w") as f:
        f.write(text)
    print(f"wrote {os.path.relpath(path)} ({len(text)} bytes)")


def num(v, digits=6):
    s = f"{v:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def simple_shapes():
    write("circle_r10.ngc", """(Kopp et al. 2019, §2.4: circle R = 10 mm from the origin, clockwise: x = R cos[s/R] - R, y = -R sin[s/R])
(the feed is high so that the axis limits bind)
G21 G90 G17
G1 F30000
G2 X0 Y0 I-10 J0
M30
""")
    write("corner_90.ngc", """(Haas 2012: 90° corner with 100 mm legs)
G21 G90 G17
G1 X100 Y0 F12000
X100 Y100
M30
""")
    write("line_arc_line.ngc", """(Haas 2012 "GKG": line - tangent arc - line; G1 but not G2 at both arc ends)
G21 G90 G17
G1 X50 Y0 F12000
G3 X70 Y20 I0 J20
G1 X70 Y70
M30
""")
    write("staircase.ngc", """(Haas 2012 "Treppe": staircase with 5 x 90° turns, 160 mm)
G21 G90 G17
G1 X40 Y0 F12000
X40 Y20
X60 Y20
X60 Y40
X80 Y40
X80 Y80
M30
""")
    write("zigzag.ngc", """(Haas 2012: zigzag, 60° corners)
G21 G90 G17
G1 F12000
""" + "".join(f"X{10 * (i + 1)} Y{0 if i % 2 else 17.320508}\n" for i in range(8)) + "M30\n")
    write("two_arcs.ngc", """(Haas 2012: two arcs with a finite curvature jump, tangent at the joint)
G21 G90 G17
G1 F12000
G3 X20 Y20 I0 J20
G2 X30 Y30 I10 J0
M30
""")


def ellipse():
    a, b, n = 40.0, 20.0, 20
    dth = 2 * math.pi / n
    pts = [(a * math.cos(i * dth), b * math.sin(i * dth)) for i in range(n + 1)]
    tan = [(-a * math.sin(i * dth) * dth, b * math.cos(i * dth) * dth) for i in range(n + 1)]
    lines = ["(Huan: ellipse a = 40, b = 20 mm from 20 support points, G06 with tangents)",
             "(tangents per unit span parameter: dP/dtheta * 2pi/20)",
             "G21 G90 G17", f"G0 X{num(pts[0][0])} Y{num(pts[0][1])}", "F6000",
             f"N10 G06 I{num(tan[0][0])} J{num(tan[0][1])} K0"]
    for (x, y), (tx, ty) in zip(pts[1:], tan[1:]):
        lines.append(f"X{num(x)} Y{num(y)} Z0 P{num(tx)} Q{num(ty)} R0;")
    lines += ["CR", "M30", ""]
    write("ellipse_g06.ngc", "\n".join(lines))
    lines = ["(the ellipse's 20 support points as a natural cubic spline: G06 without tangents)",
             "(tangents from Huan, eq. 3)",
             "G21 G90 G17", f"G0 X{num(pts[0][0])} Y{num(pts[0][1])}", "F6000", "N10 G06"]
    for (x, y) in pts[1:]:
        lines.append(f"X{num(x)} Y{num(y)} Z0;")
    lines += ["", "M30", ""]
    write("ellipse_natural.ngc", "\n".join(lines))


# --- 5-axis table ---------------------------------------------------------------------------

def derivs_wrt_s(p, p1, p2, p3):
    """Chain rule from a parameter u to arc length s over the first three (linear) axes."""
    lin = range(3)
    sig = math.sqrt(sum(p1[k] ** 2 for k in lin))
    p1p2 = sum(p1[k] * p2[k] for k in lin)
    p2p2 = sum(p2[k] ** 2 for k in lin)
    p1p3 = sum(p1[k] * p3[k] for k in lin)
    su = p1p2 / sig
    suu = (p2p2 + p1p3) / sig - su * su / sig
    u1 = 1 / sig
    u2 = -su * u1 ** 3
    u3 = -suu * u1 ** 4 + 3 * su * su * u1 ** 5
    d1 = [p1[k] * u1 for k in range(5)]
    d2 = [p2[k] * u1 * u1 + p1[k] * u2 for k in range(5)]
    d3 = [p3[k] * u1 ** 3 + 3 * p2[k] * u1 * u2 + p1[k] * u3 for k in range(5)]
    return sig, d1, d2, d3


def scaled(f, k):
    """Scales the linear axes (first three) of a curve function by k; angles stay."""
    def g(u):
        out = f(u)
        return [[v * k if i < 3 else v for i, v in enumerate(row)] for row in out]
    return g


def approach(u):
    """u in [0,1]: a long sweeping approach in 3-D with slowly tilting tool (A, B in degrees)."""
    # position and derivatives w.r.t. u, analytic
    x = 300 * u + 25 * math.sin(2 * math.pi * u)
    y = 60 * math.sin(math.pi * u) ** 2
    z = 80 - 60 * u + 10 * math.sin(3 * math.pi * u)
    A = 20 * math.sin(math.pi * u)
    B = -15 * u
    x1 = 300 + 50 * math.pi * math.cos(2 * math.pi * u)
    y1 = 60 * math.pi * math.sin(2 * math.pi * u)
    z1 = -60 + 30 * math.pi * math.cos(3 * math.pi * u)
    A1 = 20 * math.pi * math.cos(math.pi * u)
    B1 = -15
    x2 = -100 * math.pi ** 2 * math.sin(2 * math.pi * u)
    y2 = 120 * math.pi ** 2 * math.cos(2 * math.pi * u)
    z2 = -90 * math.pi ** 2 * math.sin(3 * math.pi * u)
    A2 = -20 * math.pi ** 2 * math.sin(math.pi * u)
    x3 = -200 * math.pi ** 3 * math.cos(2 * math.pi * u)
    y3 = -240 * math.pi ** 3 * math.sin(2 * math.pi * u)
    z3 = -270 * math.pi ** 3 * math.cos(3 * math.pi * u)
    A3 = -20 * math.pi ** 3 * math.cos(math.pi * u)
    return [x, y, z, A, B], [x1, y1, z1, A1, B1], [x2, y2, z2, A2, 0.0], [x3, y3, z3, A3, 0.0]


def machining(u, start):
    """u in [0,1]: machining with tight turns and fast orientation changes after the corner."""
    x0, y0, z0, a0, b0 = start
    w = 2 * math.pi * 3.5
    r = 6.0
    x = x0 - 110 * u + r * math.sin(w * u)
    y = y0 + 8 * (1 - math.cos(w * u)) + 25 * u * u
    z = z0 - 2 * u
    A = a0 + 25 * math.sin(w * u)
    B = b0 + 40 * u - 12 * math.sin(0.5 * w * u)
    x1 = -110 + r * w * math.cos(w * u)
    y1 = 8 * w * math.sin(w * u) + 50 * u
    z1 = -2.0
    A1 = 25 * w * math.cos(w * u)
    B1 = 40 - 6 * w * math.cos(0.5 * w * u)
    x2 = -r * w * w * math.sin(w * u)
    y2 = 8 * w * w * math.cos(w * u) + 50
    A2 = -25 * w * w * math.sin(w * u)
    B2 = 3 * w * w * math.sin(0.5 * w * u)
    x3 = -r * w ** 3 * math.cos(w * u)
    y3 = -8 * w ** 3 * math.sin(w * u)
    A3 = -25 * w ** 3 * math.cos(w * u)
    B3 = 1.5 * w ** 3 * math.cos(0.5 * w * u)
    return [x, y, z, A, B], [x1, y1, z1, A1, B1], [x2, y2, 0.0, A2, B2], [x3, y3, 0.0, A3, B3]


def arc_length(f, u0, u1, n=2000):
    """Simpson on |P'(u)| over the linear axes."""
    h = (u1 - u0) / n
    tot = 0.0
    for i in range(n + 1):
        u = u0 + i * h
        _, p1, _, _ = f(u)
        sp = math.sqrt(p1[0] ** 2 + p1[1] ** 2 + p1[2] ** 2)
        w = 1 if i in (0, n) else (4 if i % 2 else 2)
        tot += w * sp
    return tot * h / 3


def sample_piece(f, npts, s_offset, total_len):
    """npts rows with spacing finer where the curvature is high (non-constant, Kopp et al. 2019, §2.2)."""
    # weight density by 1 + curvature (over linear axes) and orientation rate
    fine = 4000
    us = [i / fine for i in range(fine + 1)]
    dens = []
    for u in us:
        p, p1, p2, p3 = f(u)
        sig, d1, d2, d3 = derivs_wrt_s(p, p1, p2, p3)
        curv = math.sqrt(sum(d2[k] ** 2 for k in range(3)))
        rot = math.sqrt(d1[3] ** 2 + d1[4] ** 2) * math.pi / 180
        dens.append(sig * (1 + 20 * curv + 5 * rot))
    cum = [0.0]
    for i in range(fine):
        cum.append(cum[-1] + 0.5 * (dens[i] + dens[i + 1]) / fine)
    rows = []
    s_prev_u = 0.0
    s_acc = 0.0
    for j in range(npts):
        target = cum[-1] * j / (npts - 1)
        k = min(range(fine + 1), key=lambda i: abs(cum[i] - target)) if j not in (0, npts - 1) else (0 if j == 0 else fine)
        u = us[k]
        s_acc += arc_length(f, s_prev_u, u, 200) if u > s_prev_u else 0.0
        s_prev_u = u
        p, p1, p2, p3 = f(u)
        _, d1, d2, d3 = derivs_wrt_s(p, p1, p2, p3)
        rows.append((s_offset + s_acc * total_len[1], [p[k] for k in range(5)], d1, d2, d3))
    return rows, s_acc


def five_axis():
    # Section structure after Kopp et al. 2019, Table 1: 44+25+48 points up to the corner, 21+32+21+53+48
    # after it (292 rows), 529.5 mm in all with the corner at 408.1 mm.
    ka = 408.1 / arc_length(approach, 0, 1, 4000)
    app = scaled(approach, ka)
    la = arc_length(app, 0, 1, 4000)
    rows_a, _ = sample_piece(app, 117, 0.0, (None, 1.0))
    end = rows_a[-1][1]
    m0 = lambda u: machining(u, [0.0] * 5)
    km = 121.4 / arc_length(m0, 0, 1, 4000)
    m = lambda u: [[v + (end[i] if j == 0 else 0.0) for i, v in enumerate(row)] for j, row in enumerate(scaled(m0, km)(u))]
    lm = arc_length(m, 0, 1, 4000)
    rows_m, _ = sample_piece(m, 175, rows_a[-1][0], (None, 1.0))
    rows = rows_a + rows_m
    out = ["# Kopp et al. 2019, §4 style 5-axis path table: x y z (mm), A B (deg); s is the arc length over",
           "# x y z; approach to s = %.1f mm, a corner there (two rows at the same s), then machining" % la,
           "# with tight turns and fast orientation changes; %d rows, %.1f mm." % (len(rows), la + lm),
           "# Generated by scripts/gen-examples.py; derivatives are analytic (chain rule to arc length).",
           "s," + ",".join(f"{a},{a}',{a}'',{a}'''" for a in "XYZAB")]
    for s, p, d1, d2, d3 in rows:
        vals = [s]
        for k in range(5):
            vals += [p[k], d1[k], d2[k], d3[k]]
        out.append(",".join(repr(float(v)) for v in vals))
    write("five_axis_table.csv", "\n".join(out) + "\n")


def dense(n_segments):
    """A smooth free-form curve (Lissajous-like with a slow z wave) as CAM output: short G1 moves
    of nearly equal length, coordinates rounded to 4 decimals."""
    def curve(t):
        x = 120 * math.sin(3 * t) + 40 * math.sin(7 * t + 0.5)
        y = 90 * math.sin(2 * t + 0.3) + 30 * math.cos(5 * t)
        z = 5 * math.sin(t) + 2 * math.sin(11 * t)
        return x, y, z
    # arc-length reparameterisation on a fine grid, then equal chords
    fine = n_segments * 8
    T = 2 * math.pi
    pts = [curve(T * i / fine) for i in range(fine + 1)]
    cum = [0.0]
    for i in range(fine):
        cum.append(cum[-1] + math.dist(pts[i], pts[i + 1]))
    total = cum[-1]
    out = ["(dense CAM-like program: %d G1 segments of ~%.3f mm on a smooth free-form curve)" % (n_segments, total / n_segments),
           "(generated by scripts/gen-examples.py --dense %d; chord points rounded to 4 decimals)" % n_segments,
           "G21 G90 G17", "G0 X%.4f Y%.4f Z%.4f" % pts[0], "G1 F6000"]
    j = 0
    for i in range(1, n_segments + 1):
        target = total * i / n_segments
        while j < fine and cum[j + 1] < target:
            j += 1
        f = 0 if cum[j + 1] == cum[j] else (target - cum[j]) / (cum[j + 1] - cum[j])
        p = [pts[j][k] + f * (pts[j + 1][k] - pts[j][k]) for k in range(3)]
        out.append("X%.4f Y%.4f Z%.4f" % tuple(p))
    out.append("M30")
    write("dense_freeform.ngc", "\n".join(out) + "\n")


# --- noisy CAM programs --------------------------------------------------------------------

DUP_MIN, DUP_MAX = 200, 400   # a zero-length move every DUP_MIN..DUP_MAX lines
CAM_TOL_MM = 0.01             # the G64 P of the CAM programs


class CamWriter:
    """G1 lines rounded to 4 decimals, with a duplicate (zero-length) move every few hundred
    lines at pseudo-random places (a fixed linear congruential sequence, so the output is
    reproducible without the random module's version dependence)."""

    def __init__(self, f, moves):
        self.f, self.moves, self.written = f, moves, 0
        self.lcg = 12345
        self.next_dup = self._gap()
        self.last = None

    def _gap(self):
        self.lcg = (1103515245 * self.lcg + 12345) % 2 ** 31
        return DUP_MIN + self.lcg % (DUP_MAX - DUP_MIN + 1)

    def full(self):
        return self.written >= self.moves

    def move(self, x, y, z):
        if self.full():
            return
        line = "X%.4f Y%.4f Z%.4f\n" % (x, y, z)
        self.f.write(line)
        self.written += 1
        self.next_dup -= 1
        if self.next_dup <= 0 and not self.full():
            self.f.write(line)          # the same point again: a zero-length move
            self.written += 1
            self.next_dup = self._gap()


def dense_curve(t):
    """The dense example's curve (see dense())."""
    x = 120 * math.sin(3 * t) + 40 * math.sin(7 * t + 0.5)
    y = 90 * math.sin(2 * t + 0.3) + 30 * math.cos(5 * t)
    z = 5 * math.sin(t) + 2 * math.sin(11 * t)
    return x, y, z


# Parameter steps over the dense curve's period: ~0.5 µm of path each, fine enough that the
# chord of a step deviates from the curve by far less than the 4-decimal rounding.
DENSE_FINE = 4_000_000


def cam_dense(step_mm, moves, path):
    """The dense example's curve from its start, `moves` G1 moves of `step_mm` of arc length
    (the same curve at any step: 20 µm and 2 µm compare directly over the same length)."""
    T = 2 * math.pi
    with open(path, "w") as f:
        f.write("(the dense example's curve as CAM output: %d G1 moves of %.4f mm, 4 decimals, duplicates)\n"
                % (moves, step_mm))
        f.write("(generated by scripts/gen-examples.py --cam-dense %g %d)\n" % (step_mm, moves))
        p0 = dense_curve(0.0)
        f.write("G21 G90 G17\nG0 X%.4f Y%.4f Z%.4f\nG64 P%g\nG1 F6000\n" % (p0 + (CAM_TOL_MM,)))
        w = CamWriter(f, moves)
        i, prev, s_prev, s, target = 0, p0, 0.0, 0.0, step_mm
        while not w.full() and i < DENSE_FINE:
            i += 1
            p = dense_curve(T * i / DENSE_FINE)
            s_prev, s = s, s + math.dist(prev, p)
            while s >= target and not w.full():
                f_ = (target - s_prev) / (s - s_prev)
                w.move(*(prev[k] + f_ * (p[k] - prev[k]) for k in range(3)))
                target += step_mm
            prev = p
        f.write("M30\n")
    print(f"wrote {path} ({w.written} moves, {target - step_mm:.1f} mm)")


def trochoid(moves, path, step=0.023):
    """A trochoidal pocket path as CAM output: loops of radius 2 mm advancing 0.4 mm per loop
    along rows 30 mm long, 3 mm apart, joined by half circles of the loop centre; moves of
    `step` mm of arc length (23 µm by default), F3000, at z = -1."""
    r, pitch, row, gap = 2.0, 0.4, 30.0, 3.0
    omega = 2 * math.pi / pitch          # loop angle per mm of centre travel

    def centre(u):
        """Centre of the loop after u mm of centre travel: rows along ±x joined by half circles."""
        turn = math.pi * gap / 2
        period = row + turn
        k, v = divmod(u, period)
        k = int(k)
        y0 = k * gap
        x_start, direction = (0.0, 1.0) if k % 2 == 0 else (row, -1.0)
        if v <= row:
            return x_start + direction * v, y0
        a = (v - row) / (gap / 2)         # angle along the half circle
        cx = x_start + direction * row
        return cx + direction * (gap / 2) * math.sin(a), y0 + (gap / 2) * (1 - math.cos(a))

    def tool(u):
        cx, cy = centre(u)
        a = omega * u
        return cx + r * math.cos(a), cy + r * math.sin(a), -1.0

    with open(path, "w") as f:
        f.write("(trochoidal pocket path as CAM output: %d G1 moves of ~%.3f mm, 4 decimals, duplicates)\n"
                % (moves, step))
        f.write("(generated by scripts/gen-examples.py --trochoid %d %s %g)\n" % (moves, os.path.basename(path), step))
        p0 = tool(0.0)
        f.write("G21 G90 G17\nG0 X%.4f Y%.4f Z5\nG1 Z%.4f F1000\nG64 P%g\nF3000\n" % (p0[0], p0[1], p0[2], CAM_TOL_MM))
        w = CamWriter(f, moves)
        # The tool moves ~2πr/pitch times faster than the centre: centre steps of about
        # step / (that ratio), refined so each move is ~step long.
        du_fine = step / (2 * math.pi * r / pitch) / 16
        u, prev, s = 0.0, p0, 0.0
        while not w.full():
            u += du_fine
            p = tool(u)
            s += math.dist(prev, p)
            prev = p
            if s >= step:
                w.move(*p)
                s -= step
        f.write("M30\n")
    print(f"wrote {path} ({w.written} moves)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--dense":
        dense(int(sys.argv[2]))
    elif len(sys.argv) == 5 and sys.argv[1] == "--cam-dense":
        cam_dense(float(sys.argv[2]), int(sys.argv[3]), sys.argv[4])
    elif len(sys.argv) in (4, 5) and sys.argv[1] == "--trochoid":
        trochoid(int(sys.argv[2]), sys.argv[3], *(float(a) for a in sys.argv[4:]))
    else:
        simple_shapes()
        ellipse()
        five_axis()
        dense(100_000)
