#!/usr/bin/env bash
# The whole test suite, from a fresh clone: sets up what it needs, then pytest.
#   bash scripts/test.sh [pytest args]
# On 2 pytest-xdist workers when the machine has 2 cores or more (whole test files each, module
# fixtures set up once, longest files first); DTC_TEST_WORKERS=N sets the number, 0 runs serially.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
WORKERS="${DTC_TEST_WORKERS:-$(( $(nproc) >= 2 ? 2 : 0 ))}"
[[ "$WORKERS" =~ ^[0-9]+$ ]] || { echo "DTC_TEST_WORKERS must be a number of workers, got '$WORKERS'" >&2; exit 2; }
bash scripts/setup.sh
# Foxglove's JavaScript bag readers for test/test_viewer_bags.py (pinned in test/js/package-lock.json)
if [ ! -d test/js/node_modules ] && command -v npm >/dev/null 2>&1; then
  (cd test/js && npm ci --no-audit --no-fund --loglevel=error)
fi
# shellcheck disable=SC1091
source scripts/env.sh
if [ "$WORKERS" -gt 0 ]; then
  exec python -m pytest -n "$WORKERS" --dist loadfile --no-loadscope-reorder "$@"
fi
exec python -m pytest "$@"
