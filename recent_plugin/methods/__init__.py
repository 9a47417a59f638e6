"""The registered methods: how a skill is grounded and adapted. The policy registers RECENT and its
fast-path variant; the benchmark harness registers the ablations and the baselines
(``lerobot_policy_recent.evaluation``), so the policy never imports them.
"""

from lerobot_policy_recent.recent_plugin.methods import recent  # noqa: F401  (registers RECENT)
from lerobot_policy_recent.recent_plugin.methods.base import Adaptation, Grounding, Method, method_named

__all__ = ["Adaptation", "Grounding", "Method", "method_named", "methods_of"]


def methods_of(family: str) -> tuple[str, ...]:
    """The registered method names of one family (``ablation``, ``baseline``, ...), in registration order."""
    return tuple(name for name, cls in Method.get_known_choices().items() if cls.family == family)
