#!/usr/bin/env bash
# pd, except that `pd compare ... --json` is answered by sample_compare.py (rough numbers of the
# agreed JSON shape), for testing the report scripts before the real pd compare --json exists.
#   REAL_PD=build/client/pd tests/report/pd_sample_compare.sh simulate ...
set -u
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
: "${REAL_PD:?REAL_PD must name the real pd binary}"
if [[ "${1:-}" == compare ]] && printf '%s\n' "$@" | grep -qx -- --json; then
  shift
  exec /usr/bin/python3 "$here/sample_compare.py" "$@"
fi
exec "$REAL_PD" "$@"
