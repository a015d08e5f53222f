#!/usr/bin/env bash
# Fuzzes OBJ + MTL text through ember's scene loading for SECONDS seconds (default 60)
# on the stable toolchain: tests/fuzz_obj.rs (proptest, grammar-based and byte
# mutations of the Cornell box). The address space is capped so that an input which
# makes ember allocate without bound fails the run instead of swapping the machine.
# Usage: .ci/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
cargo test --release --test fuzz_obj --no-run
# 8 GiB of address space: far more than any input here needs (they are a few KiB), far
# less than "without bound".
ulimit -v $((8 * 1024 * 1024))
RUST_BACKTRACE=0 EMBER_FUZZ_SECONDS="$seconds" cargo test --release --test fuzz_obj -- --nocapture fuzz_obj_text
