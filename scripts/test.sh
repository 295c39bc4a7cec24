#!/usr/bin/env bash
# Install what is missing, build everything (library, CLI, tests, benchmarks)
# and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
# The pinned npm packages of tests/web (glTF-Validator): npm ci when node_modules
# is missing or older than package-lock.json.
lock_sum=$(sha256sum tests/web/package-lock.json | cut -d' ' -f1)
if [ "$(cat tests/web/node_modules/.scanbench-lock 2>/dev/null)" != "$lock_sum" ]; then
  (cd tests/web && npm ci --no-audit --no-fund) && echo "$lock_sum" > tests/web/node_modules/.scanbench-lock
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2
status=0
ctest --test-dir build -j2 --output-on-failure || status=$?
# ctest prints no output of a skipped test: repeat the reasons that script tests give
# on a "SKIPPED: " line (e.g. the Slurm batch test where Slurm cannot run).
grep -h '^SKIPPED: ' build/Testing/Temporary/LastTest.log 2>/dev/null || true
# The libFuzzer harnesses (tests/fuzz) in their clang build folder, build-fuzz: each
# replays its committed corpus and runs a short fixed budget (docs/robustness.md).
scripts/fuzz.sh ci || status=$?
exit "$status"
