#!/usr/bin/env bash
# Preview cost by prolonged Hessian against direct simulation of the coarsest mesh (issue 16).
# Usage: bench/preview_hessians.sh PD OUT_DIR [FRAMES] [THREADS] [SCENE.json ...]
#   PD: the pd binary; OUT_DIR: where the frame files go (created). Default: 30 frames, 1 thread, the
#   progressive scenes of scenes/ and bench/scenes/.
# Prints one Markdown row per scene: wall time (s, GNU time) and Newton iterations of the direct
# level-0 run and of the preview with each Hessian (lagged, coarse, coarse-first), unconverged steps,
# and the largest vertex distance (m) of the coarse and coarse-first previews from the lagged one
# (pd compare; the three solve the same equations to the same tolerance).
set -euo pipefail
pd=$1 out=$2 frames=${3:-30} threads=${4:-1}
shift $(( $# < 4 ? $# : 4 ))
root=$(cd "$(dirname "$0")/.." && pwd)
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=("$root"/scenes/{flag,basket,ball-drop,drape-gear,cube-trampoline,spin-sphere}.json
                                   "$root"/bench/scenes/{flag-large,cube-trampoline-large}.json)
mkdir -p "$out"

# run NAME ARGS...: "wall its unconverged" of one pd simulate (600 s cap).
run() {
  local name=$1; shift
  local log="$out/$name.log"
  if ! /usr/bin/time -f "WALL %e" -o "$out/$name.time" timeout 600 "$pd" simulate "$@" --frames "$frames" \
       --threads "$threads" --allow-unconverged --force --out "$out/$name.h5" >"$log" 2>&1; then
    echo "failed - -"; return
  fi
  local its unconv
  # The run's total from its closing line; the progress lines carry only their frame's count.
  its=$(grep -o '^[0-9]* Newton iterations$' "$log" | awk '{s += $1} END {print s + 0}')
  unconv=$(grep -o '[0-9]* steps not converged' "$log" | awk '{s += $1} END {print s + 0}')
  echo "$(awk '{print $2}' "$out/$name.time") $its $unconv"
}

# vertex NAME: largest vertex distance of NAME's preview from the lagged one.
vertex() {
  "$pd" compare "$out/$1-lagged.h5" "$out/$1-$2.h5" --csv "$out/$1-$2.csv" 2>/dev/null |
    awk -v f="$1-$2.h5" 'index($1, f) {print $(NF - 1)}'
}

echo "| scene | direct level 0 s (its) | lagged s (its, unconverged) | coarse s (its, unconverged) | coarse-first s (its, unconverged) | lagged / direct | coarse-first / direct | coarse, coarse-first: max vertex m from lagged |"
echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
for s in "${scenes[@]}"; do
  n=$(basename "$s" .json)
  read -r dw di _ <<<"$(run "$n-direct0" "$s" --mode direct --level 0)"
  read -r lw li lu <<<"$(run "$n-lagged" "$s" --mode progressive --preview-only --hessian lagged)"
  read -r cw ci cu <<<"$(run "$n-coarse" "$s" --mode progressive --preview-only --hessian coarse)"
  read -r fw fi fu <<<"$(run "$n-coarse-first" "$s" --mode progressive --preview-only --hessian coarse-first)"
  ratio() { awk -v a="$1" -v b="$2" 'BEGIN {if (b > 0) printf "%.1f", a / b; else print "-"}'; }
  echo "| $n | $dw ($di) | $lw ($li, $lu) | $cw ($ci, $cu) | $fw ($fi, $fu) | $(ratio "$lw" "$dw") | $(ratio "$fw" "$dw") | $(vertex "$n" coarse), $(vertex "$n" coarse-first) |"
done
