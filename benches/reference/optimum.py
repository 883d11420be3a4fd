#!/usr/bin/env python3
"""Reference optimum for the look-ahead planner (Kopp et al. 2019, §4: the authors compared with
pyOpt + Ipopt on the same profile definition).

Input: the JSON that `interpd plan PROGRAM --export-nodes FILE` writes: the planner's nodes
s_i with A', A'', A''' on both sides, the feed, the (already limit_fraction-scaled) axis limits,
the time fractions where limits are checked, and the planner's own profile at the nodes.

Two problems on the same nodes:

1. Ipopt (via CasADi): the time-optimal problem with the planner's profile definition,
   Kopp et al. 2019, eq. 2–3: per interval a constant path jerk j_i over a duration T_i, v and a
   continuous (C^1), minimise sum T_i subject to every axis' velocity, acceleration and jerk
   limit (eq. 1a-1c) at the same check points inside every interval, with the geometry
   between nodes as the planner's checks see it: a path table's own rows where the export
   gives a node's "span" (A', A'', A''' to the next node as polynomials in the interval
   fraction), else interpolated (cubic Hermite for A' and A'', linear A'''), v <= feed, rest
   at stops. Started from the planner's own profile.
2. The acceleration-only problem (no jerk limit): exact forward/backward passes in b = v^2
   (b linear per step, the classical time-optimal path parameterisation), on the nodes with
   every interval split into SUBSTEPS pieces of interpolated geometry. Dropping the jerk
   limit relaxes the problem, so this is a lower bound of any jerk-limited motion time (up to
   the O(h) discretisation of the passes).

Prints per program: our motion time, the Ipopt optimum, the bound and the ratios.
Not part of `cargo test`; see docs/planner.md ("The reference optimum").
"""

import argparse
import json
import math
import sys
import time

import casadi as ca
import numpy as np

SUBSTEPS = 8


def load(path):
    with open(path) as f:
        return json.load(f)


def blocks(nodes):
    """Index ranges [i0, i1] between stops (both ends at rest)."""
    stops = [i for i, n in enumerate(nodes) if n["stop"]]
    if stops[0] != 0:
        stops.insert(0, 0)
    if stops[-1] != len(nodes) - 1:
        stops.append(len(nodes) - 1)
    return [(a, b) for a, b in zip(stops, stops[1:]) if b > a]


def geom_at(start, end, ds, sigma, k, m, span=None):
    """The planner's geometry between nodes (motion/src/planner/check.rs geom_at), sign = +1:
    the exact polynomial `span` (the node's export, per axis 18 coefficients: A' 0..7, A''
    7..13, A''' 13..18) where given, else its interpolation. `m` is the math module to use
    (math or casadi)."""
    if span is not None:
        c = span[k]

        def poly(lo, hi):
            return sum(c[lo + i] * sigma**i for i in range(hi - lo))

        return poly(0, 7), poly(7, 13), poly(13, 18)
    s2, s3 = sigma * sigma, sigma * sigma * sigma
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + sigma
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    d1 = h00 * start["d1"][k] + h01 * end["d1"][k] + ds * (h10 * start["d2"][k] + h11 * end["d2"][k])
    d2 = h00 * start["d2"][k] + h01 * end["d2"][k] + ds * (h10 * start["d3"][k] + h11 * end["d3"][k])
    d3 = (1 - sigma) * start["d3"][k] + sigma * end["d3"][k]
    return d1, d2, d3


# ----------------------------------------------------------------------------- Ipopt problem


def ipopt_block(data, i0, i1, verbose, free_ends=False):
    """Time-optimal constant-jerk profile over nodes i0..i1 (rest at both ends; with
    `free_ends`, rest only at an end that is a stop: the least time any profile of the family
    spends on these nodes, whatever it enters and leaves them with).

    Built as one SX expression graph (scalar operations, exact sparse Hessian) for Ipopt."""
    nodes, lim, prof = data["nodes"], data["limits"], data["profile"]
    n_ax = len(data["axes"])
    fracs = data["check_fractions"]
    m = i1 - i0  # intervals
    ds = [nodes[i + 1]["s"] - nodes[i]["s"] for i in range(i0, i1)]
    # Scales: velocity by the largest bound, time by the typical interval of our profile.
    vs = max(min(n["vbar"], n["feed"]) for n in nodes[i0 : i1 + 1]) or 1.0
    ours_T = [p[3] if p else None for p in prof[i0:i1]]
    ts = float(np.median([t for t in ours_T if t])) if any(ours_T) else sum(ds) / vs / m
    as_, js = vs / ts, vs / ts / ts

    V, A = ca.SX.sym("V", m + 1), ca.SX.sym("A", m + 1)
    J, T = ca.SX.sym("J", m), ca.SX.sym("T", m)
    x = ca.vertcat(V, A, J, T)
    inf = ca.inf
    lbx = [0.0] * (m + 1) + [-inf] * (m + 1) + [-inf] * m + [1e-6] * m
    ubx = [inf] * (m + 1) + [inf] * (m + 1) + [inf] * m + [inf] * m
    for idx, i in ((0, i0), (m, i1)):  # rest at both ends
        if free_ends and not nodes[i]["stop"]:
            continue
        lbx[idx] = ubx[idx] = 0.0
        lbx[m + 1 + idx] = ubx[m + 1 + idx] = 0.0
    g, lbg, ubg = [], [], []

    def add(expr, lo, hi):
        if not expr.is_constant():  # an axis that does not move
            g.append(expr)
            lbg.append(lo)
            ubg.append(hi)

    for q in range(m):
        i = i0 + q
        vq, aq, jq, tq = V[q] * vs, A[q] * as_, J[q] * js, T[q] * ts
        # Kopp et al. 2019, eq. 2 over the interval: end state and covered distance.
        add((vq + aq * tq + jq * tq**2 / 2) / vs - V[q + 1], 0.0, 0.0)
        add((aq + jq * tq) / as_ - A[q + 1], 0.0, 0.0)
        add((vq * tq + aq * tq**2 / 2 + jq * tq**3 / 6) / ds[q], 1.0, 1.0)
        start, end = nodes[i]["right"], nodes[i + 1]["left"]
        feed = nodes[i]["feed"]
        # A table interval the nodes do not interpolate well is checked at more points.
        for f in data["fine_check_fractions"] if nodes[i].get("fine") else fracs:
            tau = f * tq
            s_loc = vq * tau + aq * tau**2 / 2 + jq * tau**3 / 6
            vv = vq + aq * tau + jq * tau**2 / 2
            aa = aq + jq * tau
            sigma = 0.0 if f == 0 else (1.0 if f == 1 else s_loc / ds[q])
            if feed < 1e300:
                add(vv / feed, -inf, 1.0)
            for k in range(n_ax):
                d1, d2, d3 = geom_at(start, end, ds[q], sigma, k, ca, nodes[i].get("span"))
                vel = d1 * vv  # eq. 1a
                acc = d2 * vv**2 + d1 * aa  # eq. 1b
                jerk = d3 * vv**3 + 3 * d2 * vv * aa + d1 * jq  # eq. 1c
                add(ca.SX(vel / lim["vel"][k]), -1.0, 1.0)
                add(ca.SX(acc / lim["acc_max"][k]), lim["acc_min"][k] / lim["acc_max"][k], 1.0)
                add(ca.SX(jerk / lim["jerk"][k]), -1.0, 1.0)
    # Curvature jumps (G1 joints without G2): the axis acceleration steps by dA''.v^2 at the
    # node; the planner keeps that step within what the jerk limit moves in curvature_jump_s
    # (motion/src/planner/node.rs curvature_jump_cap), part of the same problem.
    step_s = data.get("curvature_jump_s", 0.0)
    for q in range(1, m):
        nd = nodes[i0 + q]
        for k in range(n_ax):
            jump = abs(nd["left"]["d2"][k] - nd["right"]["d2"][k])
            if jump > 0 and not nd["stop"]:
                add(jump * (V[q] * vs) ** 2 / (lim["jerk"][k] * step_s), -inf, 1.0)
    # Start from our profile.
    x0 = [0.0] * (m + 1) + [0.0] * (m + 1) + [0.0] * m + [1.0] * m
    for q in range(m):
        p = prof[i0 + q]
        if p:
            x0[q], x0[m + 1 + q] = p[0] / vs, p[1] / as_
            x0[2 * (m + 1) + q], x0[2 * (m + 1) + m + q] = p[2] / js, p[3] / ts
    opts = {"ipopt.max_iter": 3000, "ipopt.tol": 1e-9, "ipopt.print_level": 5 if verbose else 0, "print_time": False}
    solver = ca.nlpsol("ref", "ipopt", {"x": x, "f": ca.sum1(T) * ts, "g": ca.vertcat(*g)}, opts)
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    status = solver.stats()["return_status"]
    x = np.array(sol["x"]).ravel()
    v_opt = x[: m + 1] * vs
    t_opt = x[2 * (m + 1) + m :] * ts
    return float(sol["f"]), ("optimal" if status == "Solve_Succeeded" else status), v_opt, t_opt


# ------------------------------------------------------------------ acceleration-only bound


def acc_only_block(data, i0, i1):
    """Minimum time without the jerk limit: forward/backward passes in b = v^2."""
    nodes, lim = data["nodes"], data["limits"]
    n_ax = len(data["axes"])
    pts = []  # (s, d1[], d2[], feed, stop)
    for i in range(i0, i1):
        start, end = nodes[i]["right"], nodes[i + 1]["left"]
        ds = nodes[i + 1]["s"] - nodes[i]["s"]
        for q in range(SUBSTEPS):
            sig = q / SUBSTEPS
            g = [geom_at(start, end, ds, sig, k, math, nodes[i].get("span")) for k in range(n_ax)]
            pts.append((nodes[i]["s"] + sig * ds, [x[0] for x in g], [x[1] for x in g], nodes[i]["feed"]))
    end = nodes[i1]["left"]
    pts.append((nodes[i1]["s"], end["d1"][:n_ax], end["d2"][:n_ax], nodes[i1 - 1]["feed"]))
    n = len(pts)

    def mvc(p):
        """Largest v at which some a keeps every axis inside (a = 0 is not required)."""
        _, d1, d2, feed = p
        v = feed
        for k in range(n_ax):
            if abs(d1[k]) > 0:
                v = min(v, lim["vel"][k] / abs(d1[k]))
        # Acceleration limits: bisection on v for a non-empty a-range.
        lo, hi = 0.0, v
        if acc_range(p, hi)[0] <= acc_range(p, hi)[1]:
            return hi
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            r = acc_range(p, mid)
            if r[0] <= r[1]:
                lo = mid
            else:
                hi = mid
        return lo

    def acc_range(p, v):
        _, d1, d2, _ = p
        lo, hi = -math.inf, math.inf
        for k in range(n_ax):
            c = d2[k] * v * v
            if abs(d1[k]) < 1e-300:
                if c > lim["acc_max"][k] or c < lim["acc_min"][k]:
                    return (1.0, -1.0)
                continue
            x, y = (lim["acc_min"][k] - c) / d1[k], (lim["acc_max"][k] - c) / d1[k]
            lo, hi = max(lo, min(x, y)), min(hi, max(x, y))
        return lo, hi

    bmax = [mvc(p) ** 2 for p in pts]
    bmax[0] = bmax[-1] = 0.0
    # Backward pass: from rest at the end, b_i <= b_{i+1} - 2 ds a_min(s_{i+1}, b_{i+1}).
    b = bmax[:]
    for i in range(n - 2, -1, -1):
        ds = pts[i + 1][0] - pts[i][0]
        lo, hi = acc_range(pts[i + 1], math.sqrt(b[i + 1]))
        reach = b[i + 1] - 2 * ds * lo if lo <= hi else b[i + 1]
        b[i] = min(b[i], max(reach, 0.0))
    # Forward pass: from rest, b_{i+1} <= b_i + 2 ds a_max(s_i, b_i).
    for i in range(n - 1):
        ds = pts[i + 1][0] - pts[i][0]
        lo, hi = acc_range(pts[i], math.sqrt(b[i]))
        reach = b[i] + 2 * ds * hi if lo <= hi else b[i]
        b[i + 1] = min(b[i + 1], max(reach, 0.0))
    total = 0.0
    for i in range(n - 1):
        ds = pts[i + 1][0] - pts[i][0]
        vm = math.sqrt(b[i]) + math.sqrt(b[i + 1])
        if vm <= 0:
            return math.inf
        total += 2 * ds / vm
    return total


def where_lost(data, i0, i1, v_opt, dt_opt):
    """Per stretch of the block between local minima of our v-bar (the planner's section ends):
    (s from, s to, our time, Ipopt's time, largest Ipopt velocity over our v-bar at a node)."""
    nodes, prof = data["nodes"], data["profile"]
    vbar = [n["vbar"] for n in nodes]
    cuts = [i0] + [i for i in range(i0 + 1, i1) if vbar[i] < vbar[i - 1] and vbar[i] <= vbar[i + 1]] + [i1]
    out = []
    for a, b in zip(cuts, cuts[1:]):
        t_ours = sum(prof[i][3] for i in range(a, b) if prof[i])
        t_ipopt = float(sum(dt_opt[a - i0 : b - i0]))
        ratio = max((v_opt[i - i0] / vbar[i] for i in range(a, b + 1) if vbar[i] > 0), default=0.0)
        out.append((nodes[a]["s"], nodes[b]["s"], t_ours, t_ipopt, ratio))
    return out


def window_bounds(data, path, n, max_windows, verbose):
    """Ipopt with free end states on consecutive windows of `n` nodes (or `max_windows` of them
    spread evenly): per window our time on its nodes and the least time of any profile of the
    planner's family there. Over all windows of a program their sum is a lower bound of its
    jerk-limited motion time on these nodes (windows split the time at their shared nodes)."""
    nodes, prof = data["nodes"], data["profile"]
    starts = list(range(0, len(nodes) - 2, n))
    if max_windows and len(starts) > max_windows:
        step = len(starts) / max_windows
        starts = [starts[int(k * step)] for k in range(max_windows)]
    ours_sum, opt_sum, worst = 0.0, 0.0, 0.0
    t0 = time.time()
    for i0 in starts:
        i1 = min(i0 + n, len(nodes) - 1)
        t_ours = sum(p[3] for p in prof[i0:i1] if p)
        t_opt, st, _, _ = ipopt_block(data, i0, i1, verbose, free_ends=True)
        if st != "optimal":
            print(f"  {nodes[i0]['s']:9.3f}-{nodes[i1]['s']:9.3f} mm: Ipopt {st}, left out", flush=True)
            continue
        ours_sum, opt_sum = ours_sum + t_ours, opt_sum + t_opt
        worst = max(worst, t_ours / t_opt)
        print(f"  {nodes[i0]['s']:9.3f}-{nodes[i1]['s']:9.3f} mm: ours {t_ours:.4f} s, Ipopt {t_opt:.4f} s, "
              f"ours/Ipopt {t_ours / t_opt:.4f}", flush=True)
    print(f"{path}: windows of {n} nodes: ours {ours_sum:.4f} s, Ipopt (free ends) {opt_sum:.4f} s, "
          f"ours/Ipopt {ours_sum / max(opt_sum, 1e-12):.4f}, worst window {worst:.4f} "
          f"[{len(nodes)} nodes, {time.time() - t0:.1f} s]", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("exports", nargs="+", help="JSON files from interpd plan --export-nodes")
    ap.add_argument("--verbose", action="store_true", help="Ipopt iteration log")
    ap.add_argument("--no-ipopt", action="store_true", help="only the acceleration-only bound")
    ap.add_argument(
        "--windows",
        type=int,
        default=0,
        metavar="N",
        help="instead of whole blocks, Ipopt on windows of N nodes with free end states (a lower bound of the time "
        "on each window's nodes): for programs too long for one solve",
    )
    ap.add_argument("--max-windows", type=int, default=0, metavar="K", help="with --windows: K windows spread evenly")
    ap.add_argument(
        "--where",
        type=int,
        default=0,
        metavar="N",
        help="also list the N stretches (between minima of our v-bar) where our motion loses most time to Ipopt's",
    )
    args = ap.parse_args()
    if args.windows:
        for path in args.exports:
            window_bounds(load(path), path, args.windows, args.max_windows, args.verbose)
        return 0
    worst = 0.0
    for path in args.exports:
        data = load(path)
        ours = data["duration_s"]
        opt_total, bound_total, statuses = 0.0, 0.0, set()
        t0 = time.time()
        stretches = []
        for i0, i1 in blocks(data["nodes"]):
            if i1 - i0 < 2:
                # A straight rest-to-rest move planned in closed form (its own optimum).
                seg = [p for p in data["profile"][i0:i1] if p]
                t_ours = sum(p[3] for p in seg) if seg else 0.0
                opt_total += t_ours
                bound_total += t_ours
                statuses.add("closed-form")
                continue
            if not args.no_ipopt:
                t_opt, st, v_opt, dt_opt = ipopt_block(data, i0, i1, args.verbose)
                opt_total += t_opt
                statuses.add(st)
                if args.where:
                    stretches.extend(where_lost(data, i0, i1, v_opt, dt_opt))
            bound_total += acc_only_block(data, i0, i1)
        dwell = ours - sum(p[3] for p in data["profile"] if p)
        opt_total += max(dwell, 0.0)
        bound_total += max(dwell, 0.0)
        line = f"{path}: ours {ours:.5f} s"
        if not args.no_ipopt:
            ratio = ours / opt_total
            worst = max(worst, ratio)
            line += f", Ipopt {opt_total:.5f} s ({'/'.join(sorted(statuses))}), ours/Ipopt {ratio:.4f}"
        line += f", acceleration-only bound {bound_total:.5f} s, ours/bound {ours / bound_total:.4f}"
        line += f" [{len(data['nodes'])} nodes, {time.time() - t0:.1f} s]"
        print(line, flush=True)
        if args.where and stretches:
            stretches.sort(key=lambda r: -(r[2] - r[3]))
            print(f"  where {path} loses most (s from-to mm: ours s, Ipopt s, largest Ipopt v / our v-bar):")
            for s0, s1, t_ours, t_ipopt, ratio in stretches[: args.where]:
                print(f"  {s0:9.3f}-{s1:9.3f}: {t_ours:.4f} vs {t_ipopt:.4f} (+{t_ours - t_ipopt:.4f}), v/v-bar up to {ratio:.2f}")
    if not args.no_ipopt:
        print(f"largest ours/Ipopt: {worst:.4f} (target <= 1.05)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
