#!/usr/bin/env bash
# deploy.systemd_units: the systemd units of deploy/systemd/ are valid for systemd-analyze, and the
# command lines they give, expanded from a test copy of farm.conf.example, start a farm whose two
# workers register and which stops cleanly on SIGTERM.
#
# Usage: systemd_units_test.sh UNITS_DIR PD PD_SCHEDULER PD_WORKER   (binaries: absolute paths)
#
# This machine runs no systemd manager (no PID 1 systemd), so the units cannot be started for real:
# the ExecStart lines are expanded here the way systemd documents it (systemd.service(5), "Command
# lines"; systemd.exec(5), "EnvironmentFile="): Environment= first, the EnvironmentFile overriding
# it, %-specifiers, ${X} as exactly one argument, $X as a word of its own split at whitespace into
# zero or more arguments. Anything beyond that subset (quotes or backslashes in a command line, $X
# inside a word) fails the test rather than being guessed at.
set -uo pipefail

if [ $# -ne 4 ]; then
  echo "usage: $0 UNITS_DIR PD PD_SCHEDULER PD_WORKER" >&2
  exit 2
fi
UNITS_DIR=$1 PD=$2 SCHEDULER=$3 WORKER=$4
WAIT_WORKERS_S=10   # bound on the two workers showing up in `pd workers`
WAIT_EXIT_S=10      # bound on each process exiting after SIGTERM

fail() { echo "FAIL: $*" >&2; exit 1; }

if ! command -v systemd-analyze >/dev/null; then
  # Not a skip: ctest counts any non-zero exit as a failure. deploy/setup.sh installs systemd.
  fail "systemd-analyze is not installed (package systemd; run deploy/setup.sh)"
fi
for b in "$PD" "$SCHEDULER" "$WORKER"; do [ -x "$b" ] || fail "not an executable: $b"; done

TMP=$(mktemp -d /tmp/pd-systemd-test.XXXXXX) || fail "mktemp"
PIDS=()
cleanup() {
  local pid
  for pid in "${PIDS[@]}"; do kill -TERM "$pid" 2>/dev/null; done
  for pid in "${PIDS[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  done
  rm -rf "$TMP"
}
trap cleanup EXIT

# --- (a) systemd-analyze verify on copies whose ExecStart runs the build's binaries -------------
mkdir -p "$TMP/units"
sed "s#/usr/local/bin/pd-scheduler #$SCHEDULER #" "$UNITS_DIR/pd-scheduler.service" >"$TMP/units/pd-scheduler.service"
sed "s#/usr/local/bin/pd-worker #$WORKER #" "$UNITS_DIR/pd-worker@.service" >"$TMP/units/pd-worker@.service"
grep -q "^ExecStart=$SCHEDULER " "$TMP/units/pd-scheduler.service" || fail "pd-scheduler.service: ExecStart is not /usr/local/bin/pd-scheduler ..."
grep -q "^ExecStart=$WORKER " "$TMP/units/pd-worker@.service" || fail "pd-worker@.service: ExecStart is not /usr/local/bin/pd-worker ..."

# Prints systemd-analyze's lines about the given unit files (their path or unit name, instances of
# the template included) and returns its exit code. Other lines are about the host's own units.
verify_units() {
  local out rc
  out=$(systemd-analyze verify --recursive-errors=no "$@" 2>&1)
  rc=$?
  printf '%s\n' "$out" | grep -E "(^|/)(pd-scheduler\.service|pd-worker@[^ :]*\.service|pd-broken\.service)" || true
  printf '%s\n' "$out" | grep -vE "(^|/)(pd-scheduler\.service|pd-worker@[^ :]*\.service|pd-broken\.service)" |
    sed '/^$/d; s/^/  (host, ignored) /' >&2
  return $rc
}

# The filter must see a unit's own warning: a copy with an unknown setting has to be reported.
{ cat "$TMP/units/pd-scheduler.service"; echo "[Service]"; echo "NoSuchSetting=1"; } >"$TMP/units/pd-broken.service"
broken=$(verify_units "$TMP/units/pd-broken.service")
echo "$broken" | grep -q "NoSuchSetting" || fail "the verify filter missed a warning about pd-broken.service: '$broken'"
rm "$TMP/units/pd-broken.service"

# The template is verified through an instance (the analyzer loads pd-worker@1 from pd-worker@.service).
own=$(verify_units "$TMP/units/pd-scheduler.service" "$TMP/units/pd-worker@1.service")
rc=$?
[ -z "$own" ] || fail "systemd-analyze verify warns about the units: $own"
[ $rc -eq 0 ] || fail "systemd-analyze verify exited $rc"
echo "ok: systemd-analyze verify (systemd $(systemd-analyze --version | sed -n '1s/^systemd \([0-9]*\).*/\1/p')): no warning"

# --- (b) the ExecStart lines expanded with a test farm.conf, run -------------------------------
free_port() {  # a random port in 20000..59999 that nothing listens on
  local p
  for _ in $(seq 20); do
    p=$((20000 + RANDOM % 40000))
    [ -z "$(ss -Htln "sport = :$p" 2>/dev/null)" ] && { echo "$p"; return 0; }
  done
  return 1
}
WPORT=$(free_port) || fail "no free port"
CPORT=$(free_port) || fail "no free port"
[ "$WPORT" != "$CPORT" ] || CPORT=$((WPORT + 1))

# A test copy of the example: every variable set below must be in the example exactly once, so a
# renamed variable fails here instead of silently keeping its old value.
CONF="$TMP/farm.conf"
cp "$UNITS_DIR/farm.conf.example" "$CONF"
set_conf() {  # NAME VALUE: replaces the line NAME=... (the example's one uncommented assignment)
  [ "$(grep -c "^$1=" "$CONF")" -eq 1 ] || fail "farm.conf.example: expected one line $1=..."
  sed -i "s#^$1=.*#$1=$2#" "$CONF"
}
set_conf PD_FARM_DIR "$TMP/farm"
set_conf PD_WORKERS_ENDPOINT "tcp://127.0.0.1:$WPORT"
set_conf PD_CLIENTS_ENDPOINT "tcp://127.0.0.1:$CPORT"
set_conf PD_WORKER_CONNECT "tcp://127.0.0.1:$WPORT"
set_conf PD_SCHEDULER_ARGS '"--heartbeat-ms 200"'   # two words, and quotes the file parser removes
for v in PD_SCHEDULER_KEYS PD_WORKER_KEYS PD_WORKER_ARGS; do   # empty: must add no argument
  grep -qx "$v=" "$CONF" || fail "farm.conf.example: expected $v= (empty) as the default"
done

# Loads the variables of an EnvironmentFile into the associative array ENV (systemd.exec(5)):
# comments (# ;), lines without "=", surrounding whitespace dropped; a value in '' or "" on one line
# loses its quotes. Backslashes and multi-line quotes are outside this expander: fail.
declare -A ENV
load_env_file() {
  local line name value
  while IFS= read -r line || [ -n "$line" ]; do
    line="${line#"${line%%[![:space:]]*}"}"
    case "$line" in ''|'#'*|';'*) continue ;; esac
    [[ "$line" == *=* ]] || continue
    name="${line%%=*}" value="${line#*=}"
    value="${value#"${value%%[![:space:]]*}"}" value="${value%"${value##*[![:space:]]}"}"
    [[ "$value" != *\\* ]] || fail "$1: backslash in $name: not handled by this test's expander"
    if [[ "$value" =~ ^\"(.*)\"$ || "$value" =~ ^\'(.*)\'$ ]]; then value="${BASH_REMATCH[1]}"; fi
    [[ "$value" != *[\"\']* ]] || fail "$1: quotes inside $name: not handled by this test's expander"
    ENV[$name]=$value
  done <"$1"
}

# expand UNIT_FILE INSTANCE: fills ARGV (the ExecStart command line) and ENVS (the Environment=
# and EnvironmentFile= assignments, for env(1)) as systemd would for that unit instance.
expand() {
  local unit=$1 instance=$2 line word value name assignment exec_line="" host
  host=$(uname -n)
  ENV=()
  while IFS= read -r line; do
    case "$line" in
      Environment=*)
        [[ "$line" != *[\"\'\\]* ]] || fail "$unit: quoted Environment= not handled by this test's expander"
        for assignment in ${line#Environment=}; do ENV[${assignment%%=*}]=${assignment#*=}; done ;;
      EnvironmentFile=*)
        [ "${line#EnvironmentFile=}" = /etc/pd/farm.conf ] || fail "$unit: EnvironmentFile is not /etc/pd/farm.conf"
        load_env_file "$CONF" ;;  # the test's copy stands in for /etc/pd/farm.conf
      ExecStart=*) exec_line=${line#ExecStart=} ;;
    esac
  done <"$unit"
  [ -n "$exec_line" ] || fail "$unit: no ExecStart="
  [[ "$exec_line" != *[\"\'\\]* ]] || fail "$unit: quotes in ExecStart not handled by this test's expander"
  # Specifiers: %H the host name, %i the instance, %% a percent sign; any other is not expected.
  exec_line=${exec_line//%%/$'\x01'}
  exec_line=${exec_line//%H/$host}
  exec_line=${exec_line//%i/$instance}
  [[ "$exec_line" != *%* ]] || fail "$unit: a specifier this test does not expand: $exec_line"
  exec_line=${exec_line//$'\x01'/%}
  ARGV=()
  for word in $exec_line; do
    if [[ "$word" =~ ^\$([A-Za-z_][A-Za-z0-9_]*)$ ]]; then
      value=${ENV[${BASH_REMATCH[1]}]-}
      # shellcheck disable=SC2206  # word splitting is the point: zero or more arguments
      ARGV+=($value)
      continue
    fi
    while [[ "$word" =~ \$\{([A-Za-z_][A-Za-z0-9_]*)\} ]]; do
      name=${BASH_REMATCH[1]}
      word=${word//"\${$name}"/${ENV[$name]-}}
    done
    [[ "$word" != *\$* ]] || fail "$unit: '\$' in '$word' is not handled by this test's expander"
    ARGV+=("$word")
  done
  ENVS=()
  for name in "${!ENV[@]}"; do ENVS+=("$name=${ENV[$name]}"); done
}

expand "$TMP/units/pd-scheduler.service" ""
SCHED_ARGV=("${ARGV[@]}") SCHED_ENVS=("${ENVS[@]}")
expected=("$SCHEDULER" --dir "$TMP/farm" --workers-endpoint "tcp://127.0.0.1:$WPORT"
          --clients-endpoint "tcp://127.0.0.1:$CPORT" --heartbeat-ms 200)
[ "${SCHED_ARGV[*]@Q}" = "${expected[*]@Q}" ] || fail "scheduler command line: ${SCHED_ARGV[*]@Q}, expected ${expected[*]@Q}"
echo "ok: scheduler: ${SCHED_ARGV[*]@Q}"

cd "$TMP" || fail "cd $TMP"
env "${SCHED_ENVS[@]}" "${SCHED_ARGV[@]}" >"$TMP/scheduler.out" 2>"$TMP/scheduler.log" &
SCHED_PID=$!
PIDS+=("$SCHED_PID")
for _ in $(seq 50); do grep -q '"event":"listening"' "$TMP/scheduler.out" 2>/dev/null && break; sleep 0.1; done
grep -q '"event":"listening"' "$TMP/scheduler.out" ||
  fail "the scheduler did not start within 5 s: $(cat "$TMP/scheduler.out" "$TMP/scheduler.log")"

HOST=$(uname -n)
WORKER_PIDS=()
mkdir -p "$TMP/var-tmp"
for i in 1 2; do
  expand "$TMP/units/pd-worker@.service" "$i"
  # PrivateTmp= gives each instance a private /var/tmp; outside systemd the test's folder stands in.
  argv=("${ARGV[@]//\/var\/tmp\//$TMP/var-tmp/}")
  expected=("$WORKER" --connect "tcp://127.0.0.1:$WPORT" --name "$HOST-$i" --scratch "$TMP/var-tmp/pd-worker-$i" --threads 1)
  [ "${argv[*]@Q}" = "${expected[*]@Q}" ] || fail "worker $i command line: ${argv[*]@Q}, expected ${expected[*]@Q}"
  echo "ok: worker $i: ${argv[*]@Q}"
  env "${ENVS[@]}" "${argv[@]}" >"$TMP/worker-$i.log" 2>&1 &
  WORKER_PIDS+=($!)
  PIDS+=($!)
done

# One thread per worker: the unit's Environment= reached the process. $! is the pid of `env`, which
# sets the variables and then execs the worker: /proc/PID/environ shows the new environment only
# after that exec, so wait (bounded) until the pid runs the worker binary before reading it.
for pid in "${WORKER_PIDS[@]}"; do
  for _ in $(seq 50); do
    [ "$(readlink "/proc/$pid/exe" 2>/dev/null)" = "$(readlink -f "$WORKER")" ] && break
    sleep 0.1
  done
  [ "$(readlink "/proc/$pid/exe" 2>/dev/null)" = "$(readlink -f "$WORKER")" ] ||
    fail "worker $pid is not running $WORKER after 5 s: $(cat "$TMP"/worker-*.log)"
  for v in OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1; do
    tr '\0' '\n' <"/proc/$pid/environ" | grep -qx "$v" || fail "worker $pid has no $v in its environment"
  done
done

listed=""
deadline=$((SECONDS + WAIT_WORKERS_S))
while [ $SECONDS -lt $deadline ]; do
  # pd prints the JSON indented: removing whitespace makes it one line to grep (names hold none).
  reply=$("$PD" workers --json --farm "tcp://127.0.0.1:$CPORT" 2>/dev/null | tr -d ' \n')
  if [ "$(grep -o '"state":"idle"' <<<"$reply" | wc -l)" -eq 2 ] &&
     grep -q "\"name\":\"$HOST-1\"" <<<"$reply" && grep -q "\"name\":\"$HOST-2\"" <<<"$reply"; then
    listed=$reply
    break
  fi
  sleep 0.2
done
[ -n "$listed" ] || fail "pd workers did not list $HOST-1 and $HOST-2 idle within $WAIT_WORKERS_S s: '${reply:-}'
$(cat "$TMP/scheduler.log" "$TMP"/worker-*.log)"
echo "ok: pd workers lists $HOST-1 and $HOST-2 idle"

# wait_exit PID: waits up to WAIT_EXIT_S for the child PID to end; sets CODE to its exit code, or
# to "timeout". (Not in a $(...) subshell: only this shell can wait for its children.)
wait_exit() {
  local pid=$1
  for _ in $(seq $((WAIT_EXIT_S * 10))); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  if kill -0 "$pid" 2>/dev/null; then CODE=timeout; return; fi
  wait "$pid"
  CODE=$?
}
for pid in "${WORKER_PIDS[@]}" "$SCHED_PID"; do kill -TERM "$pid"; done
for pid in "${WORKER_PIDS[@]}"; do
  wait_exit "$pid"
  [ "$CODE" = 0 ] || fail "worker $pid: exit $CODE after SIGTERM"
done
wait_exit "$SCHED_PID"
[ "$CODE" = 0 ] || fail "pd-scheduler: exit $CODE after SIGTERM (expected 0): $(cat "$TMP/scheduler.log")"
PIDS=()
echo "ok: workers and scheduler exited 0 on SIGTERM"
echo "deploy.systemd_units: passed"
