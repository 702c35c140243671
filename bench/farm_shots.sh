#!/usr/bin/env bash
# The production-size shots on the farm (issue 44): for each shot and each K, a farm job on this
# machine (pd run --workers W --subsets K), then
#   - the wall time, per level when its first task was assigned and its last frame stored, each
#     vertical start's cost in seconds and in the level's median steps, and each worker's solve /
#     held / idle time (bench/farm_timeline.py, from the scheduler's log and the job file);
#   - the seams the scheduler placed (its seams_placed event) and the pops of the seams and of the
#     stitches' junctions (the last stitched frame, where the later subset takes over; read from the
#     farm's task store) against the K = 1 run (pd compare K1.h5 KK.h5 --seams ...: visible when
#     > 0.5 and > 1.5x K = 1's);
#   - pd plan's prediction from the K = 1 run's step costs, for the same W and K (to check the model)
#     and for 8, 16, 64 and 128 workers.
#
#   bench/farm_shots.sh [--shots a,b] [--frames N] [--workers W] [--subsets "1 2"] [--stitch S]
#                       [--work DIR] [--pd PATH]
# --stitch S: frames each seam is stitched over (pd run --stitch; default pd's, 10; 0: none).
#
# Shots (bench/scenes/): flag-large-10s (6 161 vertices, 1 000 frames), drape-25k (27 843 vertices,
# 150 frames), cube-trampoline-large-3s (6 617 vertices, 300 frames). At full length they take hours
# on a 2-core machine (the flag's finest level alone is about 10 s a step): --frames N runs the
# first N frames; scenes/*.json shots work too (--shots flag, looked up in scenes/ then bench/scenes/).
# Output: one block per shot on stdout; everything (farm folders, frame files, JSON) in --work.
set -u -o pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
python=/usr/bin/python3
shots="flag-large-10s,drape-25k,cube-trampoline-large-3s" frames="" workers=2 subsets="1 2" stitch=""
work="" pd="${PD:-$repo/build/client/pd}"
usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}" >&2; exit 2; }
while (($#)); do
  case "$1" in
    --shots) shots=${2:?--shots needs a value}; shift 2 ;;
    --frames) frames=${2:?--frames needs a value}; shift 2 ;;
    --workers) workers=${2:?--workers needs a value}; shift 2 ;;
    --subsets) subsets=${2:?--subsets needs a value}; shift 2 ;;
    --stitch) stitch=${2:?--stitch needs a value}; shift 2 ;;
    --work) work=${2:?--work needs a value}; shift 2 ;;
    --pd) pd=${2:?--pd needs a value}; shift 2 ;;
    -h|--help) usage ;;
    *) echo "farm_shots.sh: unknown option '$1'" >&2; usage ;;
  esac
done
[[ "$workers" =~ ^[1-9][0-9]*$ ]] || { echo "farm_shots.sh: --workers: expected a positive integer, got '$workers'" >&2; exit 2; }
[[ -z "$frames" || "$frames" =~ ^[1-9][0-9]*$ ]] || { echo "farm_shots.sh: --frames: expected a positive integer, got '$frames'" >&2; exit 2; }
[[ -z "$stitch" || "$stitch" =~ ^[0-9]+$ ]] || { echo "farm_shots.sh: --stitch: expected a non-negative integer, got '$stitch'" >&2; exit 2; }
for k in $subsets; do
  [[ "$k" =~ ^[1-9][0-9]*$ ]] || { echo "farm_shots.sh: --subsets: expected positive integers, got '$k'" >&2; exit 2; }
done
[ -x "$pd" ] || { echo "farm_shots.sh: --pd: $pd is not an executable (build first)" >&2; exit 2; }
work=${work:-$(mktemp -d /tmp/farm_shots.XXXXXX)}
mkdir -p "$work"

scene_of() {
  for d in "$repo/scenes" "$repo/bench/scenes"; do
    [ -f "$d/$1.json" ] && { echo "$d/$1.json"; return 0; }
  done
  echo "farm_shots.sh: --shots: no scene named '$1' in scenes/ or bench/scenes/" >&2
  return 1
}

status=0
IFS=, read -ra shot_list <<< "$shots"
for shot in "${shot_list[@]}"; do
  scene=$(scene_of "$shot") || exit 2
  echo "== $shot ($scene${frames:+, first $frames frames}), $workers workers"
  for k in $subsets; do
    dir="$work/$shot-K$k"
    rm -rf "$dir" "$dir.h5"
    start=$(date +%s.%N)
    if ! "$pd" run "$scene" --workers "$workers" --subsets "$k" ${frames:+--frames "$frames"} ${stitch:+--stitch "$stitch"} --keep-farm "$dir" \
        --out "$dir.h5" > "$dir.out" 2>&1; then
      echo "K = $k: pd run failed (exit $?), see $dir.out"; status=1; continue
    fi
    echo "K = $k: pd run $(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%.1f", e - s }') s"
    "$python" "$here/farm_timeline.py" "$dir/scheduler.log" "$dir.h5" --json > "$dir.timeline.json" || status=1
    "$python" - "$dir.timeline.json" <<'EOF'
import json, sys
t = json.load(open(sys.argv[1]))
print(f"  job wall {t['wall_s']:.1f} s; per level (first task, last frame, median step s): " +
      "; ".join(f"{l['level']}: {l['first_assigned_s']:.1f}, {l['last_frame_s']:.1f}, {l['median_step_s']:.4g}" for l in t["levels"]))
for v in t["vertical_starts"]:
    print(f"  vertical start level {v['level']} frame {v['frame']}: {v['seconds']:.2f} s = {v['steps']:.1f} steps")
print("  workers (solve / held / idle s): " + "; ".join(f"{w['name']} {w['solve_s']:.1f} / {w['held_s']:.1f} / {w['idle_s']:.1f}" for w in t["workers"]))
EOF
    seams=$(grep '"event":"seams_placed"' "$dir/scheduler.log" | sed -e 's/.*"message":"//' -e 's/".*//' |
            grep -o 'frame [0-9]*' | awk '{ printf "%s%s", sep, $2; sep = "," }')
    # Every frame where a later subset or a stitch's junction takes over, moved seams included.
    starts=$("$python" "$here/farm_seams.py" "$dir/farm.sqlite")
    if [ "$k" -ge 2 ] && [ -n "$seams" ] && [ -f "$work/$shot-K1.h5" ]; then
      echo "  seams placed: $seams; seams and junctions measured: $starts"
      "$pd" compare "$work/$shot-K1.h5" "$dir.h5" --seams "$starts" --csv "$dir.compare.csv" --force 2>/dev/null |
        grep '^seam pop' | sed 's/^/  /' || status=1
    fi
  done
  if [ -f "$work/$shot-K1.h5" ]; then
    full=$("$python" -c 'import json, sys; print(json.load(open(sys.argv[1]))["frames"])' "$scene")
    for k in $subsets; do
      echo "  pd plan, K = $k, the frames run (workers, makespan s, speed-up, preview done s, busy):"
      "$pd" plan "$work/$shot-K1.h5" --subsets "$k" ${stitch:+--stitch "$stitch"} --workers "$workers" | awk '/^ +[0-9]+ +[0-9.]+ / { print "   " $0 }'
    done
    for k in 1 8 16 64 128 256; do
      echo "  pd plan, the whole shot ($full frames), K = $k:"
      "$pd" plan "$work/$shot-K1.h5" --frames "$full" --subsets "$k" ${stitch:+--stitch "$stitch"} --workers "$workers,8,16,64,128" |
        awk '/^ +[0-9]+ +[0-9.]+ / { print "   " $0 }'
    done
  fi
done
echo "work folder: $work"
exit "$status"
