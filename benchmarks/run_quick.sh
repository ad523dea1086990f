#!/usr/bin/env bash
# The benchmarks' quick mode: every benchmark runs once, in this Python, nothing is saved
# (asv run --quick --dry-run); the cold start skips itself, and the PyElastica ratio where
# PyElastica is not installed. It proves that the suite runs, not how fast: a benchmark
# that raises fails the script (asv's exit code). Usage: bash benchmarks/run_quick.sh [PYTHON]
# (PYTHON: an interpreter with bathprint and asv installed, default python3).
set -euo pipefail
cd "$(dirname "$0")"
python="${1:-python3}"
export BATHPRINT_BENCH_QUICK=1
"$python" -m asv machine --yes >/dev/null
# asv exits non-zero (2) when a benchmark raises
"$python" -m asv run --python=same --quick --dry-run --show-stderr
echo "benchmarks/run_quick.sh: every benchmark ran"
