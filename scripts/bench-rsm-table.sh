#!/usr/bin/env bash
# Benchmark of `repose rsm --table` on large tables (issue 40, item 9): writes
# tables of 5e4, 2e5 and 1e6 distinct rows of three factors in [0, 1] (a
# quadratic response plus unit noise, fixed seed) and times the release
# binary on each. Numbers and their history: docs/performance.md.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --quiet
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
python3 - "$dir" <<'PY'
import random, sys
random.seed(9)
rows = []
for _ in range(1_000_000):
    a, b, c = random.random(), random.random(), random.random()
    y = 30 + 5*a - 3*b + 2*c + 4*a*b - 2*c*c + random.gauss(0, 1)
    rows.append(f"{a:.9f},{b:.9f},{c:.9f},{y:.6f}\n")
for n in (50_000, 200_000, 1_000_000):
    with open(f"{sys.argv[1]}/rows{n}.csv", "w") as f:
        f.write("a,b,c,y\n")
        f.writelines(rows[:n])
PY
for n in 50000 200000 1000000; do
    start=$(date +%s.%N)
    ./target/release/repose rsm --table "$dir/rows$n.csv" --factors a,b,c --response y \
        --ranges a=0:1,b=0:1,c=0:1 --json > /dev/null
    end=$(date +%s.%N)
    printf '%8d rows: %.2f s\n' "$n" "$(echo "$end - $start" | bc)"
done
