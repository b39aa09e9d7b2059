#!/usr/bin/env bash
# The suite under load: N fresh-clone `CI=true bash .ci/run` runs in a row (default 3) while
# another clone runs the full suite in a loop on the same machine. One line per run goes to
# WORKDIR/summary; it stops at the first failed CI run. Takes about 20-25 min per CI run on 2 cores.
#   bash scripts/ci_under_load.sh [WORKDIR (default /tmp/ci_under_load)] [REV (default HEAD)] [N]
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
base="${1:-/tmp/ci_under_load}"
rev="$(git -C "$ROOT" rev-parse "${2:-HEAD}")" || exit 2
runs="${3:-3}"
mkdir -p "$base" && rm -rf "$base"/load "$base"/ci_* "$base"/done
echo "rev $rev" > "$base/summary"
git clone -q "$ROOT" "$base/load" && git -C "$base/load" checkout -q "$rev" || exit 2
(
  cd "$base/load" && CI=true bash .ci/run > "$base/load_0.log" 2>&1
  echo "load 0 exit $?" >> "$base/summary"
  n=1
  while [ ! -e "$base/done" ]; do
    bash scripts/test.sh -p no:cacheprovider > "$base/load_$n.log" 2>&1
    echo "load $n exit $? $(tail -1 "$base/load_$n.log")" >> "$base/summary"
    n=$((n + 1))
  done
) &
sleep 30
for i in $(seq 1 "$runs"); do
  d="$base/ci_$i"
  git clone -q "$ROOT" "$d" && git -C "$d" checkout -q "$rev" || exit 2
  start=$(date +%s)
  (cd "$d" && CI=true bash .ci/run > "$base/ci_$i.log" 2>&1)
  rc=$?
  echo "ci $i exit $rc $(( $(date +%s) - start )) s $(grep -E '^=+ .*(passed|failed).* =+$' "$base/ci_$i.log" | tail -1)" >> "$base/summary"
  [ "$rc" -eq 0 ] || break
done
touch "$base/done"
wait
echo finished >> "$base/summary"
cat "$base/summary"
