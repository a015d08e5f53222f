#!/usr/bin/env bash
# Runs the Embree wrapper's tests (tests/embree_wrapper.rs: device errors, out of
# memory, builds, single-ray and packet queries) under valgrind's memcheck: invalid
# reads/writes, uses of uninitialised memory and definite leaks fail the run.
# Usage: .ci/valgrind.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(cargo test --release --test embree_wrapper --no-run --message-format=json 2>/dev/null |
    sed -n 's/.*"executable":"\([^"]*embree_wrapper[^"]*\)".*/\1/p' | tail -1)
if [ -z "$bin" ]; then
    echo "valgrind.sh: cannot find the embree_wrapper test binary" >&2
    exit 1
fi
# --test-threads=1: one test at a time keeps the run readable and Embree's thread pool
# small. Reachable blocks at exit (TBB's and Embree's global pools, Rust's test harness)
# are not leaks; "possibly lost" ones in TBB's thread start-up are suppressed in
# .ci/valgrind.supp.
valgrind --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect \
    --errors-for-leak-kinds=definite,indirect --suppressions=.ci/valgrind.supp \
    "$bin" --test-threads=1
