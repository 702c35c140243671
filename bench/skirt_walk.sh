#!/usr/bin/env bash
# The garment on a moving character (issue 46 item 3) at full size: scenes/skirt-walk/ (a 2 624-vertex
# cotton skirt on the generated 814-vertex walking body, strain limit, self-contact, friction), run
# directly and progressively with pd simulate; prints the wall time of each run, its Newton
# iterations and each level's seconds, and checks every stored frame of every level with the CGAL
# checker (pd_check_frames; the body's own crossings left out).
#
#   bench/skirt_walk.sh [--frames N] [--work DIR] [--build DIR]
# --frames N: the first N frames (default the scene's 150). Everything goes into --work (default a
# new folder under /tmp).
set -u -o pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
frames="" work="" build="$repo/build"
usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}" >&2; exit 2; }
while (($#)); do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    *) usage ;;
  esac
done
[[ -z "$work" ]] && work=$(mktemp -d /tmp/skirt-walk.XXXXXX)
mkdir -p "$work"
scene="$repo/scenes/skirt-walk/skirt-walk.json"
extra=()
[[ -n "$frames" ]] && extra=(--frames "$frames")
for mode in direct progressive; do
  start=$(date +%s.%N)
  "$build/client/pd" simulate "$scene" --mode "$mode" "${extra[@]}" --quiet --out "$work/$mode.h5" \
    > "$work/$mode.log" 2>&1
  rc=$?
  end=$(date +%s.%N)
  printf '%s: exit %d, %.1f s wall\n' "$mode" "$rc" "$(echo "$end - $start" | bc)"
  tail -n 5 "$work/$mode.log"
  "$build/tests/pd_check_frames" "$work/$mode.h5" | tail -n 1
done
echo "frame files and logs: $work"
