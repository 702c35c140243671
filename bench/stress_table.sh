#!/usr/bin/env bash
# Regenerates the table of docs/stress.md: runs every scene of scenes/stress/ at full size, direct and
# progressive, into OUT_DIR/<scene>.<mode>.h5 (pd's stderr in <scene>.<mode>.log, its exit code in
# <scene>.<mode>.rc), then prints one Markdown row per frame file (frames, intersecting frames, worst
# energy excess, Newton iterations, unconverged steps, cost). The rows come from the stress test
# binary (tests/scenes/stress_scenes_test.cpp, pd_stress_table), so the table and the CI
# checks share one analysis (no HDF5 tool or Python module is needed).
#
#   bench/stress_table.sh [--build DIR] [--out OUT_DIR] [--jobs N] [--no-run] [SCENE...]
#
# --no-run only re-reads existing frame files. SCENE names (e.g. flag-10s) restrict the run to those.
# Every pd run is bounded by PD_STRESS_TIMEOUT seconds (default 1800): a hang is reported as exit 124.
set -euo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"
build="$here/build"
out="${TMPDIR:-/tmp}/pd_stress"
jobs=1
run=1
scenes=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --no-run) run=0; shift ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    -*) echo "stress_table.sh: unknown option $1" >&2; exit 2 ;;
    *) scenes+=("$1"); shift ;;
  esac
done
if [ ${#scenes[@]} -eq 0 ]; then
  for f in "$here"/scenes/stress/*.json; do scenes+=("$(basename "$f" .json)"); done
fi
pd="$build/client/pd"
tests="$build/tests/pd_stress_table"
for exe in "$pd" "$tests"; do
  [ -x "$exe" ] || { echo "stress_table.sh: $exe not built (cmake --build $build --target pd pd_tests)" >&2; exit 2; }
done
mkdir -p "$out"
timeout_s="${PD_STRESS_TIMEOUT:-1800}"

run_one() {  # scene mode
  local f="$out/$1.$2"
  rm -f "$f.h5"
  local start end rc=0
  start=$(date +%s)
  # /usr/bin/time appends "cpu <user+system seconds>" to the log: the cost on a shared machine, where
  # the frame files' solve_seconds are wall-clock.
  timeout --kill-after=10 "$timeout_s" /usr/bin/time -a -o "$f.log" -f 'cpu %U %S' nice "$pd" simulate \
    "$here/scenes/stress/$1.json" --mode "$2" --allow-unconverged --out "$f.h5" 2> "$f.log" > /dev/null || rc=$?
  end=$(date +%s)
  echo "$rc" > "$f.rc"
  printf '%s %s: exit %d after %d s\n' "$1" "$2" "$rc" "$((end - start))" >&2
}

if [ "$run" = 1 ]; then
  pending=()
  for s in "${scenes[@]}"; do for m in direct progressive; do pending+=("$s $m"); done; done
  for job in "${pending[@]}"; do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    # shellcheck disable=SC2086
    run_one $job &
  done
  wait
fi

files=()
for s in "${scenes[@]}"; do
  for m in direct progressive; do
    f="$out/$s.$m"
    if [ -f "$f.rc" ] && [ "$(cat "$f.rc")" != 0 ]; then
      echo "$s $m: pd exited $(cat "$f.rc"): $(tail -n 2 "$f.log" | tr '\n' ' ')" >&2
    fi
    [ -f "$f.h5" ] && files+=("$f.h5")
    if [ -f "$f.log" ] && grep -q '^cpu ' "$f.log"; then
      awk -v s="$s" -v m="$m" '/^cpu /{printf "%s %s: %.0f s CPU (user + system)\n", s, m, $2 + $3}' "$f.log" >&2
    fi
  done
done
[ ${#files[@]} -gt 0 ] || { echo "stress_table.sh: no frame file in $out" >&2; exit 1; }
list="$(IFS=:; echo "${files[*]}")"
PD_STRESS_TABLE_FILES="$list" "$tests" 2>&1 | sed -n 's/^TABLE //p'
