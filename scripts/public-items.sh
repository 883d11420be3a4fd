#!/usr/bin/env bash
# Counts the public items of a crate's source tree by kind: the `pub` fn, struct, enum, trait,
# type, const, static, mod and use items (not `pub(crate)` and the like), outside test files.
# The crates deny `unreachable_pub` warnings (clippy -D warnings), so every item counted is
# reachable from outside the crate.
#   scripts/public-items.sh motion/src [--list]    (issue 37: 265 before Feed, 246 after)
set -euo pipefail
dir=$1
items=$(grep -rnE '^\s*pub (const |async |unsafe )*(fn|struct|enum|trait|type|mod|use|static|const) ' "$dir" --include=*.rs \
  | grep -vE '/tests?\.rs:|/tests/' || true)
if [ "${2:-}" = --list ]; then printf '%s\n' "$items"; exit 0; fi
printf '%s\n' "$items" | sed -E 's/^[^:]*:[0-9]+:\s*pub ((const |async |unsafe )*)(fn|struct|enum|trait|type|mod|use|static|const) .*/\3/' | sort | uniq -c
printf '%s\n' "$items" | grep -c . | sed 's/^/total /'
