"""Process setup that must happen before robosuite is imported: an OpenGL backend, quiet logs.

robosuite picks its rendering backend from ``MUJOCO_GL`` when it is first imported, so this
module configures the process on import, and every module of this package that loads robosuite
(the simulator is built from them) imports it first. Nothing else in the project does.
"""

from __future__ import annotations

import ctypes.util
import logging
import os
import warnings


def configure_headless_gl() -> str | None:
    """Honour ``MUJOCO_GL`` if set; else prefer OSMesa (software) when present, then EGL."""
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if os.environ.get("DISPLAY"):
        return None
    backend = "osmesa" if ctypes.util.find_library("OSMesa") else "egl"
    os.environ["MUJOCO_GL"] = backend
    os.environ.setdefault("PYOPENGL_PLATFORM", backend)
    return backend


def quiet_robosuite() -> None:
    """Drop robosuite's import-time chatter (missing private macros, optional robots, GR1 IK).

    A logger-level filter survives robosuite configuring its own handlers; set
    ``RECENT_ROBOSUITE_LOGS=1`` to see everything again.
    """
    if os.environ.get("RECENT_ROBOSUITE_LOGS"):
        return
    logging.getLogger("robosuite_logs").addFilter(lambda record: record.levelno >= logging.ERROR)
    warnings.filterwarnings("ignore", message="invalid escape sequence", category=SyntaxWarning)


configure_headless_gl()
quiet_robosuite()
