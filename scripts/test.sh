#!/usr/bin/env bash
# The whole test suite, from a fresh clone: sets up what it needs, then pytest on two
# workers (pytest-xdist), each running whole test files (module fixtures are set up once).
#   bash scripts/test.sh [pytest args]        (-n 0: in this process, one test at a time)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
# Foxglove's JavaScript bag readers for test/test_viewer_bags.py (pinned in test/js/package-lock.json)
if [ ! -d test/js/node_modules ] && command -v npm >/dev/null 2>&1; then
  (cd test/js && npm ci --no-audit --no-fund --loglevel=error)
fi
# shellcheck disable=SC1091
source scripts/env.sh
exec python -m pytest -n 2 --dist loadfile --no-loadscope-reorder "$@"
