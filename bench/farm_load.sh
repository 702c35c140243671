#!/usr/bin/env bash
# The scheduler under farm-scale load (docs/performance.md, "Farm load"): starts pd-scheduler in a
# temporary folder on port-0 loopback endpoints, runs pd_bench_farm_load against it (simulated
# workers and their jobs, bench/farm_load.cpp), prints the load program's JSON on stdout, stops the
# scheduler. Exit code: the load program's (0: no lease lost, nothing refused, every job done).
#
#   bench/farm_load.sh [--build DIR] [--profile none|perf|syscalls] [--keep] [-- LOAD OPTIONS]
#
#   bench/farm_load.sh                                 # 500 workers, 60 s at 2000 frames/s
#   bench/farm_load.sh -- --rate 150 --seconds 30      # given load options replace the defaults
#   bench/farm_load.sh --profile perf                  # + where the scheduler's CPU goes
#
# --profile perf: perf record (cpu-clock samples, DWARF call graphs) of the scheduler over the
#   measured window; the reports by library and by function go to the run folder and stderr.
# --profile syscalls: perf trace -s of the scheduler over the window: count and wall time of each
#   system call (fsync, pwrite64, fcntl, ...), i.e. where its one thread waits as well as computes.
#   Tracing every call slows the scheduler (counts stay right, times grow); TRACE_EVENTS=fsync,fdatasync
#   in the environment traces those alone, for their wall time undisturbed.
# --keep: keep the run folder (scheduler log, farm.sqlite, job files, profiles); its path is printed.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
build="$here/../build"
profile=none
keep=0
trace_events="${TRACE_EVENTS:-}"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --profile) profile="$2"; shift 2 ;;
    --keep) keep=1; shift ;;
    --) shift; break ;;
    *) echo "farm_load.sh: unknown option $1 (load program options go after --)" >&2; exit 2 ;;
  esac
done
case "$profile" in none|perf|syscalls) ;; *) echo "farm_load.sh: --profile: none, perf or syscalls" >&2; exit 2 ;; esac

scheduler="$build/scheduler/pd-scheduler"
load="$build/bench/pd_bench_farm_load"  # there also when only the tests are built (PD_BUILD_BENCH off)
for b in "$scheduler" "$load"; do
  if [[ ! -x "$b" ]]; then
    echo "farm_load.sh: $b not built (cmake --build $build --target pd-scheduler pd_bench_farm_load)" >&2
    exit 2
  fi
done

# The defaults, each dropped when the caller gives the same option. Jobs of 200 frames, 3 levels,
# K = 4 and 10-frame preview chunks: 29 tasks and 603 frames each, so that the per-job cost (the job
# file) is small beside the per-frame cost.
defaults=(--workers 500 --seconds 60 --rate 2000 --warmup 15 --frames 200 --subsets 4 --preview-chunk 10
          --drain-seconds 120)
args=()
for ((k = 0; k < ${#defaults[@]}; k += 2)); do
  given=0
  for a in "$@"; do [[ "$a" == "${defaults[k]}" ]] && given=1; done
  [[ $given == 1 ]] || args+=("${defaults[k]}" "${defaults[k + 1]}")
done
args+=("$@")
option() {  # the value of option $1 in args
  local k
  for ((k = 0; k < ${#args[@]} - 1; ++k)); do [[ "${args[k]}" == "$1" ]] && { echo "${args[k + 1]}"; return; }; done
}
warmup="$(option --warmup)"
window="$(option --seconds)"

dir="$(mktemp -d "${TMPDIR:-/tmp}/pd-farm-load.XXXXXX")"
scheduler_pid=""
profiler_pid=""
cleanup() {
  [[ -n "$profiler_pid" ]] && kill -INT "$profiler_pid" 2>/dev/null && wait "$profiler_pid" 2>/dev/null || true
  [[ -n "$scheduler_pid" ]] && kill -TERM "$scheduler_pid" 2>/dev/null && wait "$scheduler_pid" 2>/dev/null || true
  if [[ $keep == 1 ]]; then echo "farm_load.sh: kept $dir" >&2; else rm -rf "$dir"; fi
}
trap cleanup EXIT

# SCHEDULER_WRAPPER (environment, optional): a command prefix that execs the scheduler in the same
# process, e.g. "env LD_PRELOAD=/tmp/nofsync.so" for an experiment, or "valgrind --tool=callgrind".
${SCHEDULER_WRAPPER:-} "$scheduler" --dir "$dir/farm" \
  --workers-endpoint tcp://127.0.0.1:0 --clients-endpoint tcp://127.0.0.1:0 >"$dir/scheduler.out" 2>"$dir/scheduler.log" &
scheduler_pid=$!
# Its first stdout line: {"event":"listening","workers":"tcp://...","clients":"tcp://...",...}.
for ((k = 0; k < 200; ++k)); do
  [[ -s "$dir/scheduler.out" ]] && break
  if ! kill -0 "$scheduler_pid" 2>/dev/null; then
    echo "farm_load.sh: pd-scheduler exited:" >&2
    cat "$dir/scheduler.log" >&2
    exit 1
  fi
  sleep 0.05
done
line="$(head -n 1 "$dir/scheduler.out")"
workers_endpoint="$(sed -n 's/.*"workers":"\([^"]*\)".*/\1/p' <<<"$line")"
clients_endpoint="$(sed -n 's/.*"clients":"\([^"]*\)".*/\1/p' <<<"$line")"
if [[ -z "$workers_endpoint" || -z "$clients_endpoint" ]]; then
  echo "farm_load.sh: no listening line from pd-scheduler: '$line'" >&2
  exit 1
fi

"$load" --workers-endpoint "$workers_endpoint" --clients-endpoint "$clients_endpoint" \
  --scheduler-pid "$scheduler_pid" --scheduler-log "$dir/scheduler.log" --rtt-csv "$dir/rtt.csv" "${args[@]}" \
  >"$dir/result.json" &
load_pid=$!

# The profiler covers the measured window (it starts about when the program says "welcomed").
if [[ "$profile" != none ]]; then
  sleep "$warmup"
  if [[ "$profile" == perf ]]; then
    perf record -q -e cpu-clock -F 499 --call-graph dwarf,16384 -p "$scheduler_pid" -o "$dir/perf.data" \
      -- sleep "$window" 2>"$dir/perf.err" &
  else
    perf trace -s ${trace_events:+-e "$trace_events"} -p "$scheduler_pid" -o "$dir/syscalls.txt" -- sleep "$window" \
      2>"$dir/perf.err" &
  fi
  profiler_pid=$!
fi
set +e
wait "$load_pid"
code=$?
set -e
if [[ -n "$profiler_pid" ]]; then
  wait "$profiler_pid" || true
  profiler_pid=""
  if [[ "$profile" == perf ]]; then
    perf report -i "$dir/perf.data" --no-children --sort dso --stdio -g none 2>/dev/null | grep -v '^#' | grep -v '^$' \
      >"$dir/perf-by-library.txt" || true
    perf report -i "$dir/perf.data" --children --sort sym --stdio -g none 2>/dev/null | grep -v '^#' | grep -v '^$' \
      | head -n 80 >"$dir/perf-by-function.txt" || true
    echo "---- scheduler CPU by library (perf, the measured window)" >&2
    head -n 12 "$dir/perf-by-library.txt" >&2
    echo "---- by function, callees included (first 40)" >&2
    head -n 40 "$dir/perf-by-function.txt" >&2
  else
    echo "---- scheduler system calls over the window (perf trace -s)" >&2
    # Per thread (the main thread first, then ZeroMQ's I/O thread): its ten costliest calls.
    awk '/events,/ {print; n = 0; next} /^ +[a-z_0-9]+ +[0-9]+ +[0-9]+ +[0-9.]+/ && n++ < 10 {print}' \
      "$dir/syscalls.txt" >&2
  fi
fi
cat "$dir/result.json"
exit "$code"
