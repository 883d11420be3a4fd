#!/usr/bin/env python3
"""The hard CAM program family: seeded random programs whose parameters reach the geometry
that breaks naive smoothing (cusps, tangent reversals, loops below the tolerance, outliers),
each with the unrounded curve it was sampled from and an acceleration-only lower bound of its
motion time computed on that curve, independently of interpd's planner.

    python3 benches/cam/family.py write DIR [--seed S] [--count N] [--step-mm 0.002|0.02]
    python3 benches/cam/family.py bound PROGRAM.json   # the bound of one written program

Families (`KINDS`):

  cusp      trochoid whose loops roll along a spiral with the loop radius swept from 0.5 x to
            2 x the critical one (where the loop speed equals the speed along the spiral): the
            path passes through cusps, near-cusps and loops of a few um
  subtol    a curve with bursts of loops smaller than the tolerance (radius 0.2 - 0.9 x tol)
  raster    zig-zag rows over a curved surface joined by U-turns of 0.02 - 0.5 mm stepover
            (sub-millimetre reversals at the stepover)
  plunge    XY moves with plunge-and-retract reversals along a slanted line in Z: a true
            reversal (cusp) at each bottom
  outlier   a smooth curve with single points 20 - 200 um off it
  helix     helical ramps, radius 2 - 10 mm, 0.2 - 1 mm per turn
  wander    a random walk of micro-segments whose direction turns by ~17 deg per segment
            (no smooth curve behind it: no bound)

Every program: G21 G90 G17, a G0 to the start, G64 P0.01, F (random 3000 - 12000 mm/min),
moves of ~`step` mm of arc length, coordinates rounded to 4 decimals, the previous point
repeated (a zero-length move) every 97th line. `write` puts PROGRAM.ngc and PROGRAM.json
(kind, parameters, the number of true cusps, the feed, the bound) side by side.

The bound (`acc_only_bound`): the classical time-optimal path parameterisation without jerk
limit (forward and backward passes in b = v^2, per-axis velocity and acceleration limits and
the feed) on the unrounded curve resampled at a fine, uniform arc-length step. Dropping the
jerk limit relaxes the problem, so it is a lower bound of any jerk-limited motion along that
curve, up to the discretisation. It is computed on the curve the program was sampled from,
never on interpd's nodes. A path smoothed inside the band may be shorter than the curve (a
loop below the tolerance cut), so a ratio below 1 is possible there.

The jerk-limited bound (`axis_jerk_bound`): per axis, the moves between its reversals, each at
that axis' velocity, acceleration and jerk limit with velocity 0 at both reversals; the largest
sum over the axes. Also independent of interpd, weak on curves, close on rasters.
"""
import argparse
import json
import math
import os
import random
import sys

import numpy as np

TOL_MM = 0.01
DUP_EVERY = 97
KINDS = ["cusp", "subtol", "raster", "plunge", "outlier", "helix", "wander"]
# Arc-length step of the bound's resampling, as a share of the program's move step, and its
# floor, mm: fine enough that the bound converges (halving it changes it by < 0.1 %).
BOUND_STEP_SHARE = 0.25
BOUND_STEP_MIN_MM = 0.0002
# Parameter samples per mm of curve when the curve is resampled by arc length.
FINE_PER_MM = 20000
# The random walk's segment at the 20 um step: the ~7 um of the polyline that fell back whole.
WANDER_STEP_MM = 0.007
# A true cusp: the tangent turns by more than this within the tolerance on either side.
CUSP_TURN_DEG = 150.0


def load_machine(path):
    """Per axis (max_vel, max_acc, max_jerk) of a machine TOML (X, Y, Z)."""
    import tomllib
    with open(path, "rb") as f:
        m = tomllib.load(f)
    return [(a["max_vel"], a["max_acc"], a["max_jerk"]) for a in m["axis"]]


# ----------------------------------------------------------------------------- curves


def resample(f, u0, u1, step, approx_len):
    """Points of the parametric curve f on [u0, u1] at `step` mm of arc length (the last point
    is the curve's end), by a fine parameter walk."""
    n = max(1000, int(approx_len * FINE_PER_MM))
    u = np.linspace(u0, u1, n + 1)
    p = f(u)
    seg = np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    targets = np.arange(0.0, s[-1], step)
    if s[-1] - targets[-1] > 1e-9:
        targets = np.append(targets, s[-1])
    out = np.empty((len(targets), 3))
    for k in range(3):
        out[:, k] = np.interp(targets, s, p[:, k])
    return out


# Centre travel of the cusp trochoid, mm (the path is about 3 times as long); the daemon bench
# makes a long one (issue 41's 300 000-move program).
CUSP_CENTRE_MM = (20.0, 40.0)


def cusp_curve(rng):
    pitch = rng.uniform(0.2, 1.0)                 # centre travel per loop, mm
    omega = 2 * math.pi / pitch
    r0 = rng.uniform(5.0, 10.0)                   # spiral start radius, mm
    grow = rng.uniform(0.5, 2.0)                  # spiral radius growth per turn, mm
    length = rng.uniform(*CUSP_CENTRE_MM)         # centre travel, mm
    k0, k1 = (0.5, 2.0) if rng.random() < 0.5 else (2.0, 0.5)
    # Critical loop radius: the loop speed r * omega equals the centre speed (1 per unit u).
    r_crit = 1.0 / omega

    b = grow / (2 * math.pi)                      # radius growth per radian, mm

    def spiral(u):
        # Archimedean spiral r = r0 + b*phi by its arc length u: s(phi) = r0*phi + b*phi^2/2
        # (the b^2 term of ds/dphi = sqrt(r^2 + b^2) is below 1e-3 of r here), inverted.
        phi = (np.sqrt(r0 * r0 + 2.0 * b * u) - r0) / b
        rad = r0 + b * phi
        return rad * np.cos(phi), rad * np.sin(phi)

    def f(u):
        cx, cy = spiral(u)
        # The centre's own speed is not exactly 1: scale the loop by it, so the ratio of loop
        # speed to centre speed is k exactly.
        du = 1e-6
        dx, dy = spiral(u + du)
        speed = np.hypot(dx - cx, dy - cy) / du
        k = k0 * (k1 / k0) ** (u / length)
        r = k * r_crit * speed
        a = omega * u
        return np.stack([cx + r * np.cos(a), cy + r * np.sin(a), np.full_like(u, -1.0)], axis=1)

    u_crit = length * math.log(1.0 / k0) / math.log(k1 / k0)
    cusps = None          # counted on the curve (count_reversals)
    params = dict(pitch_mm=pitch, r0_mm=r0, grow_mm=grow, centre_mm=length, k=[k0, k1],
                  r_crit_mm=r_crit, u_crit_mm=u_crit)
    return f, (0.0, length), length * 2 * math.pi * 2 * r_crit / pitch + length, params, cusps


def subtol_curve(rng):
    R = rng.uniform(20.0, 60.0)                   # base arc radius, mm
    length = rng.uniform(20.0, 40.0)
    rho = rng.uniform(0.2, 0.9) * TOL_MM          # loop radius, mm
    kappa = rng.uniform(1.5, 4.0)                 # loop speed / base speed: real loops
    omega = kappa / rho
    bursts = [(rng.uniform(0.1, 0.9) * length, rng.uniform(0.5, 3.0)) for _ in range(rng.randint(2, 6))]

    def f(u):
        phi = u / R
        bx, by = R * np.sin(phi), R * (1 - np.cos(phi))
        w = np.zeros_like(u)
        for c, half in bursts:
            x = np.clip(np.abs(u - c) / half, 0.0, 1.0)
            w = np.maximum(w, 0.5 * (1 + np.cos(math.pi * x)))
        a = omega * u
        r = rho * w
        return np.stack([bx + r * np.cos(a) - r, by + r * np.sin(a), np.full_like(u, -1.0)], axis=1)

    params = dict(base_radius_mm=R, loop_radius_mm=rho, loop_speed_ratio=kappa,
                  bursts=[[c, h] for c, h in bursts])
    return f, (0.0, length), length * (1 + kappa), params, 0


def raster_curve(rng):
    row = rng.uniform(4.0, 12.0)
    w = math.exp(rng.uniform(math.log(0.02), math.log(0.5)))   # stepover, mm
    rows = rng.randint(4, 10)
    amp = rng.uniform(0.2, 2.0)
    lam = rng.uniform(3.0, 10.0)
    turn = math.pi * w / 2
    period = row + turn

    def surface(x, y):
        return amp * np.sin(x / lam) * np.cos(y / lam) - 2.0

    def f(u):
        k = np.floor(u / period)
        v = u - k * period
        even = (k % 2) == 0
        x_start = np.where(even, 0.0, row)
        d = np.where(even, 1.0, -1.0)
        on_row = v <= row
        a = np.clip((v - row) / (w / 2), 0.0, math.pi)
        x = np.where(on_row, x_start + d * v, x_start + d * row + d * (w / 2) * np.sin(a))
        y = k * w + np.where(on_row, 0.0, (w / 2) * (1 - np.cos(a)))
        return np.stack([x, y, surface(x, y)], axis=1)

    length = rows * period - turn
    params = dict(row_mm=row, stepover_mm=w, rows=rows, amplitude_mm=amp, wavelength_mm=lam)
    return f, (0.0, length), length * 1.2, params, 0


def plunge_curve(rng):
    legs = rng.randint(3, 8)
    leg = rng.uniform(2.0, 6.0)                   # XY travel between plunges, mm
    depth = rng.uniform(0.5, 3.0)                 # plunge depth, mm
    slope = rng.uniform(0.5, 2.0)                 # XY travel of the ramp per mm of depth
    ramp = depth * math.hypot(1.0, slope)
    heading = rng.uniform(0, 2 * math.pi)
    turn = rng.uniform(-0.3, 0.3)                 # heading change per leg, rad

    # Piecewise: leg (XY line), ramp down, ramp back up the same line (the reversal).
    pieces = []
    pos = np.array([0.0, 0.0, 0.0])
    for i in range(legs):
        h = heading + i * turn
        d = np.array([math.cos(h), math.sin(h), 0.0])
        end = pos + leg * d
        pieces.append((pos.copy(), end.copy()))
        pos = end
        dr = np.array([math.cos(h) * slope, math.sin(h) * slope, -1.0])
        dr = dr / np.linalg.norm(dr)
        bottom = pos + ramp * dr
        pieces.append((pos.copy(), bottom.copy()))
        pieces.append((bottom.copy(), pos.copy()))
    lengths = np.array([np.linalg.norm(b - a) for a, b in pieces])
    starts = np.concatenate([[0.0], np.cumsum(lengths)])

    def f(u):
        i = np.clip(np.searchsorted(starts, u, side="right") - 1, 0, len(pieces) - 1)
        a = np.array([pieces[j][0] for j in range(len(pieces))])[i]
        b = np.array([pieces[j][1] for j in range(len(pieces))])[i]
        t = ((u - starts[i]) / lengths[i])[:, None]
        return a + t * (b - a)

    params = dict(legs=legs, leg_mm=leg, depth_mm=depth, slope=slope)
    # A reversal at each bottom; the corners at the top turn by 90 deg + atan: stops as well.
    return f, (0.0, float(starts[-1])), float(starts[-1]), params, legs


def outlier_curve(rng):
    A = rng.uniform(2.0, 10.0)
    lam = rng.uniform(10.0, 30.0)
    length = rng.uniform(20.0, 40.0)

    def f(u):
        return np.stack([u, A * np.sin(2 * math.pi * u / lam), np.full_like(u, -1.0)], axis=1)

    params = dict(amplitude_mm=A, wavelength_mm=lam, outliers="20-200 um every 2-8 mm")
    return f, (0.0, length), length * 1.3, params, 0


def helix_curve(rng):
    r = rng.uniform(2.0, 10.0)
    pitch = rng.uniform(0.2, 1.0)
    turns = rng.uniform(1.5, 4.0)

    def f(u):
        a = u
        return np.stack([r * np.cos(a), r * np.sin(a), -pitch * a / (2 * math.pi)], axis=1)

    length = turns * math.hypot(2 * math.pi * r, pitch)
    params = dict(radius_mm=r, pitch_mm=pitch, turns=turns)
    return f, (0.0, turns * 2 * math.pi), length, params, 0


CURVES = {"cusp": cusp_curve, "subtol": subtol_curve, "raster": raster_curve, "plunge": plunge_curve,
          "outlier": outlier_curve, "helix": helix_curve}


def wander_points(rng, step, length):
    """A random walk of `step` mm segments turning ~17 deg each (Gaussian), in XY."""
    n = int(length / step)
    turns = np.array([rng.gauss(0.0, math.radians(17.0)) for _ in range(n)])
    h = np.cumsum(turns)
    p = np.zeros((n + 1, 3))
    p[1:, 0] = np.cumsum(step * np.cos(h))
    p[1:, 1] = np.cumsum(step * np.sin(h))
    p[:, 2] = -1.0
    return p


def count_reversals(points, tol):
    """Places where the curve's tangent turns by more than CUSP_TURN_DEG between `tol` before
    and `tol` after (a reversal the band cannot smooth away), counted once per place."""
    d = np.diff(points, axis=0)
    ds = np.sqrt((d * d).sum(axis=1))
    keep = ds > 1e-12
    d, ds = d[keep], ds[keep]
    t = d / ds[:, None]
    s = np.concatenate([[0.0], np.cumsum(ds)])[:-1]
    i_before = np.searchsorted(s, s - tol)
    i_after = np.clip(np.searchsorted(s, s + tol), 0, len(t) - 1)
    cosine = (t[i_before] * t[i_after]).sum(axis=1)
    hit = cosine < math.cos(math.radians(CUSP_TURN_DEG))
    count, inside, last_s = 0, False, -math.inf
    for i in np.nonzero(hit)[0]:
        if s[i] - last_s > 2 * tol:
            count += 1
        last_s = s[i]
    return count


# ----------------------------------------------------------------------------- the bound


def acc_only_bound(points, limits, feed_mm_s):
    """Acceleration-only time-optimal motion time along the polyline `points` taken as a
    curve (resampled finely enough that its chords are the curve), from rest to rest: b = v^2
    per sample, forward and backward passes with the per-axis acceleration constraint
    |x'_k a + x''_k b| <= a_max_k (a = b'/2), the per-axis velocity limit and the feed."""
    d = np.diff(points, axis=0)
    ds = np.sqrt((d * d).sum(axis=1))
    keep = np.concatenate([[True], ds > 1e-12])
    p = points[keep]
    s = np.concatenate([[0.0], np.cumsum(np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)))])
    h = s[1:] - s[:-1]
    n = len(p)
    # Derivatives by arc length: central differences on the (non-uniform) samples.
    x1 = np.gradient(p, s, axis=0)
    norm = np.maximum(np.sqrt((x1 * x1).sum(axis=1)), 1e-300)
    x1 = x1 / norm[:, None]
    x2 = np.gradient(x1, s, axis=0)
    vmax = np.array([l[0] for l in limits])
    amax = np.array([l[1] for l in limits])
    b_cap = np.full(n, feed_mm_s ** 2)
    for k in range(3):
        with np.errstate(divide="ignore"):
            b_cap = np.minimum(b_cap, np.where(np.abs(x1[:, k]) > 1e-12, (vmax[k] / np.abs(x1[:, k])) ** 2, np.inf))
    # The largest b at which some a satisfies every axis (bisection, vectorised).
    def a_range(b):
        lo = np.full(n, -np.inf)
        hi = np.full(n, np.inf)
        for k in range(3):
            c1, c2 = x1[:, k], x2[:, k] * b
            with np.errstate(divide="ignore", invalid="ignore"):
                u = (amax[k] - c2) / c1
                l = (-amax[k] - c2) / c1
            pos, neg, zero = c1 > 1e-12, c1 < -1e-12, np.abs(c1) <= 1e-12
            hi = np.where(pos, np.minimum(hi, u), np.where(neg, np.minimum(hi, l), hi))
            lo = np.where(pos, np.maximum(lo, l), np.where(neg, np.maximum(lo, u), lo))
            bad = zero & (np.abs(c2) > amax[k])
            lo = np.where(bad, np.inf, lo)
        return lo, hi

    lo_b, hi_b = np.zeros(n), b_cap.copy()
    lo, hi = a_range(hi_b)
    ok = lo <= hi
    for _ in range(60):
        mid = 0.5 * (lo_b + hi_b)
        l, u = a_range(mid)
        good = l <= u
        lo_b = np.where(good, mid, lo_b)
        hi_b = np.where(good, hi_b, mid)
    b_max = np.where(ok, b_cap, lo_b)
    b = b_max.copy()
    b[0] = 0.0
    b[-1] = 0.0
    for i in range(n - 1):                         # forward: largest acceleration
        _, u = a_range_at(x1[i], x2[i], b[i], amax)
        b[i + 1] = min(b[i + 1], max(0.0, b[i] + 2 * h[i] * u))
    for i in range(n - 1, 0, -1):                  # backward: largest deceleration
        l, _ = a_range_at(x1[i], x2[i], b[i], amax)
        b[i - 1] = min(b[i - 1], max(0.0, b[i] - 2 * h[i - 1] * l))
    v = np.sqrt(np.maximum(b, 0.0))
    vm = v[1:] + v[:-1]
    with np.errstate(divide="ignore"):
        t = np.where(vm > 0, 2 * h / np.maximum(vm, 1e-300), np.inf)
    return float(t.sum()), float(s[-1])


def reversal_time_s(d_mm, vmax, amax, jmax):
    """Shortest time one axis needs to move `d_mm` between two of its reversals: velocity 0 at
    both ends (an extremum of the axis), acceleration free there, |v| <= vmax, |a| <= amax,
    |j| <= jmax. The optimum is symmetric: acceleration a0 held for t1 (a0 = amax, or less where
    the move is short), jerk -jmax for 2 a0 / jmax to -a0, -a0 held for t1; a cruise at vmax
    in the middle where the peak would exceed it."""
    if d_mm <= 0.0:
        return 0.0

    def reach(a0, t1):
        # Displacement and peak velocity of the profile without cruise.
        t2 = 2.0 * a0 / jmax
        v1 = a0 * t1
        return v1 * (t1 + t2) + a0 * t2 * t2 / 2.0 - jmax * t2 ** 3 / 6.0, v1 + a0 * a0 / (2.0 * jmax)

    # The profile that just reaches vmax at its peak, and the distance it covers.
    if vmax >= amax * amax / (2.0 * jmax):
        a_c, t1_c = amax, (vmax - amax * amax / (2.0 * jmax)) / amax
    else:
        a_c, t1_c = math.sqrt(2.0 * jmax * vmax), 0.0
    d_c, _ = reach(a_c, t1_c)
    if d_mm >= d_c:
        return 2.0 * t1_c + 2.0 * a_c / jmax + (d_mm - d_c) / vmax
    # Shorter: bisect on the total time T (the displacement grows with it).
    def d_of(t_total):
        a0 = min(amax, jmax * t_total / 2.0)
        t1 = (t_total - 2.0 * a0 / jmax) / 2.0
        return reach(a0, t1)[0]
    lo, hi = 0.0, 2.0 * t1_c + 2.0 * a_c / jmax
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if d_of(mid) < d_mm:
            lo = mid
        else:
            hi = mid
    return hi


def axis_jerk_bound(points, limits, tol_mm):
    """A jerk-limited lower bound of the motion time along `points` that nothing of interpd's
    computes: per axis, the moves between its reversals (extrema, counted only where the axis
    goes back by more than 2 x tol, so a reversal the smoothing may cut inside the band is not
    one), each shortened by 2 x tol and taken at the axis' own velocity, acceleration and jerk
    limits with velocity 0 at each reversal (`reversal_time_s`); the motion takes at least the
    largest sum over the axes. Weak on curved paths (it ignores the coupling of the axes),
    close to the motion where one axis reverses at every U-turn: what the jerk limit costs that
    the acceleration-only bound does not see."""
    best = 0.0
    for k, (vmax, amax, jmax) in enumerate(limits):
        x = points[:, k]
        # Extrema with a hysteresis of 2 x tol: `cand` is the running extreme of the current
        # direction, kept as a reversal once the axis has gone back from it by more than that.
        ext, cand, direction = [x[0]], x[0], 0
        for xi in x[1:]:
            if direction == 0:
                if abs(xi - x[0]) > 2.0 * tol_mm:
                    direction, cand = (1 if xi > x[0] else -1), xi
            elif (xi - cand) * direction > 0:
                cand = xi
            elif abs(xi - cand) > 2.0 * tol_mm:
                ext.append(cand)
                direction, cand = -direction, xi
        if direction != 0:
            ext.append(cand)
        total = sum(reversal_time_s(abs(b - a) - 2.0 * tol_mm, vmax, amax, jmax) for a, b in zip(ext, ext[1:]))
        best = max(best, total)
    return best


def a_range_at(x1, x2, b, amax):
    lo, hi = -math.inf, math.inf
    for k in range(3):
        c1, c2 = x1[k], x2[k] * b
        if abs(c1) <= 1e-12:
            if abs(c2) > amax[k]:
                return math.inf, -math.inf
            continue
        u = (amax[k] - c2) / c1
        l = (-amax[k] - c2) / c1
        if c1 < 0:
            u, l = l, u
        hi, lo = min(hi, u), max(lo, l)
    return lo, hi


# ----------------------------------------------------------------------------- programs


def make(kind, seed, step):
    """(program text, unrounded points, description) of one program of the family."""
    rng = random.Random(f"{kind}:{seed}:{step}")
    feed = rng.choice([3000, 6000, 9000, 12000])
    cusps = 0
    if kind == "wander":
        pts = wander_points(rng, WANDER_STEP_MM if step > 0.005 else step, rng.uniform(10.0, 25.0))
        params = dict(turn_deg_sigma=17.0)
        curve = None
    else:
        f, (u0, u1), approx_len, params, cusps = CURVES[kind](rng)
        pts = resample(f, u0, u1, step, approx_len)
        curve = resample(f, u0, u1, max(BOUND_STEP_MIN_MM, min(step * BOUND_STEP_SHARE, 0.001)), approx_len)
        if cusps is None:
            cusps = count_reversals(curve, TOL_MM)
    prog = pts.copy()
    if kind == "outlier":
        i = 0
        while True:
            i += int(rng.uniform(2.0, 8.0) / step)
            if i >= len(prog) - 2:
                break
            t = prog[i + 1] - prog[i - 1]
            nrm = np.array([-t[1], t[0], 0.0]) / max(np.hypot(t[0], t[1]), 1e-12)
            prog[i] = prog[i] + nrm * rng.uniform(0.02, 0.2) * rng.choice([-1, 1])
        curve = None          # the bound is taken on the programmed points (the spikes count)
    lines = [f"(interpd CAM family: {kind}, seed {seed}, step {step} mm, {len(prog) - 1} moves)",
             "G21 G90 G17", "G0 X%.4f Y%.4f Z%.4f" % tuple(prog[0]), f"G64 P{TOL_MM}", f"G1 F{feed}"]
    prev = None
    for i, p in enumerate(prog[1:], start=1):
        line = "X%.4f Y%.4f Z%.4f" % tuple(p)
        lines.append(line)
        if i % DUP_EVERY == 0:
            lines.append(line)
        prev = line
    lines.append("M30")
    desc = dict(kind=kind, seed=seed, step_mm=step, moves=len(prog) - 1, feed_mm_min=feed,
                true_cusps=cusps, params=params)
    return "\n".join(lines) + "\n", prog, curve, desc


def write(dirname, seed, count, step, machine, kinds):
    os.makedirs(dirname, exist_ok=True)
    limits = load_machine(machine)
    out = []
    for i in range(count):
        kind = kinds[i % len(kinds)]
        text, prog, curve, desc = make(kind, seed + i, step)
        name = f"{kind}-{seed + i}-{'2um' if step < 0.005 else '20um'}"
        base = os.path.join(dirname, name)
        with open(base + ".ngc", "w") as f:
            f.write(text)
        ref = curve if curve is not None else prog
        if kind == "wander":
            desc["bound_s"] = None
        else:
            desc["bound_s"], desc["length_mm"] = acc_only_bound(ref, limits, desc["feed_mm_min"] / 60.0)
        desc["jerk_bound_s"] = axis_jerk_bound(ref, limits, TOL_MM)
        np.save(base + ".curve.npy", ref)
        with open(base + ".json", "w") as f:
            json.dump(desc, f, indent=1)
        out.append(base)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("dir")
    w.add_argument("--seed", type=int, default=1)
    w.add_argument("--count", type=int, default=len(KINDS))
    w.add_argument("--step-mm", type=float, default=0.02)
    w.add_argument("--kinds", default=",".join(KINDS))
    w.add_argument("--machine", default=os.path.join(os.path.dirname(__file__), "family_machine.toml"))
    a = ap.parse_args()
    if a.cmd == "write":
        for base in write(a.dir, a.seed, a.count, a.step_mm, a.machine, a.kinds.split(",")):
            d = json.load(open(base + ".json"))
            print(f"{os.path.basename(base)}: {d['moves']} moves, bound {d['bound_s']}")


if __name__ == "__main__":
    main()
