"""Dependencies of the optional ``bench`` extra (Ray, matplotlib): the policy runs without them."""

from __future__ import annotations

import importlib
from types import ModuleType

EXTRA = "bench"


def optional(module: str, feature: str) -> ModuleType:
    """Import ``module``, or stop with one line naming ``feature`` and how to install the extra."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        top = module.split(".")[0]
        if error.name != top:
            raise
        raise SystemExit(
            f"{feature} needs {top}, which the optional `{EXTRA}` extra installs: "
            f"`uv sync --extra {EXTRA}` (scripts/setup.sh does) or `pip install 'lerobot_policy_recent[{EXTRA}]'`"
        ) from None


def pyplot(feature: str) -> ModuleType:
    """matplotlib's pyplot on the headless Agg backend (no display where plots are written)."""
    optional("matplotlib", feature).use("Agg")
    return importlib.import_module("matplotlib.pyplot")
