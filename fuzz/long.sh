#!/usr/bin/env bash
# The long runs: each target (all, or those named) for RUNS executions (default 1000000),
# one after the other, with the corpus kept in fuzz/corpus/<target>/ between runs and the
# log in fuzz/logs/<target>.log. A crash, hang or out-of-memory input is written to
# fuzz/artifacts/<target>/ and the next target starts. Prints libFuzzer's final count.
#   fuzz/long.sh [TARGET…]          RUNS=5000000 fuzz/long.sh mesh_ply
set -uo pipefail
cd "$(dirname "$0")"

runs="${RUNS:-1000000}"
flags=(--sanitizer none --codegen-units 16)
cargo fuzz build "${flags[@]}" || exit 1
targets=("$@")
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(cargo fuzz list)
mkdir -p logs
status=0
for target in "${targets[@]}"; do
  mkdir -p "corpus/$target" "artifacts/$target"
  log="logs/$target.log"
  start=$(date +%s)
  cargo fuzz run "${flags[@]}" "$target" "corpus/$target" "seeds/$target" -- \
    -runs="$runs" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 >"$log" 2>&1
  rc=$?
  execs=$(grep -E "^stat::number_of_executed_units" "$log" | tail -n 1 | awk '{print $2}')
  echo "$target: rc $rc, ${execs:-?} executions, $(( $(date +%s) - start )) s"
  if [ "$rc" -ne 0 ]; then
    status=1
    grep -m 3 -E "panicked at|ERROR: libFuzzer|Test unit written" "$log"
  fi
done
exit "$status"
