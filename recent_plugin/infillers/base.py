"""One interface for every span generator: an LM with FIM, or the ontology's rule renderer."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit


@dataclass(frozen=True)
class Completion:
    text: str
    generated_tokens: int  # counted by the model's own tokenizer
    seconds: float  # wall time of the call
    prompt_tokens: int = 0
    rendered: bool = False  # written by the fast path's renderer: no model call, so no pause
    evaluated_prompt_tokens: int = 0  # the prompt tokens not already in the model's cache (where a backend knows)
    prompt_seconds: float = 0.0  # of ``seconds``: evaluating the prompt (where a backend measures it)
    generation_seconds: float = 0.0  # of ``seconds``: generating the completion
    # What was sent, for the logs: the FIM prompt (``FimPrompt.shown()``), or a program's chat with its
    # system line and instruction (ChatML, or the model's template); empty where a backend has none
    prompt: str = ""
    forced: bool = False  # the grammar admitted this one text: the model was not run (it would have copied it)
    # why the backend writes nothing for this unit, whatever the feedback (the rule backend, where the
    # ontology leaves an argument open): the span is not asked again
    declined: str = ""


class Infiller(Protocol):
    name: str
    model: str
    samples: bool  # decodes from a distribution, so a temperature and a seed apply (an LM; not the rule renderer)

    def infill(self, unit: RefactoringUnit) -> Completion:
        """Return a replacement for ``unit.span`` (one or more statements, without leading indent).

        Backends that ``samples`` also take ``temperature`` and ``seed`` keywords (seeded sampling;
        the default, 0, is greedy); the per-episode wrapper passes them only when sampling."""
        ...

    def count_tokens(self, text: str) -> int:
        """Tokens of ``text`` under this backend's tokenizer (the GO denominator)."""
        ...


def samples(infiller: object) -> bool:
    """Whether ``infiller`` decodes from a distribution (an infiller that does not say, a test
    double or a user's own renderer, is taken as deterministic)."""
    return bool(getattr(infiller, "samples", False))
