#!/usr/bin/env bash
# One fuzz target's CI smoke (called by `make fuzz-smoke`, from fuzz/):
#   smoke-one.sh TARGET WORKDIR SECONDS TIMEOUT
# Runs TARGET for SECONDS on its committed seeds in a throw-away corpus
# under WORKDIR, with libFuzzer's random seed FUZZ_SEED when it is set (the
# CI smoke fixes it, so a failure there replays with the same mutations).
# On success prints libFuzzer's final statistics; on failure the panic or
# sanitizer report and cargo-fuzz's account of the failing input (its Debug
# form and the command that reproduces it), then fails. The targets that
# read files write them under TMPDIR, which points inside WORKDIR: libFuzzer
# exits without running destructors, so they cannot clean up after
# themselves.
set -uo pipefail
target=$1 work=$2 seconds=$3 timeout=$4
mkdir -p "$work/$target" "$work/$target.tmp"
export TMPDIR="$work/$target.tmp"
log="$work/$target.log"
if "${CARGO:-cargo}" +nightly fuzz run "$target" "$work/$target" "seeds/$target" -- \
	-max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb=4096 \
	-print_final_stats=1 ${FUZZ_SEED:+"-seed=$FUZZ_SEED"} >"$log" 2>&1; then
	echo "fuzz smoke: $target ok"
	grep -E '^(Done|stat::(number_of_executed_units|new_units_added))' "$log"
	exit 0
fi
echo "fuzz smoke: $target FAILED"
# The report: the panic message or sanitizer error, then the failing input.
grep -v -E '^("|#[0-9]|	NEW_FUNC)' "$log" | grep -m 1 -A 8 -E 'panicked|ERROR:' || true
sed -n '/Failing input:/,$p' "$log" | head -n 80
tail -n 5 "$log"
exit 1
