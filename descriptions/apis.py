"""Where primitive-API files are: the bundled robot files, then the directories on ``RECENT_ROBOTS``.

An API is named by its file's stem (``ur5e`` is ``ur5e.yaml``); several APIs may share one module
of primitives (each with a file of its own).
"""

from __future__ import annotations

from pathlib import Path

from lerobot_policy_recent.descriptions.embodiments import BUNDLED_DIR, robot_dirs


def spec_dirs() -> list[Path]:
    return [BUNDLED_DIR, *robot_dirs()]


def available_apis() -> list[str]:
    return sorted({p.stem for folder in spec_dirs() for p in folder.glob("*.yaml")})


def api_spec_path(api: str) -> Path:
    for folder in spec_dirs():
        path = folder / f"{api}.yaml"
        if path.is_file():
            return path
    raise KeyError(f"no primitive API {api!r}; known APIs: {', '.join(available_apis())}")
