"""Test doubles for the LM: fixed completions exercise control flow deterministically.

The real LM path is tested with the 1.5B GGUF elsewhere; these drive retries, repairs and failure
categories whose outcome must not depend on what a model happens to write.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, RefactoringUnit, cut_unit


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


def sweep_unit(code: str, before: str, target, sweep: str, observation: str, attempt: int = 0) -> RefactoringUnit:
    """The in-situ unit a ``target_clear`` check cuts: an empty span right before the statement
    ``before`` (found in ``code``), whose hints ask for ``sweep`` first."""
    start = code.index(before)
    line = code[start : code.index("\n", start)]
    hints = Hints(
        target=target,
        original_call=line,
        substitute_call=sweep,
        reason=f"push it off first: {sweep}",
        observation=observation,
        feedback="the patch must call another primitive" if attempt else None,
        attempt=attempt,
    )
    return cut_unit(code, start, start, "in_situ_revision", hints)


def library_with(tmp_path, name: str, code: str) -> str:
    """A copy of the bundled library where skill ``name`` runs ``code`` (same metadata, same effects)."""
    import shutil

    from lerobot_policy_recent.skills.records import LIBRARY

    library = tmp_path / "library"
    shutil.copytree(LIBRARY, library)
    (library / f"{name}.py").write_text(code)
    return str(library)
