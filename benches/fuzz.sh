#!/usr/bin/env bash
# Builds and runs every cargo-fuzz target under fuzz/ for MINUTES each
# (docs/results.md, "Fuzzing"): release builds with debug assertions
# and overflow checks on (cargo-fuzz's default), no sanitizer, on a stable
# toolchain through RUSTC_BOOTSTRAP=1. Each target starts from its seeds
# (fuzz/seeds/TARGET, committed) and the corpus earlier runs grew
# (fuzz/corpus/TARGET, gitignored); crash inputs go to
# fuzz/artifacts/TARGET (gitignored), logs to target/fuzz-logs. A crash
# ends that target's run and the next target runs. Prints a table and
# exits non-zero if any target crashed or failed.
# Needs cargo-fuzz: cargo install cargo-fuzz
# Usage: benches/fuzz.sh MINUTES   (whole minutes per target, at least 1)
set -euo pipefail
cd "$(dirname "$0")/.."

usage() {
  echo "usage: benches/fuzz.sh MINUTES   (minutes per fuzz target, a whole number >= 1)" >&2
  exit 2
}
[ $# -eq 1 ] || usage
[[ "$1" =~ ^[0-9]+$ ]] && [ "$1" -ge 1 ] || usage
seconds=$(( $1 * 60 ))

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "benches/fuzz.sh: cargo-fuzz is not installed (cargo install cargo-fuzz)" >&2
  exit 2
fi
export RUSTC_BOOTSTRAP=1
fuzz_args=(--fuzz-dir fuzz -s none)
logs=target/fuzz-logs
mkdir -p "$logs"

mapfile -t targets < <(cargo fuzz list --fuzz-dir fuzz)
[ ${#targets[@]} -gt 0 ] || { echo "benches/fuzz.sh: no fuzz targets under fuzz/" >&2; exit 1; }

# Everything is built first, so that build time does not eat into a
# target's minutes and a build failure shows before any fuzzing.
echo "== building ${targets[*]}"
if ! cargo fuzz build "${fuzz_args[@]}" >"$logs/build.log" 2>&1; then
  tail -30 "$logs/build.log" >&2
  echo "benches/fuzz.sh: build failed (log: $logs/build.log)" >&2
  exit 1
fi

crash_files() {
  find "fuzz/artifacts/$1" -maxdepth 1 -type f \
    \( -name 'crash-*' -o -name 'oom-*' -o -name 'timeout-*' -o -name 'leak-*' \) | sort
}

rows=()
notes=()
failed=0
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t" "fuzz/seeds/$t"
  before=$(crash_files "$t")
  log="$logs/$t.log"
  echo "== $t: ${1} min (log: $log)"
  set +e
  cargo fuzz run "${fuzz_args[@]}" "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
    -max_total_time="$seconds" -print_final_stats=1 >"$log" 2>&1
  status=$?
  set -e
  # Inputs tried: libFuzzer's final stats (-print_final_stats=1), else its
  # last "#N" status line.
  runs=$(grep -oE 'stat::number_of_executed_(units|runs): *[0-9]+' "$log" | tail -1 | grep -oE '[0-9]+$' || true)
  [ -n "$runs" ] || runs=$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#' || true)
  [ -n "$runs" ] || runs="-"
  new=$(comm -13 <(printf '%s\n' "$before") <(crash_files "$t") | grep -c . || true)
  if [ "$new" -gt 0 ] || [ "$status" -ne 0 ]; then
    failed=1
    panic=$(grep -m1 'panicked at' "$log" || grep -m1 'ERROR: libFuzzer' "$log" || echo "exit status $status")
    notes+=("$t: $panic")
    while read -r f; do [ -n "$f" ] && notes+=("  artifact: $f"); done \
      < <(comm -13 <(printf '%s\n' "$before") <(crash_files "$t"))
  fi
  rows+=("$(printf '| %-14s | %14s | %7s | %11s |' "$t" "$runs" "$new" "$status")")
done

echo
echo "fuzzing, ${1} min per target ($(date -u +%Y-%m-%d), $(nproc) cores)"
printf '| %-14s | %14s | %7s | %11s |\n' target "inputs tried" crashes "exit status"
printf '|%s|%s|%s|%s|\n' ---------------- ---------------: --------: ------------:
printf '%s\n' "${rows[@]}"
if [ ${#notes[@]} -gt 0 ]; then
  echo
  printf '%s\n' "${notes[@]}"
  echo "reproduce one: RUSTC_BOOTSTRAP=1 cargo fuzz run --fuzz-dir fuzz -s none TARGET ARTIFACT"
fi
exit $failed
