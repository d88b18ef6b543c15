#!/usr/bin/env bash
# Runs one libFuzzer target over a fresh copy of its seed corpus (the ctest `fuzz` label).
#   run_fuzzer.sh FUZZER SEED_CORPUS_DIR WORK_DIR [libFuzzer flags...]
# WORK_DIR/corpus receives the copy (and what the run adds); crash inputs go to WORK_DIR/.
# Exit status: libFuzzer's (0 = no crash within the time given by -max_total_time).
set -euo pipefail
fuzzer=$1 seeds=$2 work=$3
shift 3
rm -rf "$work/corpus"
mkdir -p "$work/corpus"
cp -r "$seeds/." "$work/corpus/"
exec "$fuzzer" "$work/corpus" -artifact_prefix="$work/" -print_final_stats=1 "$@"
