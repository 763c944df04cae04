#!/usr/bin/env bash
# ctest helper: runs a libFuzzer target over its seed corpus (copied, so nothing is written to the source tree) and
# then for N generated inputs. Usage: run_brief.sh TARGET CORPUS_DIR RUNS
set -euo pipefail
target=$1 corpus=$2 runs=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/corpus" "$work/artifacts"
if [ -d "$corpus" ]; then cp -r "$corpus"/. "$work/corpus/"; fi
cd "$work"
"$target" -runs="$runs" -max_total_time=60 -rss_limit_mb=2048 -artifact_prefix="$work/artifacts/" "$work/corpus" 2>&1 | tail -n 30
