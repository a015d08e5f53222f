#!/usr/bin/env bash
# Fuzzes what ember reads for SECONDS seconds in all (default 60), shared equally by
# the fuzz targets tests/fuzz_*.rs, on the stable toolchain (proptest):
#   fuzz_obj           OBJ + MTL text (grammar-based, and byte mutations of the Cornell box)
#   fuzz_mtl_textures  MTL texture statements, their options and damaged image files
#   fuzz_mtl_layouts   MTL files laid out as exporters lay them out, against clean ones
#   fuzz_film_files    shard and checkpoint files (crafted headers, damaged pixels, valid checksums)
#   fuzz_scene_file    scene files (every table's keys and values of every type, transforms at the
#                      edge of f32, instanced scenes on both backends; some through `ember render`)
#   fuzz_ply           PLY meshes (every property and list type, every encoding; damaged bytes,
#                      cuts, huge header counts)
#   fuzz_gltf          glTF and GLB files (JSON values at the edge of f32 and u32, wrong types, node
#                      cycles, broken URIs; GLB bytes and lengths overwritten, files cut short)
#   fuzz_exr           EXR files for `ember denoise` (half/float, every lossless compression, scan
#                      lines and tiles, huge claimed sizes; damaged headers and bytes)
# Each target's test is the function named like it with its fuzz_ prefix. The address
# space is capped so that an input which makes ember allocate without bound fails the
# run instead of swapping the machine.
# Usage: .ci/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
targets=()
for file in tests/fuzz_*.rs; do
  targets+=("$(basename "$file" .rs)")
done
share=$(( (seconds + ${#targets[@]} - 1) / ${#targets[@]} ))
build=()
for target in "${targets[@]}"; do build+=(--test "$target"); done
cargo test --release "${build[@]}" --no-run
# 8 GiB of address space: far more than any input here needs (they are a few KiB), far
# less than "without bound". The memory ember may assume (1 GiB) is far below it, so
# that a size an input claims and the memory check lets through cannot exhaust it.
ulimit -v $((8 * 1024 * 1024))
export EMBER_MEMORY_LIMIT=$((1 << 30))
for target in "${targets[@]}"; do
  echo "== $target for $share s" >&2
  # Only the fuzz_* function of each target (its regressions run with cargo test).
  RUST_BACKTRACE=0 EMBER_FUZZ_SECONDS="$share" cargo test --release --test "$target" -- --nocapture fuzz_
done
