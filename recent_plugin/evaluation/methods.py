"""The methods ``recent bench`` compares: the registered :class:`Method` classes, on the same LM backend and model."""

from __future__ import annotations

from dataclasses import replace

from lerobot_policy_recent.recent_plugin.methods import Method, method_named, methods_of
from lerobot_policy_recent.recent_plugin.methods.baselines import Baseline
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

_FAMILY_ORDER = ("recent", "variant", "baseline", "sanity", "ablation")  # how tables list them
METHODS: tuple[str, ...] = tuple(name for family in _FAMILY_ORDER for name in methods_of(family))
BASELINE_METHODS = methods_of("baseline")
# the methods that ground through the ontology (RECENT, its variants and ablations, oracle-rule): rule
# coverage means something for them only (a baseline's program has no span the ontology decides)
ONTOLOGY_METHODS = tuple(n for n in METHODS if not issubclass(Method.get_choice_class(n), Baseline))
ABLATION_METHODS = methods_of("ablation")
# What each ablation is expected to do to RECENT's numbers (the paper's ablation tables).
EXPECTED: dict[str, dict[str, int]] = {name: dict(Method.get_choice_class(name).expected) for name in ABLATION_METHODS}


def parse_methods(text: str) -> list[str]:
    """``recent,cap`` or ``all`` → method names, with a clear error for an unknown one."""
    names = list(METHODS) if text.strip() == "all" else [m.strip() for m in text.split(",") if m.strip()]
    unknown = [m for m in names if m not in METHODS]
    if unknown or not names:
        raise ValueError(f"unknown method(s) {', '.join(unknown) or '(none)'}; choose from: all, {', '.join(METHODS)}")
    return names


def settings_for(method: str, base: RecentSettings) -> RecentSettings:
    """``base`` (LM, budgets) with ``method`` as its method."""
    return replace(base, method=method_named(method))
