#!/usr/bin/env bash
# Fingerprints the planned motion of every example: for each example program on each machine
# file (and G64 P0.01 / P0.1 variants of the corner shapes and of a dense slice), the exit code
# of `interpd plan --json --out`, the motion time and a hash of the setpoint CSV; and a hash of
# `interpd law --preset P --json` for every preset. Two binaries plan the same motion when their
# fingerprints agree (compare them with scripts/plan-fingerprint-compare.py).
#
#   scripts/plan-fingerprint.sh target/release/interpd /tmp/after.txt
set -uo pipefail
[ $# -eq 2 ] || { echo "usage: $0 INTERPD_BINARY OUT.txt" >&2; exit 2; }
BIN=$(readlink -f "$1"); OUT=$(readlink -f "$2")
cd "$(dirname "$0")/.."
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
for f in staircase corner_90 two_arcs line_arc_line zigzag demo; do
  for p in 0.01 0.1; do { echo "G64 P$p"; cat "examples/$f.ngc"; } > "$TMP/${f}_p$p.ngc"; done
done
{ echo "G64 P0.01"; head -5000 examples/dense_freeform.ngc; } > "$TMP/dense5000_p0.01.ngc"

plan() {  # plan LABEL PROGRAM [MACHINE]
  local args=(plan "$2" --json --out "$TMP/out.csv") j rc d h
  [ -n "${3:-}" ] && args+=(--machine "$3")
  j=$("$BIN" "${args[@]}" 2>/dev/null); rc=$?
  d=$(printf '%s' "$j" | python3 -c 'import sys, json
try: print(repr(json.load(sys.stdin).get("duration_s")))
except Exception: print("-")')
  h=-; [ $rc = 0 ] && h=$(sha256sum "$TMP/out.csv" | cut -c1-16)
  echo "${3:-default} $1 rc=$rc dur=$d csv=$h" >> "$OUT"
}

: > "$OUT"
for m in "" config/machines/xyz.toml tests/machines/xyz_tight.toml tests/machines/xyz_loose.toml \
         config/machines/xyzab.toml tests/machines/xyzab_tight.toml tests/machines/xyzab_loose.toml; do
  for p in examples/*.ngc examples/*.csv; do plan "$p" "$p" "$m"; done
done
for p in "$TMP"/*_p0.*.ngc; do
  for m in "" tests/machines/xyz_tight.toml; do plan "$(basename "$p")" "$p" "$m"; done
done
for pr in rr5 rr7 rr11 asymmetric constant-velocity degree8 inflection:0.4; do
  echo "law $pr $("$BIN" law --preset "$pr" --json 2>/dev/null | sha256sum | cut -c1-16)" >> "$OUT"
done
echo "$(wc -l < "$OUT") cases written to $OUT"
