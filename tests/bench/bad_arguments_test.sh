#!/usr/bin/env bash
# The benchmark programs refuse a bad argument or input file with a message naming it and a non-zero
# exit status below 128: never an abort (134) or another signal. --help exits 0.
#   bad_arguments_test.sh BENCH_DIR SOURCE_DIR
set -u
dir=$1
src=$2
failed=0
checked=0

# refused WORD PROGRAM ARGS...: the run ends with a status in 1..127 and its output contains WORD.
refused() {
  local word=$1 out rc
  shift
  out=$(cd "$src" && timeout 60 "$dir/$@" 2>&1)
  rc=$?
  checked=$((checked + 1))
  if [ "$rc" -eq 0 ] || [ "$rc" -ge 124 ] || [[ "$out" != *"$word"* ]]; then
    echo "FAIL: $* -> status $rc, expected a refusal naming '$word':"
    echo "$out" | head -5
    failed=1
  fi
}

# helps PROGRAM: --help exits 0 with a usage text.
helps() {
  local out rc
  out=$(timeout 60 "$dir/$1" --help 2>&1)
  rc=$?
  checked=$((checked + 1))
  if [ "$rc" -ne 0 ] || [[ "$out" != *"Usage"* ]]; then
    echo "FAIL: $1 --help -> status $rc:"
    echo "$out" | head -5
    failed=1
  fi
}

refused cells pd_bench_step_cost 0
refused cells pd_bench_step_cost abc
refused --threads pd_bench_step_cost --threads 0 5
refused --projection pd_bench_step_cost --projection nope 5
refused /nonexistent.json pd_bench_progressive /nonexistent.json
refused --hessian pd_bench_progressive --hessian nope
refused --frames pd_bench_progressive --frames x
refused --levels pd_bench_progressive --levels 0
refused /nonexistent.json pd_bench_seam_overlap /nonexistent.json --frames 10 --seam 5
refused --overlaps pd_bench_seam_overlap scenes/flag.json --frames 10 --seam 5 --overlaps 1,x
refused --seam pd_bench_seam_overlap scenes/flag.json --frames 10 --seam 9
refused /nonexistent.json pd_bench_seam_stitch /nonexistent.json --frames 100 --seam 30
refused --widths pd_bench_seam_stitch scenes/flag.json --frames 100 --seam 30 --widths 1,x
refused --seam pd_bench_seam_stitch scenes/flag.json --frames 40 --seam 30
refused --bogus pd_bench_hierarchy --bogus
refused usage pd_bench_contact_step --bogus
helps pd_bench_step_cost
helps pd_bench_progressive
helps pd_bench_seam_overlap
helps pd_bench_seam_stitch

echo "$checked cases checked"
exit "$failed"
