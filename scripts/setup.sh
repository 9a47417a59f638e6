#!/usr/bin/env bash
# Set up RECENT on a fresh machine: system GL for headless rendering, uv, the locked environment,
# and the default offline code LM. Idempotent: a second run reuses every cache.
#   RECENT_CACHE_DIR   where models and shard wheels go (default ~/.cache/lerobot_policy_recent)
#   UV_CACHE_DIR       uv's cache, incl. the llama-cpp-python wheel built from source (~25 min once)
# llama.cpp is built with run-time-selected CPU kernels (pyproject.toml, docs/llm_runtime.md), so the
# cached wheel runs on any x86-64 host; setup still proves the LM works here before it says "ready".
set -euo pipefail
cd "$(dirname "$0")/.."

log() { printf '\033[1m[setup]\033[0m %s\n' "$*"; }

# MuJoCo renders offscreen through OSMesa on machines without a GPU (lerobot-eval records videos).
if ! ldconfig -p 2>/dev/null | grep -q libOSMesa; then
  if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    log "installing libosmesa6 for headless rendering"
    apt-get install -y -q libosmesa6 >/dev/null 2>&1 || { apt-get update -q >/dev/null && apt-get install -y -q libosmesa6 >/dev/null; }
  else
    log "warning: libOSMesa not found; install libosmesa6 (or set MUJOCO_GL=egl) to render videos"
  fi
fi

# LeRobot decodes dataset videos with torchcodec, which needs FFmpeg's shared libraries; without them
# every LeRobotDataset load prints a loading traceback before falling back to pyav.
if ! ldconfig -p 2>/dev/null | grep -q 'libavutil\.so'; then
  if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    log "installing FFmpeg's libraries for LeRobot's video decoder (torchcodec)"
    apt-get install -y -q --no-install-recommends ffmpeg >/dev/null 2>&1 \
      || { apt-get update -q >/dev/null && apt-get install -y -q --no-install-recommends ffmpeg >/dev/null; }
  else
    log "warning: FFmpeg's libraries not found; install ffmpeg so LeRobot's torchcodec decoder loads"
  fi
fi

PYTHON=${PYTHON:-python3}
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' 2>/dev/null; then
  for candidate in python3.12 "$HOME/.pyenv/versions/$(cat .python-version)/bin/python"; do
    if command -v "$candidate" >/dev/null 2>&1; then PYTHON=$candidate; break; fi
  done
fi
"$PYTHON" -c 'import sys; assert sys.version_info[:2] == (3, 12), sys.version' \
  || { echo "RECENT needs Python 3.12 (see .python-version)"; exit 1; }

if ! "$PYTHON" -m uv --version >/dev/null 2>&1; then
  log "installing uv"
  "$PYTHON" -m pip install -q --disable-pip-version-check "uv==0.13.8"
fi

log "syncing the locked environment (.venv)"
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc 2>/dev/null || echo 2)}
# Offline first: an online sync may re-validate the llama-cpp-python sdist, which gives it a new
# cache revision and throws away the wheel uv built from it (~11 min to rebuild on 2 cores).
if ! "$PYTHON" -m uv sync --locked --offline --extra bench --python "$PYTHON" >/dev/null 2>&1; then
  "$PYTHON" -m uv sync --locked --extra bench --python "$PYTHON"
fi

# A .venv made before the portable build keeps its llama-cpp-python (same version, so uv leaves it):
# one built for the CPU of whatever host made it. Replace it with the wheel of run-time variants.
if ! .venv/bin/python -c 'import sys; from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import variant_libraries as v; sys.exit(not v())' 2>/dev/null; then
  log "replacing a llama-cpp-python built for one CPU with the portable build"
  "$PYTHON" -m uv sync --locked --extra bench --python "$PYTHON" --reinstall-package llama-cpp-python
fi

log "provisioning the default code LM (Qwen2.5-Coder-1.5B, GGUF)"
.venv/bin/recent model fetch qwen2.5-coder-1.5b --quiet >/dev/null

log "checking the LM runs on this CPU (a worker process fills one known span)"
if ! check=$(.venv/bin/recent model check qwen2.5-coder-1.5b 2>&1); then
  printf '%s\n' "$check" >&2
  log "setup stopped: the code LM does not run correctly here (see above); nothing else is wrong with the install"
  exit 3
fi
log "${check##*$'\n'}"  # the verdict line (llama.cpp's own notes come before it)
log "ready: $(.venv/bin/recent model path qwen2.5-coder-1.5b)"
