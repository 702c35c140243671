#!/usr/bin/env bash
# Wall times of pd simulate runs taken in turn, for ratios measured in one session (issue 16): this
# machine's speed drifts by 15 % or more within minutes, so two binaries or two modes are only
# compared run against neighbouring run.
# Usage:
#   bench/alternate_runs.sh binaries OLD_PD NEW_PD ROUNDS -- SIMULATE_ARGS...
#       OLD_PD and NEW_PD in turn with the same arguments ("old 2.81" / "new 2.59" lines);
#   bench/alternate_runs.sh preview PD ROUNDS -- SCENE.json [SIMULATE_ARGS...]
#       the preview (--preview-only) and direct level 0 (--mode direct --level 0) of one scene in
#       turn, with their ratio ("preview 2.59 direct 0.75 ratio 3.44" lines).
# Each run writes to a temporary file that is removed at the end; add --frames and --threads to
# SIMULATE_ARGS (pd's defaults otherwise). A run that fails stops the script with its log.
set -euo pipefail
usage() { sed -n '5,12p' "$0" >&2; exit 2; }
[ $# -ge 1 ] || usage
mode=$1; shift
case $mode in
  binaries) [ $# -ge 4 ] && [ "$4" = "--" ] || usage; old=$1 new=$2 rounds=$3; shift 4 ;;
  preview) [ $# -ge 4 ] && [ "$3" = "--" ] || usage; pd=$1 rounds=$2; shift 3 ;;
  *) usage ;;
esac
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "alternate_runs.sh: ROUNDS must be a positive integer, got '$rounds'" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# timed NAME PD ARGS...: runs pd simulate, prints its wall time in seconds.
timed() {
  local name=$1 bin=$2; shift 2
  local start end
  start=$(date +%s.%N)
  if ! "$bin" simulate "$@" --force --out "$tmp/$name.h5" >"$tmp/$name.log" 2>&1; then
    echo "alternate_runs.sh: $bin simulate $* failed:" >&2; cat "$tmp/$name.log" >&2; exit 1
  fi
  end=$(date +%s.%N)
  awk -v a="$start" -v b="$end" 'BEGIN {printf "%.2f", b - a}'
}

for _ in $(seq "$rounds"); do
  if [ "$mode" = binaries ]; then
    o=$(timed old "$old" "$@")
    echo "old $o"
    n=$(timed new "$new" "$@")
    echo "new $n"
  else
    p=$(timed preview "$pd" "$@" --preview-only)
    d=$(timed direct "$pd" "$@" --mode direct --level 0)
    awk -v p="$p" -v d="$d" 'BEGIN {printf "preview %.2f direct %.2f ratio %.2f\n", p, d, p / d}'
  fi
done
