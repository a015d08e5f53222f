#!/bin/bash
# Equal-time efficiency of path guiding: 1 / (relMSE · CPU seconds), guided against
# unguided `mis`, one thread, runs alternating (unguided, guided) per scene and
# repetition so that a shared machine's load falls on both alike. CPU time is the
# process's user + system time (training included for guided runs).
#
#   EMBER=target/release/ember ROOM_DIR=.../grey-white-room ROOM_REF=room.exr \
#   STAIR_DIR=.../wooden-staircase STAIR_REF=stair.exr bash benches/guiding_efficiency.sh
#
# References (not shipped): the room's is a guided ember render at 160x90, 16384 spp
# with the room's flags below, --max-depth 8 --seed 1 --guiding (about 12 minutes on 2
# threads; relMSE about 2.2e-4 of its own). An unguided one of 4096 spp (relMSE about
# 1.8e-3 of its own, an eighth of a guided 256-spp render's error) lowers the room's
# measured gain per sample from 2.0x to 1.9x (README, "A tenth sitting"); the staircase's one at
# 72x128, 16384 spp with the staircase's flags and --seed 7. SCENES (default
# "room stair orig glossy") and REPS (default 2) choose what runs, INTEGRATOR (default
# mis) the estimator both runs use.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
EMBER=${EMBER:-$ROOT/target/release/ember}
REFS=$ROOT/tests/data/references
ROOM=("${ROOM_DIR:-}/living-room.obj" --width 160 --height 90 --env "${ROOM_DIR:-}/textures/Sky 19.exr"
  --env-rotate -90 --fov 58.7155 --eye 5.10518,0.731065,-2.31789 --look-at 4.143388,0.805472,-2.054414
  --up 0.071763,0.997228,-0.019659)
STAIR=("${STAIR_DIR:-}/staircase.obj" --width 72 --height 128 --fov 58.54 --eye 0.0324209,1.52673,4.88197
  --look-at 0.0247749,1.571785,3.883015 --up 0.000344842,0.998984,0.0450537)
BOX=(--width 512 --height 512 --eye 0,1,3.9 --look-at 0,1,0 --fov 40)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

run() { # label reference render-arguments...
  local label=$1 ref=$2
  shift 2
  local cpu rel
  cpu=$( { /usr/bin/time -f "%U %S" "$EMBER" render "$@" --max-depth 8 --threads 1 \
      --integrator "${INTEGRATOR:-mis}" \
      -o "$TMP/out.exr" 2>&1 >/dev/null; } | tail -1 | awk '{print $1 + $2}')
  rel=$("$EMBER" compare "$TMP/out.exr" "$ref" | grep -o 'relMSE [0-9.e+-]*' | cut -d' ' -f2)
  awk -v l="$label" -v r="$rel" -v c="$cpu" -v load="$(cut -d' ' -f1 /proc/loadavg)" \
    'BEGIN { printf "%-12s relMSE %.4g  CPU %6.1f s  efficiency %.4g  (load %s)\n", l, r, c, 1 / (r * c), load }'
}

for rep in $(seq "${REPS:-2}"); do
  seed=$((rep + 10))
  for scene in ${SCENES:-room stair orig glossy}; do
    # Samples per pixel and training iterations: the guided render traces as many
    # paths as the unguided one (training's 2^it - 1 samples are the first of its
    # --spp, `sd-tree 6`; with `sd-tree 5` and before, the guided render took 224 and
    # 56 spp, training coming on top; until 2026-12-03 it took 255 and 63, a path
    # short, and off the power of two the pixels' Sobol sets are best at: 3% more
    # relMSE on the Original). The iterations are those `Guiding::for_spp` gives by
    # default.
    case $scene in
      room) args=("${ROOM[@]}"); ref=$ROOM_REF; spp=256; it=5 ;;
      stair) args=("${STAIR[@]}"); ref=$STAIR_REF; spp=256; it=5 ;;
      orig) args=("$ROOT/meshes/CornellBox-Original.obj" "${BOX[@]}")
            ref=$REFS/cornell-box/cornell_ref_8192spp.exr; spp=64; it=3 ;;
      glossy) args=("$ROOT/meshes/CornellBox-GlossyMix.obj" "${BOX[@]}")
              ref=$REFS/cornell-glossy/CornellBox-GlossyMix_ref_4096spp.exr; spp=64; it=3 ;;
      *) echo "error: unknown scene '$scene' (room, stair, orig, glossy)" >&2; exit 2 ;;
    esac
    run "$scene mis" "$ref" "${args[@]}" --seed $seed --spp $spp
    run "$scene guided" "$ref" "${args[@]}" --seed $seed --spp $spp --guiding --guiding-iterations $it
  done
done
