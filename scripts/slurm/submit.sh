#!/usr/bin/env bash
# Renders one frame as a Slurm job array of shards, then merges them in a job that runs
# once every shard has succeeded.
#
#   scripts/slurm/submit.sh SCENE.obj --shards N --spp S -o OUT.exr [--dir SHARED_DIR]
#                           [--sbatch-args "ARGS"] [any other `ember render` flags]
#
# Task I of the array runs `ember render --shard I/N -o SHARED_DIR/shard-I-of-N.ember`,
# checkpointing into that file every 60 s (unless --checkpoint-every is given); a task
# that Slurm re-queues finds its file and continues it with --resume. The merge job
# (--dependency=afterok on the array) writes OUT. Prints the two job ids.
#
# Every node must reach, under the same paths: the ember binary ($EMBER, or `ember` on
# PATH), the scene with its MTL and textures, SHARED_DIR (default: OUT's directory,
# subdirectory NAME.shards) and OUT's directory. Uses only sbatch, --array,
# --dependency=afterok, SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT; partition, time
# limit, account etc. come from --sbatch-args or sbatch's own SBATCH_* variables.
set -euo pipefail

die() { echo "submit.sh: error: $*" >&2; exit 2; }
absolute() { [[ $1 = /* ]] && printf '%s' "$1" || printf '%s/%s' "$PWD" "$1"; }

scene="" shards="" spp="" out="" dir="" sbatch_args="" flags=() own_checkpoints=1
while (($#)); do
  case $1 in
    --shards) shards=${2-}; shift 2 || die "--shards needs a number" ;;
    --spp) spp=${2-}; shift 2 || die "--spp needs a number" ;;
    -o|--output) out=${2-}; shift 2 || die "-o needs a file" ;;
    --dir) dir=${2-}; shift 2 || die "--dir needs a directory" ;;
    --sbatch-args) sbatch_args=${2-}; shift 2 || die "--sbatch-args needs a value" ;;
    --shard|--resume|--checkpoint) die "$1 is chosen by submit.sh for each task" ;;
    --checkpoint-every) own_checkpoints=0; flags+=("$1" "${2-}"); shift 2 || die "$1 needs a value" ;;
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) flags+=("$1"); shift ;;
    *) if [[ -z $scene ]]; then scene=$1; else flags+=("$1"); fi; shift ;;
  esac
done
[[ -n $scene ]] || die "no scene given (usage: submit.sh SCENE.obj --shards N --spp S -o OUT.exr)"
[[ -f $scene ]] || die "no scene file $scene"
[[ $shards =~ ^[1-9][0-9]*$ ]] || die "--shards must be a positive whole number, got '${shards}'"
[[ $spp =~ ^[1-9][0-9]*$ ]] || die "--spp must be a positive whole number, got '${spp}'"
[[ -n $out ]] || die "no output given (-o OUT.exr)"
command -v sbatch >/dev/null || die "sbatch not found: run this on a Slurm login node"

ember=${EMBER:-$(command -v ember || true)}
[[ -n $ember && -x $ember ]] || die "no ember binary: put it on PATH or set EMBER=/shared/path/to/ember"
ember=$(absolute "$ember") scene=$(absolute "$scene") out=$(absolute "$out")
name=$(basename "$out"); name=${name%.*}
dir=$(absolute "${dir:-$(dirname "$out")/$name.shards}")
mkdir -p "$dir" || die "cannot create the shard directory $dir"
((own_checkpoints)) && flags+=(--checkpoint-every 60)

part() { printf '%s/shard-%s-of-%s.ember' "$dir" "$1" "$shards"; }

# The task script: fixed arguments quoted once here; the shard number at run time.
task=$dir/render-task.sh
{
  echo '#!/usr/bin/env bash'
  echo 'set -euo pipefail'
  echo 'i=$SLURM_ARRAY_TASK_ID n=${SLURM_ARRAY_TASK_COUNT:-'"$shards"'}'
  printf 'part=%q/shard-$i-of-$n.ember\n' "$dir"
  echo '# A re-queued task continues its own shard file.'
  echo 'resume=(); [[ -f $part ]] && resume=(--resume)'
  printf 'exec %q render %q --spp %q --shard "$i/$n" -o "$part" "${resume[@]}"' "$ember" "$scene" "$spp"
  ((${#flags[@]})) && printf ' %q' "${flags[@]}"
  echo
} >"$task"
merge=$dir/merge-task.sh
{
  echo '#!/usr/bin/env bash'
  printf 'exec %q merge' "$ember"
  for ((i = 0; i < shards; i++)); do printf ' %q' "$(part "$i")"; done
  printf ' -o %q\n' "$out"
} >"$merge"
chmod +x "$task" "$merge"

# shellcheck disable=SC2086 # --sbatch-args is split into words on purpose
array=$(sbatch --parsable --job-name="ember-$name" --array="0-$((shards - 1))" --requeue \
  --output="$dir/shard-%a.log" --open-mode=append $sbatch_args "$task")
array=${array%%;*}
# shellcheck disable=SC2086
merged=$(sbatch --parsable --job-name="ember-merge-$name" --dependency="afterok:$array" \
  --output="$dir/merge.log" $sbatch_args "$merge")
merged=${merged%%;*}
echo "array job $array ($shards shards of $spp spp in $dir), merge job $merged -> $out"
