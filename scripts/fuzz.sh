#!/usr/bin/env bash
# Fuzzes vunify's input readers with cargo-fuzz (libFuzzer) on the stable toolchain:
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#
# SECONDS per target (default 60); targets default to all of them: obj ply off gltf vtree camera_path
# script. Installs cargo-fuzz when it is missing. Each target starts from its committed seeds
# (fuzz/seeds/TARGET, made by `cargo run --example fuzz_seeds`) and its own growing corpus
# (fuzz/corpus/TARGET, not committed). A crash stops the run with the input in
# fuzz/artifacts/TARGET/; turn it into a test in tests/fuzz_regressions.rs before fixing it.
# With FUZZ_SUMMARY=FILE, a line per target (executions, seconds) is appended to FILE.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(obj ply off gltf vtree camera_path script)
command -v cargo-fuzz >/dev/null 2>&1 || cargo install cargo-fuzz --locked --quiet
# --sanitizer none: libFuzzer's coverage works on stable Rust; AddressSanitizer needs nightly, and
# the readers are safe Rust, where it would find nothing the panics and limits do not.
cargo fuzz build --sanitizer none
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t"
  log=$(mktemp)
  # -rss_limit_mb: an input that makes a reader allocate beyond this is a finding (no allocation
  # from an unchecked count); -timeout: one that takes this long is a hang.
  # `timeout`: libFuzzer can deadlock reporting a hang found inside an allocation; the run still
  # ends, as a failure.
  if ! timeout --kill-after=10 $((seconds + 120)) \
      cargo fuzz run --sanitizer none "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
      -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
      -max_len=65536 -print_final_stats=1 >"$log" 2>&1; then
    tail -40 "$log"
    echo "scripts/fuzz.sh: $t found a crash; its input is in fuzz/artifacts/$t/" >&2
    rm -f "$log"
    exit 1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
  echo "fuzz $t: $runs inputs in $seconds s, no crash"
  [ -z "${FUZZ_SUMMARY:-}" ] || echo "$t $runs $seconds" >>"$FUZZ_SUMMARY"
  rm -f "$log"
done
