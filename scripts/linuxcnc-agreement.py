#!/usr/bin/python3
"""Agreement of interpd with LinuxCNC's interpreter over directories of G-code programs.

Usage: /usr/bin/python3 scripts/linuxcnc-agreement.py BINARY DIR... [--machine FILE] [--json]
       [--jobs N] [--list]

For every `.ngc` under the DIRs (recursively):

- Scope. A program is left out, with the reason, when it needs what interpd is not meant to
  carry out (issue 38): probing (G38.x), lathe modes (G7 G8 G33.1 G70 G71 G72 G76, G96 with
  G7/G8), remapping, HAL or Python (M62-M68, M100-M199, `#<_ini[`, `#<_hal[`, `(py,`, a
  directory whose INI file remaps codes or loads Python), U/V/W axes, or an `o<name> call` of
  a subroutine that is neither in the file nor a `name.ngc` in its directory.
- LinuxCNC: `rs274 -g -t TOOLS -v VARS` (Debian's `linuxcnc-uspace`), run in the program's
  directory (where LinuxCNC's interpreter looks for subroutine files without an INI file):
  the verdict. The motion comes from `scripts/rs274_canon.py` (LinuxCNC's `gcode` module, the
  same interpreter, doubles); for programs with T, H or tool-number D words (not G41.1/G42.1's
  diameter D), which the module cannot run without a live tool table, from `rs274 -g`'s printed calls (4 decimals in the program's
  units: the final position is then compared within 1 µm plus that rounding). `rs274 -g` prints a
  NURBS (G5, G5.1, G5.2/G5.3) as one `NURBS_FEED` call without its points, so a program with
  one whose tool words are only T and M6 (no D, H, G41/G42/G43: the tool does not change the
  motion) is run through the module without its T and M6 words (on M6 the module crashes). The
  module draws a NURBS as `15·(n+1)` chords, and its path length is theirs (interpd draws the
  same chords: docs/formats.md). Where the module crashes (M61 Q) on a program without NURBS,
  the printed calls are the reference.
- interpd: `BINARY check FILE --machine M`: the verdict, the first error, the path length
  (the programmed path, cutter-compensated, before smoothing); `BINARY plan FILE --machine M
  --period-ms 1e6 --out CSV`: the final position (the last sample, where the machine rests).

The machine: the 3-axis machine FILE (default tests/machines/xyz_loose.toml, X Y ±1000 mm,
Z ±500 mm), or for a program with A, B or C words the `--rotary-machine` (default
tests/machines/xyzabc_loose.toml: the same with rotary A B C), written to a scratch copy with travel widened to ±100 000 mm (the programs are not
written for any one machine) and tools 1-99 added where FILE has none: diameter 0.125 in
(3.175 mm), length 0, as `rs274`'s tool table gets them too (tool 1 of FILE is kept: 6 mm).

Both accept and agree: final X Y Z within 1 µm and path length within 0.01 mm (over X Y Z; a
move of A B C alone counts its degrees, as LinuxCNC's canon and interpd count it). A program both
accept whose `interpd plan` fails or takes longer than 60 s has no final position and is
counted apart.
"""
import argparse
import collections
import concurrent.futures
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CANON = os.path.join(REPO, "scripts", "rs274_canon.py")
SYSTEM_PYTHON = "/usr/bin/python3"
MM_PER_INCH = 25.4
POS_TOL_MM = 1e-3
LENGTH_TOL_MM = 0.01
TRAVEL_MM = 100_000.0
DEFAULT_TOOL_DIAMETER_MM = 3.175
TOOLS = range(1, 100)
TIMEOUT_S = 120
# `interpd plan` only gives the final position; a plan that takes longer is reported apart.
PLAN_TIMEOUT_S = 60

# ----------------------------------------------------------------------------------------------
# Scope


def strip_comments(line):
    """The line without `( … )` comments and without what follows `;`."""
    out, depth = [], False
    for c in line:
        if depth:
            depth = c != ")"
        elif c == "(":
            depth = True
        elif c == ";":
            break
        else:
            out.append(c)
    return "".join(out)


def words(text):
    """(letter, number text) of every word outside comments; named parameters `#<x>`,
    O-word names `o<x>` and keywords of two or more letters (SIN, sub, while …) are skipped."""
    out = []
    for raw in text.splitlines():
        line = strip_comments(raw).upper().replace(" ", "").replace("\t", "")
        line = re.sub(r"<[^>]*>", "", line)
        line = re.sub(r"[A-Z]{2,}", "", line)
        for m in re.finditer(r"([A-Z])([-+]?[0-9.]+)?", line):
            out.append((m.group(1), m.group(2) or ""))
    return out


def code_values(ws, letter):
    vals = []
    for l, n in ws:
        if l == letter and n:
            try:
                vals.append(float(n))
            except ValueError:
                pass
    return vals


def ini_needs_remap(directory):
    """The test directory's INI file remaps codes or loads Python (tests/interp/*)."""
    for name in os.listdir(directory):
        if name.endswith(".ini"):
            try:
                with open(os.path.join(directory, name), errors="replace") as f:
                    text = f.read().upper()
            except OSError:
                continue
            if "REMAP" in text or "[PYTHON]" in text or "TOPLEVEL" in text:
                return True
    return False


def out_of_scope(path, text):
    """The reason the program is left out, or None."""
    ws = words(text)
    g = code_values(ws, "G")
    m = code_values(ws, "M")
    low = text.lower()
    if any(math.isclose(v, x) for v in g for x in (38.2, 38.3, 38.4, 38.5)):
        return "probing (G38.x)"
    if any(math.isclose(v, x) for v in g for x in (7, 8, 33.1, 70, 71, 72, 76)):
        return "lathe modes (G7 G8 G33.1 G70-G72 G76)"
    if (
        any(62 <= v <= 68 or 100 <= v <= 199 for v in m)
        or "#<_ini[" in low
        or "#<_hal[" in low
        or "(py," in low
        or ";py," in low
        or ini_needs_remap(os.path.dirname(path))
    ):
        return "remapping, HAL or Python"
    if any(l in "UVW" for l, _ in ws):
        return "U/V/W axes"
    subs = {n.lower() for n in re.findall(r"o\s*<\s*([^>]+?)\s*>\s*sub\b", low)}
    calls = {n.lower() for n in re.findall(r"o\s*<\s*([^>]+?)\s*>\s*call\b", low)}
    directory = os.path.dirname(path)
    present = {f[:-4].lower() for f in os.listdir(directory) if f.lower().endswith(".ngc")}
    if calls - subs - present:
        return "absent subroutine files"
    return None


def has_tool_word(text):
    """A T or H word, or a D word that names a tool: the `gcode` module needs a running
    LinuxCNC's tool table for them. G41.1/G42.1's D is a diameter (no look-up): such programs
    run through the module, in doubles, not through `rs274 -g`'s 4 printed decimals."""
    for raw in text.splitlines():
        ws = words(raw)
        diameter = any(math.isclose(v, x) for v in code_values(ws, "G") for x in (41.1, 42.1))
        if any(l in "TH" or (l == "D" and not diameter) for l, _ in ws):
            return True
    return False


def needs_tool_data(text):
    """D or H words, or G41/G42/G43 (which use the tool in the spindle without them)."""
    ws = words(text)
    return any(l in "DH" for l, _ in ws) or any(
        math.isclose(v, x) for v in code_values(ws, "G") for x in (41, 42, 43)
    )


# ----------------------------------------------------------------------------------------------
# LinuxCNC


def rs274_g(path, tools_tbl, scratch):
    """`rs274 -g`'s verdict (None or the first error line) and its printed output."""
    var = os.path.join(scratch, "rs274.var")
    open(var, "w").close()
    try:
        p = subprocess.run(
            ["rs274", "-g", "-t", tools_tbl, "-v", var, os.path.basename(path)],
            cwd=os.path.dirname(path),
            env=dict(os.environ, HOME=scratch),
            capture_output=True,
            text=True,
            errors="replace",
            timeout=TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return "timeout", ""
    if p.returncode == 0:
        return None, p.stdout
    # The message goes to stderr (after "executing"); older builds print it on stdout.
    lines = [
        l for l in (p.stderr + "\n" + p.stdout).splitlines() if l.strip() and not l.lstrip()[:1].isdigit() and l.strip() != "executing"
    ]
    return (lines[0] if lines else f"exit {p.returncode}"), p.stdout


def arc_length(start, end, centre, plane_axes, turns):
    """Length of a helix from `start` to `end` (XYZ, mm) around `centre` (in the plane's axis
    order) with signed `turns` (positive counter-clockwise). Where the end point misses the
    start's circle, LinuxCNC moves a spiral whose radius changes linearly with the angle
    (`pmCircleInit`): its length, ∫ √(r² + r′² + h′²) dφ by Simpson's rule."""
    i, j, k = plane_axes
    a0 = math.atan2(start[j] - centre[1], start[i] - centre[0])
    a1 = math.atan2(end[j] - centre[1], end[i] - centre[0])
    r = math.hypot(start[i] - centre[0], start[j] - centre[1])
    r1 = math.hypot(end[i] - centre[0], end[j] - centre[1])
    if turns > 0:
        sweep = (a1 - a0) % (2 * math.pi)
    else:
        sweep = (a0 - a1) % (2 * math.pi)
    if sweep <= 1e-12:
        sweep = 2 * math.pi
    sweep += 2 * math.pi * (abs(turns) - 1)
    rise = end[k] - start[k]
    if abs(r1 - r) <= 1e-9:
        return math.hypot(r * sweep, rise)
    dr, dh = (r1 - r) / sweep, rise / sweep
    n = 2000
    step = sweep / n
    f = [math.sqrt((r + dr * step * m) ** 2 + dr * dr + dh * dh) for m in range(n + 1)]
    return step / 3 * (f[0] + f[n] + 4 * sum(f[1:n:2]) + 2 * sum(f[2:n:2]))


PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


def without_tool_changes(text):
    """The program without its T words and M6 (outside comments): what `gcode` can run."""
    out = []
    for raw in text.splitlines():
        parts, depth, code = [], False, []
        for c in raw + "\n":
            if depth or c in "(;" or c == "\n":
                if code:
                    chunk = "".join(code)
                    chunk = re.sub(r"(?i)\bT\s*[0-9]+", "", chunk)
                    chunk = re.sub(r"(?i)M\s*0*6(?![0-9.])", "", chunk)
                    parts.append(chunk)
                    code = []
                if c == ";":
                    depth = "line"
                elif c == "(" and not depth:
                    depth = True
                elif c == ")" and depth is True:
                    depth = False
                if c != "\n":
                    parts.append(c)
            else:
                code.append(c)
        out.append("".join(parts))
    return "\n".join(out) + "\n"


def canon_motion(path, text_instead=None, scratch=None):
    """(final XYZ mm, path length mm) from rs274_canon.py, or an error string. With
    `text_instead`, that text is run (written to `scratch`) in the program's directory."""
    target = os.path.basename(path)
    if text_instead is not None:
        target = os.path.join(scratch, "canon-" + os.path.basename(path))
        with open(target, "w") as f:
            f.write(text_instead)
    try:
        p = subprocess.run(
            [SYSTEM_PYTHON, CANON, target],
            cwd=os.path.dirname(path),
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return "canon timeout"
    # The program's own (PRINT, …) output shares stdout: the answer is the JSON line.
    answers = [l for l in p.stdout.splitlines() if l.startswith('{"file"')]
    if p.returncode != 0 or not answers:
        return f"canon failed ({p.returncode})"
    v = json.loads(answers[-1])
    if not v["ok"]:
        return "canon refuses: " + v["error"]
    pos = [0.0, 0.0, 0.0]
    rot = [0.0, 0.0, 0.0]
    length = 0.0
    for mv in v["moves"]:
        end = mv["end"][:3]
        end_rot = mv["end"][3:6]
        if mv["kind"] == "arc":
            length += arc_length(pos, end, mv["centre"], PLANE_AXES[mv["plane"]], mv["turns"])
        else:
            length += straight_length(pos, end, rot, end_rot)
        pos, rot = end, end_rot
    return pos, length, 0.0


def straight_length(pos, end, rot, end_rot):
    """A straight move's length as LinuxCNC's canon and interpd count it: over X Y Z, or over
    A B C (degrees) when only they move."""
    d = math.dist(pos, end)
    return d if d > 1e-9 else math.dist(rot, end_rot)


CALL = re.compile(r"([A-Z_0-9]+)\((.*)\)\s*$")
PRINTED_PLANES = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}


def printed_motion(out):
    """(final XYZ mm, path length mm, rounding mm) from `rs274 -g`'s printed calls: positions
    in the units of USE_LENGTH_UNITS, plus the G92 offset, turned by SET_XY_ROTATION (degrees,
    about the work origin), plus the G5x and tool length offsets."""
    scale, plane = 1.0, 17
    g5x, g92, tlo = [0.0] * 3, [0.0] * 3, [0.0] * 3
    pos = [0.0] * 3
    rot = [0.0] * 3
    length = 0.0
    inch = False
    rotation_deg = 0.0

    def nums(args):
        return [float(x) for x in re.split(r"[,\s]+", args.strip()) if x]

    def machine(p):
        # As LinuxCNC's canon (`rotate_and_offset_pos`): the G92 offset, the XY rotation of
        # the work system (SET_XY_ROTATION, degrees), then the work and tool offsets.
        v = [p[k] + g92[k] for k in range(3)]
        if rotation_deg:
            t = math.radians(rotation_deg)
            v[0], v[1] = v[0] * math.cos(t) - v[1] * math.sin(t), v[0] * math.sin(t) + v[1] * math.cos(t)
        return [(v[k] + g5x[k] + tlo[k]) * scale for k in range(3)]

    for line in out.splitlines():
        m = CALL.search(line)
        if not m:
            continue
        name, args = m.group(1), m.group(2)
        if name == "USE_LENGTH_UNITS":
            inch = "INCHES" in args
            scale = MM_PER_INCH if inch else 1.0
        elif name == "SELECT_PLANE":
            plane = PRINTED_PLANES.get(args.strip(), 17)
        elif name == "SET_G5X_OFFSET":
            g5x = nums(args)[1:4]
        elif name == "SET_G92_OFFSET":
            g92 = nums(args)[:3]
        elif name == "SET_XY_ROTATION":
            rotation_deg = nums(args)[0]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            tlo = nums(args)[:3]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            a = nums(args)
            end, end_rot = machine(a[:3]), a[3:6]
            length += straight_length(pos, end, rot, end_rot)
            pos, rot = end, end_rot
        elif name == "ARC_FEED":
            a = nums(args)
            i, j, k = PLANE_AXES[plane]
            prog, centre_prog = [0.0] * 3, [0.0] * 3
            prog[i], prog[j], prog[k] = a[0], a[1], a[5]
            centre_prog[i], centre_prog[j] = a[2], a[3]
            end = machine(prog)
            c = machine(centre_prog)
            length += arc_length(pos, end, [c[i], c[j]], (i, j, k), int(a[4]))
            pos = end
            rot = a[6:9] if len(a) >= 9 else rot
    # Per axis: the printed position and the printed tool length offset, each rounded.
    rounding = 2 * 0.5e-4 * (MM_PER_INCH if inch else 1.0)
    return pos, length, rounding


# ----------------------------------------------------------------------------------------------
# interpd

LENGTH = re.compile(r"length ([0-9.]+) mm")


# An operator message interpd check/plan print on stderr (docs/formats.md, "Messages"), not an
# error: `FILE:LINE: msg|debug|print: text`.
MESSAGE_LINE = re.compile(r"^\S.*:\d+: (msg|debug|print): ")


def error_lines(stderr):
    """The lines of interpd's stderr that are not operator messages."""
    return [l for l in stderr.strip().splitlines() if not MESSAGE_LINE.match(l)]


def interpd_check(binary, path, machine):
    """(None, length mm) or (first error message, None)."""
    try:
        p = subprocess.run(
            [binary, "check", path, "--machine", machine], capture_output=True, text=True, timeout=TIMEOUT_S
        )
    except subprocess.TimeoutExpired:
        return "timeout", None
    if p.returncode == 0:
        m = LENGTH.search(p.stdout)
        return None, float(m.group(1)) if m else None
    first = (error_lines(p.stderr) or [f"exit {p.returncode}"])[0]
    return first, None


def interpd_final(binary, path, machine, scratch):
    csv = os.path.join(scratch, "plan.csv")
    try:
        p = subprocess.run(
            [binary, "plan", path, "--machine", machine, "--period-ms", "1e6", "--out", csv],
            capture_output=True,
            text=True,
            timeout=PLAN_TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return f"plan timeout ({PLAN_TIMEOUT_S} s)"
    if p.returncode != 0 and "has no motion" in p.stderr:
        return [0.0, 0.0, 0.0]
    if p.returncode != 0:
        return "plan failed: " + (error_lines(p.stderr) or [""])[0]
    with open(csv) as f:
        rows = f.read().strip().splitlines()
    head = rows[0].split(",")
    last = rows[-1].split(",")
    return [float(last[head.index(a)]) for a in "XYZ"]


def normalise(message, path):
    """The error message without its position and with numbers replaced, for counting."""
    msg = message
    if msg.startswith(path):
        msg = msg[len(path) :]
    msg = re.sub(r"^:\d+:\d+:\s*", "", msg)
    msg = re.sub(r"^:\d+:\s*", "", msg)
    # Numbers that are not part of a word (G38.2 stays, a value like 0.0025 mm goes).
    msg = re.sub(r"(?<![A-Za-z0-9.])[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "N", msg)
    return msg.strip()


# ----------------------------------------------------------------------------------------------


def machine_files(base, scratch):
    """The widened machine file for interpd and the same tools as an rs274 tool table."""
    with open(base, "rb") as f:
        cfg = tomllib.load(f)
    with open(base) as f:
        text = f.read()
    # Travel: rewrite the min/max lines of the axis tables.
    text = re.sub(r"(?m)^min\s*=.*$", f"min = {-TRAVEL_MM}", text)
    text = re.sub(r"(?m)^max\s*=.*$", f"max = {TRAVEL_MM}", text)
    have = {t["number"]: t for t in cfg.get("tool", [])}
    tools = []
    for n in TOOLS:
        t = have.get(n)
        d = t["diameter"] if t else DEFAULT_TOOL_DIAMETER_MM
        length = t.get("length", 0.0) if t else 0.0
        tools.append((n, d, length))
        if not t:
            text += f"\n[[tool]]\nnumber = {n}\ndiameter = {d}\nlength = {length}\n"
    machine = os.path.join(scratch, "machine.toml")
    with open(machine, "w") as f:
        f.write(text)
    # rs274's tool table: standalone `rs274` reads its values as inches (a D6 offsets a G21
    # program by 76.2 mm).
    tbl = os.path.join(scratch, "tools.tbl")
    with open(tbl, "w") as f:
        for n, d, length in tools:
            f.write(f"T{n} P{n} Z{length / MM_PER_INCH:.12f} D{d / MM_PER_INCH:.12f}\n")
    return machine, tbl, tools


def uses_rotary_axes(text):
    """A, B or C words: the program needs the machine with rotary axes. A letter that stands
    alone (not within ABS, ATAN, AND, call, sub …; spaces kept, so `A EXISTS[#<b>]` counts)."""
    for raw in text.splitlines():
        line = re.sub(r"<[^>]*>", "", strip_comments(raw).upper())
        if re.search(r"(?<![A-Z_])[ABC](?![A-Z_])", line):
            return True
    return False


def run_one(args, machines, tbl, path):
    r = {"file": path}
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError as e:
        r["scope"] = f"unreadable ({e})"
        return r
    reason = out_of_scope(path, text)
    if reason:
        r["scope"] = reason
        return r
    r["scope"] = None
    machine = machines[1] if uses_rotary_axes(text) else machines[0]
    scratch = tempfile.mkdtemp(prefix="agree-")
    try:
        err, out = rs274_g(path, tbl, scratch)
        r["rs274_ok"] = err is None
        r["rs274_error"] = err
        ierr, length = interpd_check(args.binary, path, machine)
        r["interpd_ok"] = ierr is None
        r["interpd_error"] = ierr
        r["interpd_error_normalised"] = normalise(ierr, path) if ierr else None
        if r["rs274_ok"] and r["interpd_ok"]:
            if not has_tool_word(text):
                theirs = canon_motion(path)
            elif "NURBS_FEED" in out and not needs_tool_data(text):
                # `rs274 -g` prints a NURBS as one call without its points, and the `gcode`
                # module crashes on M6: T and M6 without D, H, G41/G42 or G43 do not change the
                # motion, so the module runs the program without them.
                theirs = canon_motion(path, without_tool_changes(text), scratch)
            else:
                theirs = printed_motion(out)
            if isinstance(theirs, str) and theirs.startswith("canon failed") and "NURBS_FEED" not in out:
                # The module crashed (it segfaults on M61 Q): rs274 -g's printed calls, which
                # the same interpreter produced, are the reference.
                theirs = printed_motion(out)
                r["reference"] = "rs274 -g printed calls (the gcode module crashed)"
            ours = interpd_final(args.binary, path, machine, scratch)
            r["interpd_length_mm"] = length
            r["interpd_final_mm"] = ours if not isinstance(ours, str) else None
            if isinstance(ours, str):
                # No final position from interpd: neither agreeing nor disagreeing.
                r["agree"] = None
                r["why"] = ours
            elif isinstance(theirs, str):
                r["agree"] = False
                r["why"] = theirs
            else:
                pos, rs_length, rounding = theirs
                r["rs274_final_mm"] = pos
                r["rs274_length_mm"] = rs_length
                dpos = max(abs(a - b) for a, b in zip(ours, pos))
                dlen = abs(length - rs_length)
                r["final_diff_mm"] = dpos
                r["length_diff_mm"] = dlen
                r["agree"] = dpos <= POS_TOL_MM + rounding and dlen <= LENGTH_TOL_MM
                if not r["agree"]:
                    r["why"] = f"final position differs by {dpos:.6f} mm, length by {dlen:.4f} mm"
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("binary")
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--machine", default=os.path.join(REPO, "tests/machines/xyz_loose.toml"))
    ap.add_argument(
        "--rotary-machine",
        default=os.path.join(REPO, "tests/machines/xyzabc_loose.toml"),
        help="the machine for programs with A, B or C words",
    )
    ap.add_argument("--json", action="store_true", help="one JSON object with the table and every program")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--list", action="store_true", help="also list every in-scope program with its verdicts")
    ap.add_argument("--top", type=int, default=15, help="refusal reasons listed")
    args = ap.parse_args()
    if shutil.which("rs274") is None:
        sys.exit("rs274 not found: apt-get install -y --no-install-recommends linuxcnc-uspace")
    files = []
    for d in args.dirs:
        for root, _, names in os.walk(d):
            files += [os.path.abspath(os.path.join(root, n)) for n in names if n.lower().endswith(".ngc")]
    files.sort()
    scratch = tempfile.mkdtemp(prefix="agree-machine-")
    try:
        machine, tbl, _ = machine_files(args.machine, scratch)
        rotary_dir = os.path.join(scratch, "rotary")
        os.mkdir(rotary_dir)
        machine_abc, _, _ = machine_files(args.rotary_machine, rotary_dir)
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            results = list(pool.map(lambda p: run_one(args, (machine, machine_abc), tbl, p), files))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    left_out = collections.Counter(r["scope"] for r in results if r["scope"])
    scope = [r for r in results if not r["scope"]]
    both = [r for r in scope if r["rs274_ok"] and r["interpd_ok"]]
    table = collections.OrderedDict(
        [
            ("programs", len(results)),
            ("left out", sum(left_out.values())),
            ("in scope", len(scope)),
            ("accepted by rs274", sum(r["rs274_ok"] for r in scope)),
            ("accepted by interpd", sum(r["interpd_ok"] for r in scope)),
            ("both accept and agree", sum(r["agree"] is True for r in both)),
            ("both accept but disagree", sum(r["agree"] is False for r in both)),
            ("both accept, interpd plan fails", sum(r["agree"] is None for r in both)),
            ("rs274 only", sum(r["rs274_ok"] and not r["interpd_ok"] for r in scope)),
            ("interpd only", sum(r["interpd_ok"] and not r["rs274_ok"] for r in scope)),
            ("refused by both", sum(not r["rs274_ok"] and not r["interpd_ok"] for r in scope)),
        ]
    )
    reasons = collections.Counter(r["interpd_error_normalised"] for r in scope if not r["interpd_ok"])
    reasons_rs_ok = collections.Counter(
        r["interpd_error_normalised"] for r in scope if not r["interpd_ok"] and r["rs274_ok"]
    )
    if args.json:
        print(
            json.dumps(
                {
                    "binary": args.binary,
                    "dirs": args.dirs,
                    "machine": args.machine,
                    "table": table,
                    "left_out": left_out,
                    "interpd_refusals": reasons.most_common(),
                    "interpd_refusals_where_rs274_accepts": reasons_rs_ok.most_common(),
                    "programs": results,
                },
                indent=1,
            )
        )
        return
    print(f"interpd: {args.binary}; machine: {args.machine} (travel ±{TRAVEL_MM:g} mm, tools 1-99)")
    width = max(len(k) for k in table)
    for k, v in table.items():
        print(f"  {k:<{width}}  {v:5d}")
    rs_ok = table["accepted by rs274"]
    if rs_ok:
        print(f"  agreeing / accepted by rs274: {table['both accept and agree'] / rs_ok:.1%}")
    print("left out:")
    for k, v in left_out.most_common():
        print(f"  {v:5d}  {k}")
    print(f"interpd's refusals of in-scope programs (first error, normalised; top {args.top}):")
    for k, v in reasons.most_common(args.top):
        print(f"  {v:5d}  {k}  (rs274 accepts {reasons_rs_ok.get(k, 0)})")
    disagree = [r for r in both if not r["agree"]]
    if disagree:
        print("both accept but disagree, or interpd's plan fails:")
        for r in disagree:
            print(f"  {r['file']}: {r.get('why')}")
    if args.list:
        print("in scope:")
        for r in scope:
            verdict = "agree" if r.get("agree") else "-"
            print(
                f"  {r['file']}: rs274 {'ok' if r['rs274_ok'] else 'refuses'}, interpd "
                f"{'ok' if r['interpd_ok'] else r['interpd_error']}, {verdict}"
            )


if __name__ == "__main__":
    main()
