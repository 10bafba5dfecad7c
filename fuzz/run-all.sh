#!/usr/bin/env bash
# Runs every fuzz target (or the TARGETs named) for SECONDS (default 20) and prints, per
# target: executions,
# coverage, and the result. Uses the nightly toolchain with AddressSanitizer where
# `cargo +nightly` works (and FUZZ_TOOLCHAIN is not `stable`), else stable with `-s none`.
# Exits non-zero if any target fails.
set -uo pipefail
cd "$(dirname "$0")"
secs=${1:-20}
shift || true
if ! command -v cargo-fuzz >/dev/null 2>&1; then
  cargo install cargo-fuzz --locked || cargo install cargo-fuzz
fi
if [ "${FUZZ_TOOLCHAIN:-}" != stable ] && cargo +nightly --version >/dev/null 2>&1; then
  tc=(+nightly); san=(); mode="nightly, address sanitizer"
else
  tc=(); san=(-s none); mode="stable, no sanitizer"
fi
echo "fuzzing each target for ${secs}s ($mode)"
cargo "${tc[@]}" fuzz build "${san[@]}" >/dev/null 2>&1 || cargo "${tc[@]}" fuzz build "${san[@]}" || exit 1
status=0
printf '%-18s %12s %8s %8s  %s\n' target executions cov ft result
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=($(cargo "${tc[@]}" fuzz list))
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t"
  seeds=()
  [ -d "seeds/$t" ] && seeds=("seeds/$t")
  # A target's own dictionary (TARGET.dict) if it has one, else the text formats' tokens.
  dict=text.dict
  [ -f "$t.dict" ] && dict="$t.dict"
  log=$(mktemp)
  cargo "${tc[@]}" fuzz run "${san[@]}" "$t" "corpus/$t" "${seeds[@]}" -- \
    -max_total_time="$secs" -dict="$dict" -print_final_stats=1 -rss_limit_mb=2048 >"$log" 2>&1
  rc=$?
  execs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' | tail -1)
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+')
  ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+')
  if [ $rc -eq 0 ]; then result=ok; else result="FAILED (exit $rc, log $log)"; status=1; tail -30 "$log"; fi
  printf '%-18s %12s %8s %8s  %s\n' "$t" "${execs:-?}" "${cov:-?}" "${ft:-?}" "$result"
  [ $rc -eq 0 ] && rm -f "$log"
done
exit $status
