"""ProgPrompt (``progprompt``): a Pythonic header importing the target's actions, translate the reference."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle, ProgramPrompt
from lerobot_policy_recent.ontology.conversions import api_notes
from lerobot_policy_recent.recent_plugin.methods.base import Method
from lerobot_policy_recent.robosuite_envs.primitives.session import TaskContext


@dataclass(frozen=True)
class PythonicStyle(BaselineStyle):
    """ProgPrompt's header: the actions imported with their parameters, the objects a list."""

    def header(self, prompt: ProgramPrompt) -> str:
        """ProgPrompt: import the target's actions (each with its parameters), list the objects, show
        the source robot's program, and ask for its translation."""
        robot, source = prompt.target.name, prompt.skill.source_embodiment
        module = f"{robot.lower()}_actions"
        lines = [f"from {module} import {p.name}  # {p.signature()}" for p in prompt.target.api.primitives]
        lines.append(f"from scene import task  # {', '.join(f'task.{q}(name)' for q in TaskContext.QUERIES)}")
        lines += [f"# {note}" for note in api_notes(prompt.target.api)]
        lines += ["", f"objects = {[o.split(' ')[0] for o in prompt.context.objects]!r}", ""]
        lines += prompt.api_example_lines()
        lines += [f"# Reference program for the {source} robot:", prompt.example(), ""]
        lines.append(f"# Task: {prompt.context.instruction}")
        lines.append(
            f"# Translate the reference program from {source} actions to the {robot} actions imported above, "
            "keeping its logic:"
        )
        return "\n".join(lines) + "\n"


@Method.register_subclass("progprompt")
@dataclass
class ProgPrompt(Baseline):
    """ProgPrompt as the paper adapts it: a Pythonic header importing the target's actions, the scene's
    objects, the source program as a one-shot example to translate; run as is, regenerated on an error."""

    style: ClassVar[BaselineStyle] = PythonicStyle("progprompt", statement_repairs=0)
