#!/usr/bin/env bash
# The project's test command (README, .ci/run): unit, property and end-to-end tests in a
# release build, the time-bounded parser fuzzing, and the CAN tests over vcan (in a VM when the
# host has no vcan). Exit status: non-zero if anything failed.
set -euo pipefail
cd "$(dirname "$0")/.."

export FUZZ_SECONDS="${FUZZ_SECONDS:-60}"
# Property tests draw from one fixed seed here, so a CI run is reproducible (a plain
# `cargo test` explores new random cases; a failure it finds lands in a *.proptest-regressions
# file and is replayed from then on).
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261123}"
echo "== cargo test --workspace --release (parser fuzzing ${FUZZ_SECONDS}s)"
cargo test --workspace --release

if [ -x scripts/vcan-vm.sh ]; then
    echo "== CAN tests over vcan (scripts/vcan-vm.sh)"
    scripts/vcan-vm.sh
fi
echo "== all tests passed"
