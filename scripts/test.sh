#!/usr/bin/env bash
# Runs every check ember has: formatting, lints, the whole test suite against the
# system's Embree (with denoising through the Open Image Denoise that scripts/setup.sh
# provides: tests/denoise.rs), a split render on a one-node Slurm cluster (scripts/slurm/test.sh,
# as root: it installs Debian's munge and slurm packages), a bounded fuzzing run, the
# FFI wrapper under valgrind, and the Embree tests again against Embree 4 (built from
# ../shared/embree4/setup.sh when that rig is beside the repository).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check" >&2
cargo fmt --all -- --check
echo "== cargo clippy" >&2
cargo clippy --release --all-targets --features peers -- -D warnings
echo "== cargo test (system Embree)" >&2
cargo test --release
echo "== Slurm: shards and a merge on a one-node cluster (installs munge and slurm)" >&2
bash scripts/slurm/test.sh
echo "== fuzzing OBJ/MTL, texture statements and film files for ${EMBER_CI_FUZZ_SECONDS:-60} s" >&2
bash .ci/fuzz.sh "${EMBER_CI_FUZZ_SECONDS:-60}"
echo "== Embree wrapper under valgrind" >&2
bash .ci/valgrind.sh

rig=../shared/embree4/setup.sh
if [[ -f $rig ]]; then
  echo "== Embree 4 leg" >&2
  bash "$rig" "$PWD/.embree4" >/dev/null
  EMBREE_DIR="$PWD/.embree4" cargo test --release --test embree_analytic --test embree_wrapper --test accel_agreement \
    --test render --test robustness --test aov --test adaptive --test denoise --test integrators --test determinism \
    --test cutouts --test texture_maps --test untrusted --test instancing
else
  echo "== Embree 4 leg skipped: $rig not found" >&2
fi
