#!/usr/bin/env python3
"""Checks the simulated drive's EDS with an independent CANopen implementation.

Usage: check_eds.py EDS_FILE

Two layers:
1. The `canopen` package from PyPI parses the file (canopen.objectdictionary.import_od) and
   derives the PDO configuration from it exactly as a CANopen master would (PdoMap.read with
   from_od=True): COB-IDs, transmission types, mapped objects and their bit lengths.
2. A structural CiA 306 check that canopen does not do: every object listed in the
   [Mandatory|Optional|Manufacturer]Objects sections exists and vice versa, SupportedObjects
   counts match, SubNumber matches the sub-index sections and sub-index 0 equals the highest
   sub-index.

Prints one line per failed check and exits 1 if any failed, 0 otherwise.
"""

import configparser
import re
import sys

import canopen
from canopen.objectdictionary import datatypes

NODE_ID = 3
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


def main(path):
    od = canopen.objectdictionary.import_od(path, node_id=NODE_ID)

    def default(index, sub=None):
        obj = od[index]
        return (obj[sub] if sub is not None else obj).default

    # Key objects with their types, access and defaults.
    expect_vars = [
        # index, name, data type, access, default
        (0x1000, "Device type", datatypes.UNSIGNED32, "ro", 0x00020192),
        (0x1001, "Error register", datatypes.UNSIGNED8, "ro", 0),
        (0x1014, "COB-ID EMCY", datatypes.UNSIGNED32, "ro", 0x80 + NODE_ID),
        (0x6040, "Controlword", datatypes.UNSIGNED16, "rww", None),
        (0x6041, "Statusword", datatypes.UNSIGNED16, "ro", None),
        (0x1017, "Producer heartbeat time", datatypes.UNSIGNED16, "rw", 0),
        (0x6060, "Modes of operation", datatypes.INTEGER8, "rw", 0),
        (0x6061, "Modes of operation display", datatypes.INTEGER8, "ro", 0),
        (0x6064, "Position actual value", datatypes.INTEGER32, "ro", None),
        (0x607A, "Target position", datatypes.INTEGER32, "rww", None),
        (0x6502, "Supported drive modes", datatypes.UNSIGNED32, "ro", 0xA0),
        (0x607C, "Home offset", datatypes.INTEGER32, "rw", 0),
        (0x6098, "Homing method", datatypes.INTEGER8, "rw", 37),
        (0x609A, "Homing acceleration", datatypes.UNSIGNED32, "rw", None),
    ]
    for index, name, dtype, access, dflt in expect_vars:
        if index not in od:
            failures.append(f"0x{index:04X} {name}: missing")
            continue
        var = od[index]
        check(var.name == name, f"0x{index:04X}: name {var.name!r}, expected {name!r}")
        check(var.data_type == dtype, f"0x{index:04X} {name}: data type 0x{var.data_type:04X}, expected 0x{dtype:04X}")
        check(var.access_type == access, f"0x{index:04X} {name}: access {var.access_type}, expected {access}")
        if dflt is not None:
            check(var.default == dflt, f"0x{index:04X} {name}: default {var.default!r}, expected {dflt!r}")
    for index in (0x6040, 0x6041, 0x6064, 0x607A):
        check(od[index].pdo_mappable, f"0x{index:04X}: must be PDO-mappable")

    # Device type: profile 402 in the low word, servo drive (0x0002) in the high word.
    check(default(0x1000) & 0xFFFF == 402, "0x1000: device profile is not 402")
    check(default(0x6502) & 0x80, "0x6502: CSP (bit 7) not supported")
    check(default(0x6502) & 0x20, "0x6502: homing (bit 5) not supported")
    check([s for s in od[0x6099].subindices] == [0, 1, 2], f"0x6099: sub-indices {list(od[0x6099].subindices)}")
    ident = od[0x1018]
    check([s for s in ident.subindices] == [0, 1, 2, 3, 4], f"0x1018: sub-indices {list(ident.subindices)}")
    check(default(0x60C2, 1) == 4 and default(0x60C2, 2) == -3, "0x60C2: interpolation period is not 4 ms (4 x 10^-3 s)")
    check(0x608F in od or 0x6091 in od, "neither 0x608F nor 0x6091 present")

    # The power-on PDOs exactly as a master derives them from the dictionary: CiA 402's
    # default, the controlword alone in RPDO1 and the statusword alone in TPDO1, event-driven.
    network = canopen.Network()
    node = network.add_node(NODE_ID, od)
    node.rpdo.read(from_od=True)
    node.tpdo.read(from_od=True)
    expect_pdos = [
        ("RPDO1", node.rpdo[1], 0x200 + NODE_ID, [("Controlword", 0x6040, 16)]),
        ("TPDO1", node.tpdo[1], 0x180 + NODE_ID, [("Statusword", 0x6041, 16)]),
    ]
    for label, pdo, cob_id, entries in expect_pdos:
        check(pdo.enabled, f"{label}: not enabled")
        check(pdo.cob_id == cob_id, f"{label}: COB-ID 0x{pdo.cob_id:X}, expected 0x{cob_id:X}")
        check(pdo.trans_type == 255, f"{label}: transmission type {pdo.trans_type}, expected 255 (event-driven)")
        got = [(v.name, v.index, v.length) for v in pdo.map]
        check(got == entries, f"{label}: mapping {got}, expected {entries}")
    # The mapping the master configures (interpd_canopen::boot::csp_ops) encoded by canopen
    # gives the protocol crate's byte layout (little-endian, DLC 6).
    rpdo = node.rpdo[1]
    rpdo.clear()
    rpdo.add_variable(0x6040)
    rpdo.add_variable(0x607A)
    rpdo["Controlword"].raw = 0x000F
    rpdo["Target position"].raw = -2
    check(rpdo.length == 48, f"configured RPDO1: {rpdo.length} bits, expected 48")
    check(bytes(rpdo.data) == bytes([0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF]), f"RPDO1 bytes {bytes(rpdo.data).hex()}")
    for index in (0x6040, 0x607A, 0x6041, 0x6064, 0x6061):
        check(od[index].pdo_mappable, f"0x{index:04X}: the master maps it, so it must be PDO-mappable")
    check(len(node.rpdo.map) >= 1 and len(node.tpdo.map) >= 1, "no PDO maps")

    structural_check(path)


def structural_check(path):
    eds = configparser.RawConfigParser(inline_comment_prefixes=(";",))
    eds.optionxform = str
    with open(path) as f:
        eds.read_file(f)
    for section in ("FileInfo", "DeviceInfo", "DummyUsage", "MandatoryObjects", "OptionalObjects"):
        check(eds.has_section(section), f"[{section}] missing")
    check(eds.get("FileInfo", "EDSVersion", fallback="") == "4.0", "FileInfo: EDSVersion is not 4.0")
    listed = set()
    for section in ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects"):
        if not eds.has_section(section):
            continue
        n = int(eds.get(section, "SupportedObjects"), 0)
        entries = [int(eds.get(section, str(i)), 0) for i in range(1, n + 1)]
        extra = [k for k in eds.options(section) if k != "SupportedObjects" and not (k.isdigit() and 1 <= int(k) <= n)]
        check(not extra, f"[{section}]: entries beyond SupportedObjects={n}: {extra}")
        check(len(set(entries)) == n, f"[{section}]: duplicate entries")
        listed.update(entries)
    for index in (0x1000, 0x1001, 0x1018):
        check(index in listed, f"mandatory object 0x{index:04X} not listed")
    objects = {int(s, 16) for s in eds.sections() if re.fullmatch(r"[0-9A-Fa-f]{4}", s)}
    check(objects == listed, f"listed but undefined: {sorted(hex(i) for i in listed - objects)}, "
          f"defined but unlisted: {sorted(hex(i) for i in objects - listed)}")
    for s in eds.sections():
        m = re.fullmatch(r"([0-9A-Fa-f]{4})sub([0-9A-Fa-f]+)", s)
        if m:
            check(int(m.group(1), 16) in objects, f"[{s}] belongs to no object")
    for index in sorted(objects):
        sec = f"{index:04X}"
        otype = int(eds.get(sec, "ObjectType", fallback="0x7"), 0)
        if otype in (0x8, 0x9):
            subs = sorted(int(m.group(1), 16) for s in eds.sections()
                          if (m := re.fullmatch(rf"{sec}sub([0-9A-Fa-f]+)", s, re.IGNORECASE)))
            n = int(eds.get(sec, "SubNumber"), 0)
            check(n == len(subs), f"[{sec}]: SubNumber={n}, {len(subs)} sub-index sections")
            # In a PDO mapping parameter sub-index 0 is the number of mapped objects.
            is_mapping = 0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF
            check(is_mapping or (subs and int(eds.get(f"{sec}sub0", "DefaultValue"), 0) == subs[-1]),
                  f"[{sec}]: sub-index 0 is not the highest sub-index {subs[-1] if subs else None}")
        else:
            for key in ("ParameterName", "DataType", "AccessType"):
                check(eds.has_option(sec, key), f"[{sec}]: {key} missing")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    try:
        main(sys.argv[1])
    except Exception as e:  # a parse failure is a test failure with its message, not a traceback only
        failures.append(f"{type(e).__name__}: {e}")
    for f in failures:
        print(f"EDS check failed: {f}")
    if failures:
        sys.exit(1)
    print(f"EDS OK: {sys.argv[1]} (canopen {canopen.__version__})")
