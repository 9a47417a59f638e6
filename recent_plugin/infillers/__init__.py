"""Span generators behind one interface (:class:`~lerobot_policy_recent.recent_plugin.infillers.base.Infiller`).

Which one runs is a choice of the settings tree (:mod:`~lerobot_policy_recent.recent_plugin.infillers.configs`).
"""

from __future__ import annotations

from lerobot_policy_recent.recent_plugin.infillers.base import Completion, Infiller
from lerobot_policy_recent.recent_plugin.infillers.configs import InfillerConfig, infiller_config


def make_infiller(backend: str, model: str | None = None, *, seed: int = 0, **fields) -> Infiller:
    """Build the infiller ``backend`` with ``model`` and its other config fields (tests and benchmarks)."""
    return infiller_config(backend, **({"model": model} if model else {}), **fields).build(seed)


__all__ = ["Completion", "Infiller", "InfillerConfig", "infiller_config", "make_infiller"]
