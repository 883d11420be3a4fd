#!/usr/bin/python3
"""Canonical motion of G-code programs as LinuxCNC's interpreter produces it, one JSON object per
program on stdout, for the differential test (tests/tests/rs274_differential.rs).

Runs each FILE through the `gcode` Python module of the Debian package `linuxcnc-uspace` (the
interpreter `rs274` links, with the canonical calls handed over as doubles instead of
`rs274 -g`'s four decimals), starting in G21 like interpd. Output per program:

    {"file": ..., "ok": true|false, "error": "...", "moves": [...], "final_dwell_s": ...}

Each move: {"kind": "rapid"|"feed"|"arc", "end": [X Y Z A B C U V W] (mm, deg),
"feed_mm_min": number or null, "dwell_s": seconds of dwell before it} and for arcs also
"plane" (17, 18, 19), "centre" (mm, in the plane's axis order: X Y, Z X, Y Z) and "turns"
(signed: positive counter-clockwise). Positions and centres are machine coordinates: the
module's program coordinates plus the G92 offset, turned by the work system's XY rotation
(G10 L2 R), plus the work (G54-G59.3) and tool length (G43.1) offsets it reports, as LinuxCNC's
canon maps them and as interpd's path is. Moves shorter than 1e-9 mm are dropped, as interpd drops them. Usage: /usr/bin/python3 scripts/rs274_canon.py FILE...
"""
import json
import math
import os
import sys
import tempfile

import gcode

MM_PER_INCH = 25.4
# Linear axes among X Y Z A B C U V W: the module reports them in inches.
LINEAR = [True, True, True, False, False, False, True, True, True]
# interpd drops moves shorter than this (motion/src/program/gcode.rs, MIN_MOVE_MM).
MIN_MOVE_MM = 1e-9
# LinuxCNC's plane codes (CANON_PLANE_XY, _YZ, _XZ) as G17, G19, G18, and the axis indices
# of (first, second, helix) for each.
PLANES = {1: (17, (0, 1, 2)), 2: (19, (1, 2, 0)), 3: (18, (2, 0, 1))}


def to_mm(values):
    return [v * MM_PER_INCH if lin else v for v, lin in zip(values, LINEAR)]


class Recorder:
    """The canon the module calls back; records moves, feeds, dwells and the plane."""

    def __init__(self, parameter_file):
        self.parameter_file = parameter_file
        self.moves = []
        self.pos = [0.0] * 9
        self.feed_mm_min = None
        self.plane = 1
        self.dwell_s = 0.0
        # Work (G54-G59) and G92 offsets, in the module's units, per axis.
        self.g5x = [0.0] * 9
        self.g92 = [0.0] * 9
        # The rotation of the active work system about Z, degrees (SET_XY_ROTATION).
        self.rotation_deg = 0.0
        # The tool length offset (USE_TOOL_LENGTH_OFFSET: G43.1, or G43 with a tool table),
        # in the module's units.
        self.tlo = [0.0] * 9

    def _machine(self, values):
        """Program coordinates (the module's units) to machine coordinates in mm: as
        LinuxCNC's canon (`rotate_and_offset_pos`), the G92 offset, then the XY rotation of
        the work system about its origin, then the work and tool length offsets."""
        v = [p + h for p, h in zip(values, self.g92)]
        if self.rotation_deg:
            t = math.radians(self.rotation_deg)
            v[0], v[1] = v[0] * math.cos(t) - v[1] * math.sin(t), v[0] * math.sin(t) + v[1] * math.cos(t)
        return to_mm([p + g + t for p, g, t in zip(v, self.g5x, self.tlo)])

    def _move(self, kind, end, extra=None):
        lin = math.sqrt(sum((e - p) ** 2 for e, p, l in zip(end, self.pos, LINEAR) if l))
        rot = math.sqrt(sum((e - p) ** 2 for e, p, l in zip(end, self.pos, LINEAR) if not l))
        if kind != "arc" and lin <= MIN_MOVE_MM and rot <= MIN_MOVE_MM:
            self.pos = end
            return
        move = {"kind": kind, "end": end, "feed_mm_min": None if kind == "rapid" else self.feed_mm_min,
                "dwell_s": self.dwell_s}
        move.update(extra or {})
        self.moves.append(move)
        self.dwell_s = 0.0
        self.pos = end

    def straight_traverse(self, *a):
        self._move("rapid", self._machine(a))

    def straight_feed(self, *a):
        self._move("feed", self._machine(a))

    def arc_feed(self, first_end, second_end, first_centre, second_centre, rotation, axis_end, a, b, c, u, v, w):
        g, (i, j, k) = PLANES[self.plane]
        prog = [0.0] * 3 + [a, b, c, u, v, w]
        prog[i], prog[j], prog[k] = first_end, second_end, axis_end
        end = self._machine(prog)
        centre_prog = [0.0] * 9
        centre_prog[i], centre_prog[j] = first_centre, second_centre
        centre_mm = self._machine(centre_prog)
        self._move("arc", end, {"plane": g, "centre": [centre_mm[i], centre_mm[j]], "turns": rotation})

    def set_feed_rate(self, rate):
        self.feed_mm_min = rate * MM_PER_INCH

    def set_plane(self, plane):
        self.plane = plane

    def dwell(self, seconds):
        self.dwell_s += seconds

    # Calls without an effect on the compared motion.
    def next_line(self, state):
        pass

    def comment(self, text):
        pass

    def message(self, text):
        pass

    def set_traverse_rate(self, rate):
        pass

    def set_xy_rotation(self, deg):
        self.rotation_deg = deg

    def set_g5x_offset(self, index, *a):
        self.g5x = list(a)

    def set_g92_offset(self, *a):
        self.g92 = list(a)

    def tool_offset(self, *a):
        self.tlo = list(a) + [0.0] * (9 - len(a))

    def change_tool(self, *a):
        pass

    def straight_probe(self, *a):
        pass

    def rigid_tap(self, *a):
        pass

    def user_defined_function(self, *a):
        pass

    def get_tool(self, pocket):
        return (-1,) + (0.0,) * 12 + (0,)

    def get_external_angular_units(self):
        return 1.0

    def get_external_length_units(self):
        return 1.0 / MM_PER_INCH

    def get_axis_mask(self):
        return 0x1FF

    def get_block_delete(self):
        return False

    def check_abort(self):
        return False


def run(path, parameter_file):
    canon = Recorder(parameter_file)
    result, _seq = gcode.parse(path, canon, ["G21"], "")
    ok = result <= gcode.MIN_ERROR
    return {"file": path, "ok": ok, "error": "" if ok else gcode.strerror(result),
            "moves": canon.moves, "final_dwell_s": canon.dwell_s}


def main():
    with tempfile.TemporaryDirectory() as tmp:
        parameter_file = os.path.join(tmp, "rs274.var")
        open(parameter_file, "w").close()
        for path in sys.argv[1:]:
            print(json.dumps(run(path, parameter_file)), flush=True)


if __name__ == "__main__":
    main()
