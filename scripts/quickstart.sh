#!/usr/bin/env bash
# README command 1: set everything up, then ground a user's own Panda skill (examples/skills/put_in_bin.py,
# served in place of the bundled one) onto the Robotiq 2F-85, whose place takes the receptacle's name: no
# one object places the skill's drop point, so the LM decides which object it is, validation holds its
# answer to the role, and the episode runs.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/recent run --task cube_in_bin --robot Robotiq85 --skill_library examples/skills "$@"
