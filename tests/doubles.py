"""Test doubles for the LM: fixed completions exercise control flow deterministically.

The real LM path is tested with the 1.5B GGUF elsewhere; these drive retries, repairs and failure
categories whose outcome must not depend on what a model happens to write.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot_policy_recent.recent_plugin.infillers.base import Completion


@dataclass
class ScriptedInfiller:
    """Replays ``texts`` in order; every call costs ``tokens`` tokens and 0.01 s; the units asked are kept."""

    texts: list[str]
    tokens: int = 7
    name: str = "scripted"
    model: str = "fixed"
    units: list = field(default_factory=list)

    def infill(self, unit):
        self.units.append(unit)
        return Completion(self.texts.pop(0), generated_tokens=self.tokens, seconds=0.01)

    def count_tokens(self, text):
        return 100
