"""The registered methods: RECENT, its variants and ablations, and the baselines.

Importing this package registers every method; adding one means adding a module here that
registers a :class:`Method` subclass, and importing it below.
"""

from lerobot_policy_recent.recent_plugin.methods import baselines, recent  # noqa: F401  (registers the methods)
from lerobot_policy_recent.recent_plugin.methods.base import Adaptation, Grounding, Method, method_named

__all__ = ["Adaptation", "Grounding", "Method", "method_named", "methods_of"]


def methods_of(family: str) -> tuple[str, ...]:
    """The registered method names of one family (``ablation``, ``baseline``, ...), in registration order."""
    return tuple(name for name, cls in Method.get_known_choices().items() if cls.family == family)
