#!/usr/bin/env bash
# The speed-against-error report (docs/report/README.md and its PNGs) in one command.
#
#   bench/report/make_report.sh [--quick] [--out DIR] [--scenes a,b] [--frames N] [--work DIR]
#                               [--pd PATH] [--k-scenes a,b] [--k-frames N] [--plan-shots a,b]
#                               [--plan-frames N] [--keep-going] [--allow-missing-compare]
#
# For each scene (default: every scenes/*.json) it runs, one pd process at a time so that each
# cost is that of one core (pd sets OMP_THREAD_LIMIT=1 itself, util/process_setup.h):
#   1. the reference: direct simulation of the finest level of a copy of the scene whose
#      solver.tolerance is 100x smaller (pd simulate --mode direct --level L);
#   2. the progressive run (pd simulate --mode progressive: every level);
#   3. a direct run of each level's mesh (pd simulate --mode direct --level l, l = 0..L);
# each timed (wall seconds of the pd call; the frame files also hold each frame's solve_seconds),
# then pd compare REF.h5 OTHER.h5 --json for the progressive and every direct run. For the
# K scenes (default flag, cube-trampoline and drape-gear) it runs the farm job for K = 1, 2, 4, 8
# (pd run --workers 2 --subsets K, seams stitched as pd's default), times it, and compares each
# against K = 1 with pd compare K1.h5 KK.h5 --seams <every seam and stitch junction, read from the
# job's task store by bench/farm_seams.py> --json. For the plan shots (default bench/scenes'
# flag-large-10s, drape-25k, cube-trampoline-large-3s) it runs their first --plan-frames frames
# (default 8) progressively and asks pd plan for the whole shot at K = 1, 8, 16, 64, 128 on 1, 8, 16,
# 64 and 128 workers (plans/SHOT-KK.json): the page's scaling predictions.
# Finally bench/report/plots.py (Debian's /usr/bin/python3 with python3-matplotlib and
# python3-h5py) writes the PNGs and the page into --out.
#
# --quick (CI): two small scenes, 10 frames, K = 1, 2, no plan shots; under 3 minutes on one core.
# --plan-shots none: no plan shots.
# --scenes none: no scene runs, only the farm runs of --k-scenes.
# --frames N: at most N frames per scene (a scene with fewer keeps its own count).
# --work DIR: where frame files, JSON and logs go (kept); default a temporary folder, removed.
# --keep-going: a failed pd call is recorded and the report goes on without it.
# --allow-missing-compare: a failed pd compare --json is recorded and the page is made without it
#   (its cost-vs-error and seam-jitter plots are then left out and say so).
# Exit status: 0 when every run and the page were made; 1 when a run failed; 2 on a bad command line.
set -u -o pipefail
command_line=$(printf '%q ' "$0" "$@")  # recorded in the work folder, shown on the page

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
python=/usr/bin/python3  # Debian's: its matplotlib and h5py (not a pyenv python on PATH)

out="$repo/docs/report" scenes="" frames="" work="" pd="${PD:-$repo/build/client/pd}" quick=0
k_scenes="flag,cube-trampoline,drape-gear" k_frames="" k_values="1 2 4 8" keep_going=0 allow_missing_compare=0
plan_shots="flag-large-10s,drape-25k,cube-trampoline-large-3s" plan_frames=8 farm_store=""
usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}" >&2; exit 2; }
while (($#)); do
  case "$1" in
    --quick) quick=1 ;;
    --out) out=${2:?--out needs a folder}; shift ;;
    --scenes) scenes=${2:?--scenes needs a list}; shift ;;
    --frames) frames=${2:?--frames needs a number}; shift ;;
    --work) work=${2:?--work needs a folder}; shift ;;
    --pd) pd=${2:?--pd needs a path}; shift ;;
    --k-scenes) k_scenes=${2?--k-scenes needs a list}; shift ;;
    --k-frames) k_frames=${2:?--k-frames needs a number}; shift ;;
    --plan-shots) plan_shots=${2:?--plan-shots needs a list}; shift ;;
    --plan-frames) plan_frames=${2:?--plan-frames needs a number}; shift ;;
    --keep-going) keep_going=1 ;;
    --allow-missing-compare) allow_missing_compare=1 ;;
    -h|--help) usage ;;
    *) echo "make_report.sh: unknown option $1" >&2; usage ;;
  esac
  shift
done
if ((quick)); then
  # The two cheapest three-level scenes with contact and a strain limit between them.
  scenes=${scenes:-cube-trampoline,flag} frames=${frames:-10} k_values="1 2"
  k_scenes="cube-trampoline,flag" k_frames=${k_frames:-10} plan_shots=none
fi
[[ "$plan_shots" == none ]] && plan_shots=""
for n in "$frames" "$k_frames" "$plan_frames"; do
  [[ -z "$n" || "$n" =~ ^[1-9][0-9]*$ ]] || { echo "make_report.sh: frame counts must be integers >= 1, got '$n'" >&2; exit 2; }
done
[[ -x "$pd" ]] || { echo "make_report.sh: no pd binary at $pd (build it, or give --pd / \$PD)" >&2; exit 2; }
[[ -x "$python" ]] && "$python" -c 'import matplotlib, h5py' 2>/dev/null || {
  echo "make_report.sh: $python lacks matplotlib or h5py (apt-get install python3-matplotlib python3-h5py)" >&2; exit 2; }
if [[ -z "$scenes" ]]; then
  scenes=$(cd "$repo/scenes" && ls -1 *.json | sed 's/\.json$//' | paste -sd, -)
elif [[ "$scenes" == none ]]; then
  scenes=""
fi
if [[ -z "$work" ]]; then
  work=$(mktemp -d /tmp/pd-report.XXXXXX)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work/logs" "$work/scenes" "$work/compare" "$work/farms" "$work/plans" "$out" || exit 1
manifest="$work/runs.tsv"
echo "${command_line% }" >"$work/command.txt"
printf 'id\tscene\tkind\tlevel\tsubsets\tframes\th5\twall_s\tstatus\tcompare_json\n' >"$manifest"
failed=0
log() { printf '[%s] %s\n' "$(date +%H:%M:%S)" "$*" >&2; }

# fail MESSAGE: a run failed; stop unless --keep-going.
fail() {
  log "FAILED: $*"
  failed=1
  ((keep_going)) || exit 1
}

# timed ID CMD...: runs one pd call with its output in logs/ID.log; sets $wall to its wall seconds.
timed() {
  local id=${1//\//.}; shift  # file-safe: flag/direct-1 -> flag.direct-1
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >"$work/logs/$id.log" 2>&1
  local rc=$?
  t1=$(date +%s.%N)
  wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
  return $rc
}

# compare ID REF OTHER [--seams LIST]: pd compare ... --json into compare/ID.json; prints its path,
# or "-" when it failed.
compare() {
  local id=${1//\//.} ref=$2 other=$3; shift 3
  local json="$work/compare/$id.json"
  if "$pd" compare "$ref" "$other" --json --csv "$work/compare/$id.csv" "$@" >"$json" 2>"$work/logs/$id.compare.log" &&
     "$python" -c 'import json, sys; json.load(open(sys.argv[1]))' "$json" 2>>"$work/logs/$id.compare.log"; then
    echo "$json"
  else
    log "pd compare --json failed for $id: $(head -c 300 "$work/logs/$id.compare.log")"
    if ((allow_missing_compare)); then echo "-"; else echo "FAIL"; fi
  fi
}

# record ID SCENE KIND LEVEL SUBSETS FRAMES H5 WALL STATUS COMPARE
record() { local IFS=$'\t'; echo "$*" >>"$manifest"; }

# The scene's level count (pd hierarchy --json) and frame count (its file, capped by --frames).
scene_levels() {
  "$pd" hierarchy "$1" --out "$work/$2.hierarchy.h5" --json 2>"$work/logs/$2.hierarchy.log" |
    "$python" -c 'import json, sys; print(len(json.load(sys.stdin)["levels"]))'
}
scene_frames() {
  "$python" - "$1" "$2" <<'EOF'
import json, sys
n = json.load(open(sys.argv[1]))["frames"]
print(min(n, int(sys.argv[2])) if sys.argv[2] else n)
EOF
}

# The reference's scene: a copy with solver.tolerance / 100, its name kept, OBJ paths made absolute
# (relative ones are resolved against the scene's folder, which the copy is not in).
reference_scene() {
  "$python" - "$1" "$2" <<'EOF'
import json, os, sys
src, dst = sys.argv[1], sys.argv[2]
scene = json.load(open(src))
scene.setdefault("name", os.path.splitext(os.path.basename(src))[0])
solver = scene.setdefault("solver", {})
solver["tolerance"] = solver.get("tolerance", 1e-3) / 100.0  # docs/scene-format.md default 1e-3
def absolute_paths(node):
    if isinstance(node, dict):
        if node.get("type") == "obj" and isinstance(node.get("path"), str) and not os.path.isabs(node["path"]):
            node["path"] = os.path.join(os.path.dirname(os.path.abspath(src)), node["path"])
        for v in node.values():
            absolute_paths(v)
    elif isinstance(node, list):
        for v in node:
            absolute_paths(v)
absolute_paths(scene)
json.dump(scene, open(dst, "w"), indent=1)
EOF
}

# Runs one pd call and records it; compares it against REF unless REF is empty. With $farm_store set
# (a farm run's farm.sqlite), the comparison measures the seams and junctions the job had.
run_one() {
  local id=$1 scene=$2 kind=$3 level=$4 subsets=$5 n=$6 h5=$7 ref=$8; shift 8
  local cmp="-" status=ok seams=""
  log "$id: $*"
  if timed "$id" "$@"; then
    [[ -n "$farm_store" ]] && seams=$("$python" "$repo/bench/farm_seams.py" "$farm_store")
    if [[ -n "$ref" ]]; then
      cmp=$(compare "$id" "$ref" "$h5" ${seams:+--seams "$seams"})
      if [[ "$cmp" == FAIL ]]; then
        cmp="-"
        record "$id" "$scene" "$kind" "$level" "$subsets" "$n" "$h5" "$wall" "compare-failed" "$cmp"
        fail "$id: pd compare --json (see $work/logs/${id//\//.}.compare.log)"
        return
      fi
    fi
  else
    status=failed
    fail "$id: $* (see $work/logs/${id//\//.}.log)"
  fi
  log "$id: $status, ${wall} s"
  record "$id" "$scene" "$kind" "$level" "$subsets" "$n" "$h5" "$wall" "$status" "$cmp"
}

log "work folder $work; report into $out; pd $pd"
IFS=, read -r -a scene_list <<<"$scenes"
for name in "${scene_list[@]}"; do
  src="$repo/scenes/$name.json"
  [[ -f "$src" ]] || { fail "$name: no scene file $src"; continue; }
  levels=$(scene_levels "$src" "$name") || { fail "$name: pd hierarchy failed"; continue; }
  n=$(scene_frames "$src" "$frames")
  finest=$((levels - 1))
  ref_scene="$work/scenes/$name.json"
  reference_scene "$src" "$ref_scene" || { fail "$name: cannot write the reference scene"; continue; }
  ref="$work/$name.reference.h5"
  farm_store=""
  run_one "$name/reference" "$name" reference "$finest" 0 "$n" "$ref" "" \
    "$pd" simulate "$ref_scene" --out "$ref" --mode direct --level "$finest" --frames "$n" --quiet --allow-unconverged
  [[ -f "$ref" ]] || continue
  run_one "$name/progressive" "$name" progressive all 0 "$n" "$work/$name.progressive.h5" "$ref" \
    "$pd" simulate "$src" --out "$work/$name.progressive.h5" --mode progressive --frames "$n" --quiet --allow-unconverged
  for ((l = 0; l < levels; ++l)); do
    run_one "$name/direct-$l" "$name" direct "$l" 0 "$n" "$work/$name.direct-$l.h5" "$ref" \
      "$pd" simulate "$src" --out "$work/$name.direct-$l.h5" --mode direct --level "$l" --frames "$n" --quiet --allow-unconverged
  done
done

IFS=, read -r -a k_list <<<"$k_scenes"
for name in "${k_list[@]}"; do
  [[ -n "$name" ]] || continue
  src="$repo/scenes/$name.json"
  [[ -f "$src" ]] || { fail "$name: no scene file $src"; continue; }
  n=$(scene_frames "$src" "${k_frames:-$frames}")
  k1="$work/$name.farm-K1.h5"
  for k in $k_values; do
    h5="$work/$name.farm-K$k.h5"
    ref=""
    ((k > 1)) && ref=$k1
    [[ -n "$ref" && ! -f "$ref" ]] && ref=""
    farm_store="$work/farms/$name-K$k/farm.sqlite"
    rm -rf "$work/farms/$name-K$k"
    run_one "$name/farm-K$k" "$name" farm all "$k" "$n" "$h5" "$ref" \
      "$pd" run "$src" --workers 2 --subsets "$k" --frames "$n" --out "$h5" --keep-farm "$work/farms/$name-K$k"
  done
done
farm_store=""

# The plan shots: a few frames of each for its step costs, then pd plan for the whole shot.
IFS=, read -r -a plan_list <<<"$plan_shots"
for name in "${plan_list[@]}"; do
  [[ -n "$name" ]] || continue
  src="$repo/bench/scenes/$name.json"
  [[ -f "$src" ]] || { fail "$name: no benchmark scene $src"; continue; }
  full=$(scene_frames "$src" "")
  h5="$work/plans/$name.h5"
  log "$name/plan-run: $plan_frames frames of bench/scenes/$name.json"
  if ! timed "$name/plan-run" "$pd" simulate "$src" --out "$h5" --mode progressive --frames "$plan_frames" --quiet \
      --allow-unconverged; then
    fail "$name: pd simulate for its step costs (see $work/logs/$name.plan-run.log)"
    continue
  fi
  for k in 1 8 16 64 128; do
    "$pd" plan "$h5" --frames "$full" --subsets "$k" --workers 1,8,16,64,128 --json >"$work/plans/$name-K$k.json" \
      2>"$work/logs/$name.plan-K$k.log" || fail "$name: pd plan --subsets $k (see $work/logs/$name.plan-K$k.log)"
  done
done

log "plots and page: $python $here/plots.py --work $work --out $out"
"$python" "$here/plots.py" --work "$work" --out "$out" || { log "FAILED: plots.py"; exit 1; }
log "done: $out/README.md"
exit "$failed"
