"""Where RECENT keeps large downloads (models, shard wheels): outside the repository."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """``$RECENT_CACHE_DIR``, else ``$XDG_CACHE_HOME/lerobot_policy_recent``, else ``~/.cache/...``."""
    if env := os.environ.get("RECENT_CACHE_DIR"):
        return Path(env).expanduser()
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")).expanduser()
    return base / "lerobot_policy_recent"
