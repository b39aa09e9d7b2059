#!/usr/bin/env bash
# Build the documentation site: docs/ (MyST Markdown, Sphinx, furo) -> docs/_build/html.
# Warnings are errors (-W --keep-going: every warning is listed, then the build fails); -E
# re-reads every page, so a warning is never hidden by an up-to-date cache.
# The reference pages are generated from the code (docs/_ext/drive_reference.py), so the
# workspace is sourced (run `bash scripts/setup.sh` once first).
#   bash scripts/docs.sh [extra sphinx-build args]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
[ -f install/local_setup.bash ] || { echo "[docs] ERROR: no install/: run bash scripts/setup.sh first" >&2; exit 1; }
# shellcheck disable=SC1091
source scripts/env.sh
exec python -m sphinx -b html -E -W --keep-going -q "$@" docs docs/_build/html
