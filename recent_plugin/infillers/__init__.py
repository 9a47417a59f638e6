"""Span generators behind one interface (:class:`~lerobot_policy_recent.recent_plugin.infillers.base.Infiller`)."""

from __future__ import annotations

from lerobot_policy_recent.recent_plugin.infillers.base import Completion, Infiller

BACKENDS = ("llamacpp", "transformers", "openai", "rule")


def make_infiller(
    backend: str,
    model: str = "qwen2.5-coder-1.5b",
    *,
    n_threads: int | None = None,
    seed: int = 0,
    base_url: str | None = None,
    device: str | None = None,
    dtype: str = "auto",
    quantization: str | None = None,
) -> Infiller:
    """Build the infiller ``backend``.

    ``model`` is a known model name or a path to a GGUF file (llamacpp), a Hub id, a local model
    directory, a known name or a GGUF path (transformers, on ``device`` with ``dtype`` and optional
    ``quantization``), or the server's model id (openai, which also needs ``base_url``, e.g.
    ``http://127.0.0.1:8000``).
    """
    if backend == "rule":
        from lerobot_policy_recent.recent_plugin.infillers.rule import RuleInfiller

        return RuleInfiller()
    if backend == "llamacpp":
        from lerobot_policy_recent.recent_plugin.infillers.llamacpp import LlamaCppInfiller
        from lerobot_policy_recent.recent_plugin.models import ensure_model

        return LlamaCppInfiller(str(ensure_model(model)), n_threads=n_threads, seed=seed)
    if backend == "transformers":
        from lerobot_policy_recent.recent_plugin.infillers.hf_transformers import TransformersInfiller

        return TransformersInfiller(model, device=device, dtype=dtype, quantization=quantization, n_threads=n_threads)
    if backend == "openai":
        from lerobot_policy_recent.recent_plugin.infillers.openai_compat import OpenAICompatInfiller

        if not base_url:
            raise ValueError("the openai backend needs a server: pass --base-url (e.g. http://127.0.0.1:8000)")
        return OpenAICompatInfiller(base_url, model)
    raise ValueError(f"unknown backend {backend!r}; choose one of: {', '.join(BACKENDS)}")


__all__ = ["BACKENDS", "Completion", "Infiller", "make_infiller"]
