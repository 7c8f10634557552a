#!/usr/bin/env bash
# A short run of every fuzz target (FUZZ_SECONDS each, default 5), from the committed seeds:
# keeps the targets compiling and catches a crash on the seeds or close to them. The long runs
# are described in fuzz/README.md. Uses the stable toolchain (cargo-fuzz with `--sanitizer
# none`); skips with a message when cargo-fuzz is missing and cannot be installed.
set -euo pipefail
cd "$(dirname "$0")"

secs="${FUZZ_SECONDS:-5}"
if ! cargo fuzz --version >/dev/null 2>&1; then
  if ! cargo install cargo-fuzz --locked; then
    echo "fuzz/ci.sh skipped: needs cargo-fuzz (cargo install cargo-fuzz --locked failed)"
    exit 0
  fi
fi

# Without a sanitizer the targets build on stable; 16 codegen units build the dependencies
# (burn among them) several times faster, for slightly slower runs.
flags=(--sanitizer none --codegen-units 16)
start=$(date +%s)
cargo fuzz build "${flags[@]}"
echo "fuzz build: $(( $(date +%s) - start )) s"

# New inputs go to a scratch corpus (ignored by git); the seeds are only read.
for target in $(cargo fuzz list); do
  corpus="corpus-ci/$target"
  rm -rf "$corpus"
  mkdir -p "$corpus"
  echo "== $target (${secs} s)"
  log="corpus-ci/$target.log"
  if ! cargo fuzz run "${flags[@]}" "$target" "$corpus" "seeds/$target" -- \
    -max_total_time="$secs" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 >"$log" 2>&1; then
    tail -n 60 "$log"
    echo "fuzz/ci.sh: $target failed (input under fuzz/artifacts/$target/)"
    exit 1
  fi
  grep -E "^stat::number_of_executed_units" "$log" || true
done
echo "fuzz/ci.sh: every target ran ${secs} s without a crash ($(( $(date +%s) - start )) s in all)"
