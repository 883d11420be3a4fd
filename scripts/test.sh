#!/usr/bin/env bash
# The project's test command (README, .ci/run): no unused dependencies and no import circles
# between the files of one folder; unit, property and end-to-end tests in a release build, the
# time-bounded parser fuzzing, the CAN tests over vcan (in a VM when the host has no vcan) and
# a 5-minute soak of the daemon with the plant, which runs beside the CAN tests. Exit status:
# non-zero if anything failed.
set -euo pipefail
cd "$(dirname "$0")/.."

export FUZZ_SECONDS="${FUZZ_SECONDS:-60}"
# Property tests draw from one fixed seed here, so a CI run is reproducible (a plain
# `cargo test` explores new random cases; a failure it finds lands in a *.proptest-regressions
# file and is replayed from then on).
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261123}"
# The soak's client acts from a fixed seed too; 0 seconds skips it.
SOAK_SECONDS="${SOAK_SECONDS:-300}"
SOAK_SEED="${SOAK_SEED:-20261127}"
# Unused dependencies fail the run first, before anything is built (cargo-machete reads each
# crate's [dependencies]; .ci/run installs it).
echo "== cargo machete (unused dependencies)"
if ! cargo machete --version >/dev/null 2>&1; then
    echo "cargo-machete is not installed: cargo install cargo-machete --locked" >&2
    exit 1
fi
cargo machete
echo "== import circles between the files of one folder (scripts/module-cycles.py)"
python3 scripts/module-cycles.py
echo "== cargo test --workspace --release (parser fuzzing ${FUZZ_SECONDS}s; the soak runs below)"
cargo test --workspace --release -- --skip soak_keeps_the_limits_and_its_memory

# The soak is a real-time run on the host. The CAN tests meanwhile either run in a VM in
# virtual time, where host load cannot make a thread late, or on the host's vcan with the
# daemon and drives at SCHED_FIFO; their build runs at a lower priority than the soak.
soak_pid=""
SOAK_LOG="$(mktemp -t interpd-soak.XXXXXX)"
if [ "$SOAK_SECONDS" != 0 ]; then
    echo "== soak: ${SOAK_SECONDS}s, SOAK_SEED=${SOAK_SEED} (target/release/soak), beside the CAN tests"
    "${CARGO_TARGET_DIR:-target}/release/soak" --seconds "$SOAK_SECONDS" --seed "$SOAK_SEED" >"$SOAK_LOG" 2>&1 &
    soak_pid=$!
fi
can_rc=0
if [ -x scripts/vcan-vm.sh ]; then
    echo "== CAN tests over vcan (scripts/vcan-vm.sh)"
    nice -n 10 scripts/vcan-vm.sh || can_rc=$?
fi
soak_rc=0
if [ -n "$soak_pid" ]; then
    wait "$soak_pid" || soak_rc=$?
    echo "== soak (exit status $soak_rc):"
    cat "$SOAK_LOG"
fi
rm -f "$SOAK_LOG"
if [ "$can_rc" != 0 ] || [ "$soak_rc" != 0 ]; then
    echo "== FAILED: CAN tests exit status $can_rc, soak exit status $soak_rc"
    exit 1
fi
echo "== all tests passed"
