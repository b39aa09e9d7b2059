#!/usr/bin/env bash
# The whole test suite, from a fresh clone: sets up what it needs, then pytest.
#   bash scripts/test.sh [pytest args]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
# shellcheck disable=SC1091
source scripts/env.sh
exec python -m pytest "$@"
