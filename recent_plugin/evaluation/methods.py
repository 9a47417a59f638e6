"""The methods ``recent bench`` compares: each is a set of agent settings on the same LM backend and model."""

from __future__ import annotations

from dataclasses import replace

from lerobot_policy_recent.recent_plugin.agent import AgentSettings

METHODS: dict[str, dict[str, object]] = {
    "recent": {},
    "recent+fast-path": {"fast_path": True},
    "cap": {"mode": "cap"},
    "repair": {"mode": "repair"},
    "agentless": {"mode": "agentless"},
    "recent-no-ontology": {"mode": "no-ontology"},
    "recent-name-similarity": {"mode": "name-similarity"},
    "recent-no-insitu": {"insitu": False},
    "recent-full-regen": {"mode": "full-regen"},
    "recent-no-offline-validation": {"offline_validation": False},
}
BASELINE_METHODS = ("cap", "repair", "agentless")
ABLATION_METHODS = tuple(m for m in METHODS if m.startswith("recent-"))  # "recent+…" are variants, not ablations

# What each ablation is expected to do to RECENT's numbers (the paper's ablation tables):
# metric -> +1 (goes up) or -1 (goes down).
EXPECTED: dict[str, dict[str, int]] = {
    "recent-no-ontology": {"sr": -1, "ei": +1},
    "recent-name-similarity": {"sr": -1, "ei": +1},
    "recent-no-insitu": {"sr": -1},
    "recent-full-regen": {"sr": -1, "go": +1},
    "recent-no-offline-validation": {"sr": -1, "go": +1},
}


def parse_methods(text: str) -> list[str]:
    """``recent,cap`` or ``all`` → method names, with a clear error for an unknown one."""
    names = list(METHODS) if text.strip() == "all" else [m.strip() for m in text.split(",") if m.strip()]
    unknown = [m for m in names if m not in METHODS]
    if unknown or not names:
        raise ValueError(f"unknown method(s) {', '.join(unknown) or '(none)'}; choose from: all, {', '.join(METHODS)}")
    return names


def settings_for(method: str, base: AgentSettings) -> AgentSettings:
    """``base`` (backend, model, threads, retries) with what ``method`` changes."""
    return replace(base, **METHODS[method])
