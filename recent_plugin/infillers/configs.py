"""The infiller choices of the settings tree: ``--infiller.type=llamacpp|transformers|openai|rule``.

Each backend is a registered config class with its own fields, and builds its infiller; the
``recent`` CLI and ``lerobot-eval --policy.infiller.*`` read the same classes.
"""

from __future__ import annotations

from dataclasses import dataclass

import draccus

from lerobot_policy_recent.recent_plugin.infillers.base import Infiller
from lerobot_policy_recent.recent_plugin.infillers.prompt_states import STATE_BUDGET_BYTES
from lerobot_policy_recent.recent_plugin.models.registry import DEFAULT_MODEL
from lerobot_policy_recent.recent_plugin.refactoring.window import WINDOWS


@dataclass
class InfillerConfig(draccus.ChoiceRegistry):
    """What fills a refactoring unit: a code LM, or the ontology's rendering with no LM (``rule``)."""

    @classmethod
    def default_choice_name(cls) -> str:
        return "llamacpp"  # a flag such as ``--infiller.n_threads=2`` alone keeps the default choice

    @property
    def backend(self) -> str:
        return InfillerConfig.get_choice_name(type(self))

    def build(self, seed: int = 0) -> Infiller:
        """Load the LM now (grounding time then measures grounding, not loading)."""
        raise NotImplementedError


@dataclass
class LMConfig(InfillerConfig):
    """What every code-LM backend shares."""

    # How much of a span's enclosing function its FIM prompt shows: ``dataflow`` (what the edit
    # reads and writes) or ``function`` (all of it); docs/llm_runtime.md
    prompt_window: str = "dataflow"

    def __post_init__(self) -> None:
        if self.prompt_window not in WINDOWS:
            raise ValueError(f"unknown prompt_window {self.prompt_window!r}; choose one of: {', '.join(WINDOWS)}")


@InfillerConfig.register_subclass("llamacpp")
@dataclass
class LlamaCppConfig(LMConfig):
    """A GGUF code model on CPU through llama.cpp, in a worker process."""

    model: str = DEFAULT_MODEL  # a known model name (`recent model list`) or a path to a .gguf file
    n_threads: int | None = None  # CPU threads for llama.cpp (None: up to 2)
    prompt_state_mib: int = STATE_BUDGET_BYTES // 2**20  # earlier prompts' KV states kept for reuse (0: none)

    def build(self, seed: int = 0) -> Infiller:
        from lerobot_policy_recent.recent_plugin.infillers.llamacpp import LlamaCppInfiller
        from lerobot_policy_recent.recent_plugin.models import ensure_model

        return LlamaCppInfiller(
            str(ensure_model(self.model)),
            n_threads=self.n_threads,
            seed=seed,
            prompt_window=self.prompt_window,
            state_bytes=self.prompt_state_mib * 2**20,
        )


@InfillerConfig.register_subclass("transformers")
@dataclass
class TransformersConfig(LMConfig):
    """A Hugging Face model: a Hub id, a local model directory, a known name or a GGUF path."""

    model: str = DEFAULT_MODEL  # Hub id, model directory, known name or .gguf path
    device: str | None = None  # cuda or cpu (None: CUDA when available)
    dtype: str = "auto"  # auto, float32, float16 or bfloat16
    quantization: str | None = None  # 8bit or 4bit (CUDA only)
    n_threads: int | None = None  # CPU threads (on the CPU)

    def build(self, seed: int = 0) -> Infiller:
        from lerobot_policy_recent.recent_plugin.infillers.hf_transformers import TransformersInfiller

        return TransformersInfiller(
            self.model,
            device=self.device,
            dtype=self.dtype,
            quantization=self.quantization,
            n_threads=self.n_threads,
            prompt_window=self.prompt_window,
        )


@InfillerConfig.register_subclass("openai")
@dataclass
class OpenAIConfig(LMConfig):
    """An OpenAI-compatible completions server (vLLM, llama.cpp's server, ...)."""

    model: str = DEFAULT_MODEL  # the server's model id
    base_url: str | None = None  # the server, e.g. http://127.0.0.1:8000

    def build(self, seed: int = 0) -> Infiller:
        from lerobot_policy_recent.recent_plugin.infillers.openai_compat import OpenAICompatInfiller

        if not self.base_url:
            raise ValueError(
                "the openai infiller needs a server: pass --infiller.base_url (e.g. http://127.0.0.1:8000)"
            )
        return OpenAICompatInfiller(self.base_url, self.model, prompt_window=self.prompt_window)


@InfillerConfig.register_subclass("rule")
@dataclass
class RuleConfig(InfillerConfig):
    """No LM: the ontology's rendering of each span (undecided values stay unfilled)."""

    def build(self, seed: int = 0) -> Infiller:
        from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller

        return RuleInfiller()


def infiller_config(backend: str, **fields) -> InfillerConfig:
    """The config of ``backend`` with ``fields``, with a clear error for an unknown backend or field."""
    known = InfillerConfig.get_known_choices()
    if backend not in known:
        raise ValueError(f"unknown infiller {backend!r}; choose one of: {', '.join(known)}")
    try:
        return known[backend](**fields)
    except TypeError as error:
        raise ValueError(f"infiller {backend!r}: {error}") from None
