"""Primitive APIs: the modules of primitives the executor binds into skill code.

``api_functions("ur5e")`` returns the callables of the module that ``descriptions/robots/ur5e.yaml``
names (``module:``); the file itself is data the ontology reads (``descriptions/apis.py``).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import sys
from pathlib import Path

from lerobot_policy_recent.descriptions.apis import api_spec_path
from lerobot_policy_recent.descriptions.embodiments import BUNDLED_DIR, read_yaml
from lerobot_policy_recent.robosuite_envs.primitives.session import PrimitiveFailure, RobotSession, TaskContext

__all__ = [
    "PrimitiveFailure",
    "RobotSession",
    "TaskContext",
    "api_functions",
    "module_functions",
]


def api_functions(api: str) -> dict[str, object]:
    """The primitives of the bundled API ``<api>``: those of the module its YAML names (``module:``;
    several embodiments may share one module, each with a YAML of its own)."""
    path = api_spec_path(api)
    spec = read_yaml(path) or {}
    return module_functions(spec.get("module") or f"lerobot_policy_recent.robosuite_envs.primitives.{api}", path.parent)


def import_primitive_module(module_name: str, directory: Path | None = None):
    """Import a primitive module, or fail in one line that names its file: a robot added from files
    (``RECENT_ROBOTS``) brings its own module, whose errors are the user's to fix. ``directory``
    (the robot file's) is where such a module is found."""
    if directory is not None and directory != BUNDLED_DIR and str(directory) not in sys.path:
        sys.path.append(str(directory))
    try:
        return importlib.import_module(module_name)
    except SyntaxError as exc:
        raise ValueError(
            f"{exc.filename}:{exc.lineno}: primitive module {module_name!r} does not parse: {exc.msg}"
        ) from None
    except ModuleNotFoundError as exc:
        if exc.name and (module_name == exc.name or module_name.startswith(exc.name + ".")):
            raise  # the module itself is missing: the caller names the YAML that asked for it
        raise ValueError(f"{_module_file(module_name)}: primitive module {module_name!r}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - whatever the user's module raised, named with its file
        raise ValueError(
            f"{_module_file(module_name)}: primitive module {module_name!r} raised on import: "
            f"{type(exc).__name__}: {exc}"
        ) from None


def _module_file(module_name: str) -> str:
    try:
        spec = importlib.util.find_spec(module_name)
    except (ImportError, ValueError):
        spec = None
    return str(spec.origin) if spec is not None and spec.origin else module_name


def module_functions(module_name: str, directory: Path | None = None) -> dict[str, object]:
    """The primitives of a primitive module (the ``module:`` of its YAML, found beside it in ``directory``):
    its ``__all__`` if it re-exports shared motions, else the public generator functions it defines."""
    module = import_primitive_module(module_name, directory)
    names = getattr(module, "__all__", None) or [
        name
        for name, fn in vars(module).items()
        if inspect.isgeneratorfunction(fn) and fn.__module__ == module.__name__
    ]
    return {name: getattr(module, name) for name in names if not name.startswith("_")}
