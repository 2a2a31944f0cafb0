#!/usr/bin/env bash
# Benchmark of `repose runs list` on a large store (issue 42): the ignored
# test `bench_runs_list_on_ten_thousand_runs` in tests/tracking.rs writes a
# store of 10^4 synthetic runs (1 000 frictions x 10 packing seeds, through
# the store's own writer, no simulation; on /dev/shm when it exists) and
# times the release binary listing it plain, with --where and with
# --group-seeds, three times each. Numbers and their history: docs/performance.md.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo test --release --test tracking -- --ignored --nocapture \
    bench_runs_list_on_ten_thousand_runs
