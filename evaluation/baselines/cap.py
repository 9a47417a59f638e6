"""Code-as-Policies (``cap``) and its rows: a perfect example (``cap-target-example``), another model
(``cap-distilled``), a served chat model (``cap-llm``)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

from lerobot_policy_recent.evaluation.baselines.base import Baseline, llamacpp_model, target_program
from lerobot_policy_recent.evaluation.baselines.program_prompt import BaselineStyle, ProgramContext, describe_scene
from lerobot_policy_recent.ontology.builder import Ontology
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.methods.base import Method
from lerobot_policy_recent.robosuite_envs.observation import Observation
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec
from lerobot_policy_recent.skills.repository import Skill


@dataclass(frozen=True)
class RawStateStyle(BaselineStyle):
    """CaP-Codex's richer repair input: each object's position and orientation, and the end effector's pose."""

    def scene(self, obs: Observation) -> str:
        return describe_scene(obs, raw=True)


@Method.register_subclass("cap")
@dataclass
class CodeAsPolicies(Baseline):
    """Code-as-Policies, prompted as the original CaP prompts are: in-context examples written in the
    *target's* API (other skills of the library, as the ontology renders them for the target with no
    LM), then the skill's source program (the reference skill the RECENT paper gives every baseline)
    and the task; the whole program, and on a failure the whole program again with the error appended.
    Nothing of the task's own skills is shown in the target's API (that is ``cap-target-example``).
    A target on which the ontology renders few skills completely gets what it renders.
    ``--method.api_examples=0`` shows the source program alone (``cap`` up to 2026-12-01)."""

    style: ClassVar[BaselineStyle] = BaselineStyle("cap", statement_repairs=0)
    api_examples: int = 2


@Method.register_subclass("cap-target-example")
@dataclass
class CodeAsPoliciesTargetExample(CodeAsPolicies):
    """Sanity row: CaP with a perfect example, the skill's program for the *target* robot (the
    ontology's complete rendering, no LM), in place of the other skills' examples. What CaP can do at
    best with this model and protocol. A skill the ontology cannot render completely for the target
    (an argument only an LM can decide) has no such program, and the row refuses it rather than
    showing a different example."""

    family: ClassVar[str] = "sanity"
    style: ClassVar[BaselineStyle] = BaselineStyle("cap-target-example", statement_repairs=0)
    api_examples: int = 0

    def context(
        self, task: TaskSpec | None, skills: tuple[Skill, ...], target: Target, ontology: Ontology, max_retries: int
    ) -> ProgramContext:
        examples = tuple((skill.name, target_program(skill, target, ontology, max_retries)) for skill in skills)
        return replace(super().context(task, skills, target, ontology, max_retries), target_examples=examples)


@Method.register_subclass("cap-distilled")
@dataclass
class CodeAsPoliciesDistilled(CodeAsPolicies):
    """The paper's CaP-CodeV-R1 row: CaP's protocol on another, smaller or distilled model (``model``).

    The paper's CodeV-R1-Distill-Qwen-7B cannot be provisioned offline here; the slot defaults to
    the other model that can, Qwen2.5-Coder-0.5B-Instruct. ``--method.model_name=PATH`` runs any GGUF.
    """

    model_name: str = "qwen2.5-coder-0.5b"  # a known model name (`recent model list`) or a .gguf path

    def model(self, lm: Infiller) -> Infiller:
        return llamacpp_model(self.model_name, getattr(lm, "n_threads", None))


@Method.register_subclass("cap-llm")
@dataclass
class CodeAsPoliciesLLM(CodeAsPolicies):
    """The paper's CaP-Codex row: CaP's protocol on a large served chat model (``--method.base_url``,
    ``--method.model_name``, the key in ``$OPENAI_API_KEY``), with the richer inputs the appendix gives
    it: object positions and orientations, and the error unfiltered, in every repair prompt."""

    style: ClassVar[BaselineStyle] = RawStateStyle("cap-llm", statement_repairs=0)
    base_url: str | None = None  # an OpenAI-compatible server with /v1/chat/completions
    model_name: str = "gpt-5.2-codex"

    def model(self, lm: Infiller) -> Infiller:
        import os

        from lerobot_policy_recent.recent_plugin.infillers.openai_chat import OpenAIChatInfiller

        if not self.base_url:
            raise ValueError("cap-llm needs a served chat model: pass --method.base_url (and --method.model_name)")
        return OpenAIChatInfiller(self.base_url, self.model_name, api_key=os.environ.get("OPENAI_API_KEY"))
