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

# Without a sanitizer the targets build on stable. The smoke build is unoptimised and carries
# no debug info (`[profile.dev]` in Cargo.toml): it compiles the dependency tree (burn among
# them) about three times faster than a release build, and a few seconds per target need no
# fast code. FUZZ_PROFILE=release builds as the long runs do.
flags=(--sanitizer none)
if [ "${FUZZ_PROFILE:-dev}" = dev ]; then
  flags+=(--dev)
fi
start=$(date +%s)
cargo fuzz build "${flags[@]}"
echo "fuzz build: $(( $(date +%s) - start )) s"
# FUZZ_BUILD_ONLY=1: build and stop (CI builds while the other tests run, then runs).
if [ "${FUZZ_BUILD_ONLY:-0}" = 1 ]; then
  exit 0
fi

# The targets run as the programs cargo-fuzz built (what `cargo fuzz run` would start, without
# its build check per target), two at a time: one per core on the CI machine. New inputs go to
# a scratch corpus (ignored by git); the seeds are only read; a crashing input lands in
# artifacts/TARGET/ as with `cargo fuzz run`.
profile_dir=release
if [[ " ${flags[*]} " == *" --dev "* ]]; then
  profile_dir=debug
fi
bin_dir="target/$(rustc -vV | sed -n 's/^host: //p')/$profile_dir"
rm -rf corpus-ci
mkdir -p corpus-ci
run_target() {
  local target="$1"
  mkdir -p "corpus-ci/$target" "artifacts/$target"
  "$bin_dir/$target" "corpus-ci/$target" "seeds/$target" -artifact_prefix="artifacts/$target/" \
    -max_total_time="$secs" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
    >"corpus-ci/$target.log" 2>&1
}
lane() {
  for target in "$@"; do
    run_target "$target" || echo "$target" >>corpus-ci/failed
  done
}
mapfile -t targets < <(cargo fuzz list)
half=$(( (${#targets[@]} + 1) / 2 ))
lane "${targets[@]:0:half}" &
lane "${targets[@]:half}" &
wait
for target in "${targets[@]}"; do
  echo "== $target (${secs} s): $(grep -E "^stat::number_of_executed_units" "corpus-ci/$target.log" || echo "no stats")"
done
if [ -s corpus-ci/failed ]; then
  while read -r target; do
    tail -n 60 "corpus-ci/$target.log" || true
    echo "fuzz/ci.sh: $target failed (input under fuzz/artifacts/$target/)"
  done <corpus-ci/failed
  exit 1
fi
echo "fuzz/ci.sh: ${#targets[@]} targets ran ${secs} s each without a crash ($(( $(date +%s) - start )) s in all)"
