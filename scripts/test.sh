#!/usr/bin/env bash
# README command 2: set everything up, then run the test suite (add --runslow for the full one).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/python -m pytest "$@"
