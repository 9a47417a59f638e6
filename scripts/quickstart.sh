#!/usr/bin/env bash
# README command 1: set everything up, then ground the Panda skill onto a Sawyer (the ontology names
# the object its pick takes, from the point it grasps at) and run it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/recent run --task cube_in_bin --robot Sawyer "$@"
