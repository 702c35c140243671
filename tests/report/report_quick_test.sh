#!/usr/bin/env bash
# ctest report.quick: bench/report/make_report.sh --quick into a temporary folder writes the page,
# every PNG the page links exists and is a valid non-empty PNG, and the runs table has one row per
# pd call the script made (its runs.tsv), every one of them ok.
#   tests/report/report_quick_test.sh PD_BINARY
# Exit 0: passed; 1: failed; 77: skipped (reason printed), e.g. no matplotlib/h5py for /usr/bin/python3.
set -u -o pipefail
pd=${1:?usage: report_quick_test.sh PD_BINARY}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
python=/usr/bin/python3
if ! [[ -x "$python" ]] || ! "$python" -c 'import matplotlib, h5py' 2>/dev/null; then
  echo "SKIP: $python lacks matplotlib or h5py (apt-get install python3-matplotlib python3-h5py; deploy/setup.sh)"
  exit 77
fi
tmp=$(mktemp -d /tmp/pd-report-test.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
failures=0
check() {  # check CONDITION_STATUS MESSAGE
  if [[ "$1" != 0 ]]; then echo "FAIL: $2"; failures=$((failures + 1)); else echo "ok: $2"; fi
}

# Bounded: --quick takes under 3 minutes; timeout signals make_report.sh's whole process group, so
# a pd run farm (scheduler, workers) is stopped with it.
# TMPDIR marks every process the run starts (pd run's farm folder and its scheduler and workers'
# environment), so that what is left over can be found below without touching anyone else's.
mkdir -p "$tmp/tmpdir"
start=$(date +%s)
TMPDIR="$tmp/tmpdir" timeout --kill-after=10 240 bash "$repo/bench/report/make_report.sh" --quick --pd "$pd" --work "$tmp/work" \
  --out "$tmp/page" >"$tmp/make_report.log" 2>&1
rc=$?
echo "make_report.sh --quick: exit $rc after $(($(date +%s) - start)) s"
if [[ $rc != 0 ]]; then
  tail -n 30 "$tmp/make_report.log"
  for f in "$tmp"/work/logs/*.log; do [[ -s "$f" ]] && { echo "--- $f"; tail -n 5 "$f"; }; done 2>/dev/null
fi
check "$rc" "make_report.sh --quick exits 0"
page="$tmp/page/README.md"
[[ -s "$page" ]]; check $? "the page $page exists and is not empty"

if [[ -s "$page" ]]; then
  "$python" "$here/check_page.py" "$page" "$tmp/work/runs.tsv"
  check $? "linked PNGs valid, one table row per run"
fi
# Nothing the report started may outlive it (pd run stops its own farm).
left=""
for pid in $(pgrep -x pd-scheduler; pgrep -x pd-worker; pgrep -x pd); do  # one name each: pgrep -x sees 15 characters
  if tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qxF "TMPDIR=$tmp/tmpdir"; then
    left+=" $pid"
    kill "$pid" 2>/dev/null  # ours (its environment says so): stop it, and fail
  fi
done
[[ -z "$left" ]]; check $? "no process of this test left running${left:+ (stopped:$left)}"
if ((failures)); then
  echo "report.quick: $failures checks failed; make_report.sh log tail:"
  tail -n 15 "$tmp/make_report.log"
  exit 1
fi
echo "report.quick: passed"
