"""The methods ``recent bench`` compares: the registered :class:`Method` classes, on the run's LM backend.

A grid row is a method name, on the run's model, or ``method@model``, the method on another model of
the same backend (``recent bench --models``): each row is a row of every table, never pooled.
"""

from __future__ import annotations

from dataclasses import replace

# Importing a method's module registers it; tables list a family's methods in this order.
# A new baseline is one module in evaluation/baselines/ and one line here (docs/benchmark.md).
# isort: off
from lerobot_policy_recent.evaluation import ablations  # noqa: F401  (RECENT's ablations and oracle-rule)
from lerobot_policy_recent.evaluation.baselines import cap, repair, scot, progprompt, roboinspector, agentless  # noqa: F401

# isort: on
from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.recent_plugin.methods import Method, method_named, methods_of
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


def method_rank(method: str) -> int:
    """A method's place in table order (``METHODS``); one no longer registered goes after all of them."""
    return METHODS.index(method) if method in METHODS else len(METHODS)


ON_MODEL = "@"  # method@model: a grid row running the method on another model


def method_of(row: str) -> str:
    """The registered method a grid row runs (``cap`` of ``cap@qwen2.5-coder-0.5b``)."""
    return row.split(ON_MODEL, 1)[0]


def model_of(row: str) -> str | None:
    """The model a grid row names (None: the run's own ``--infiller.model``)."""
    return row.split(ON_MODEL, 1)[1] if ON_MODEL in row else None


def parse_methods(text: str, models: tuple[str, ...] = (), run_model: str | None = None) -> list[str]:
    """``recent,cap``, ``all`` or ``recent@qwen2.5-coder-0.5b`` → grid rows, with a clear error for an
    unknown method. ``models``: every method on each of them, except a method with a model of its
    own (``cap-distilled``, ``oracle-rule``), which runs once; the run's own model (``run_model``)
    keeps the plain name, so a row is named the same whichever models a run compares."""
    rows = list(METHODS) if text.strip() == "all" else [m.strip() for m in text.split(",") if m.strip()]
    unknown = [m for m in rows if method_of(m) not in METHODS]
    if unknown or not rows:
        raise ValueError(f"unknown method(s) {', '.join(unknown) or '(none)'}; choose from: all, {', '.join(METHODS)}")
    rows = [method_of(r) if model_of(r) == run_model else r for r in rows]  # recent@<the run's model> is recent
    if models:
        named = [r for r in rows if model_of(r) is not None]
        if named:
            raise ValueError(f"--models applies to plain method names; {', '.join(named)} already names a model")
        rows = [
            r if model == run_model or not _on_the_runs_model(r) else f"{r}{ON_MODEL}{model}"
            for r in rows
            for model in models
        ]
    for row in rows:
        model = model_of(row)
        if model is None:
            continue
        if not model:
            raise ValueError(f"{row}: no model after {ON_MODEL!r}")
        if not _on_the_runs_model(method_of(row)):
            raise ValueError(f"{row}: {method_of(row)} runs on a model of its own, so it takes no {ON_MODEL}model")
    return list(dict.fromkeys(rows))


def _on_the_runs_model(method: str) -> bool:
    """Whether ``method`` runs on the run's LM (not on a model of its own, nor on none)."""
    return type(method_named(method)).model is Method.model


def settings_for(row: str, base: RecentSettings) -> RecentSettings:
    """``base`` (LM, budgets) with the row's method as its method, and its model where it names one."""
    settings = replace(base, method=method_named(method_of(row)))
    model = model_of(row)
    if model is None or model == getattr(base.infiller, "model", None):
        return settings
    if not hasattr(base.infiller, "model"):
        raise ValueError(
            f"{row}: a row on another model needs an LM backend, not --infiller.type={base.infiller.backend}"
        )
    return replace(settings, infiller=replace(base.infiller, model=model))
