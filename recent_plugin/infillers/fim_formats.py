"""FIM token formats of the code-model families RECENT can drive.

Servers and libraries differ in whether they accept ``suffix``; the portable way is to send the
pre-formatted FIM string as the prompt and stop on the family's special tokens.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FimFormat:
    family: str
    prefix: str
    suffix: str
    middle: str
    stops: tuple[str, ...]

    def render(self, prefix: str, suffix: str) -> str:
        return f"{self.prefix}{prefix}{self.suffix}{suffix}{self.middle}"


FORMATS = {
    f.family: f
    for f in (
        FimFormat(
            "qwen2.5-coder",
            "<|fim_prefix|>",
            "<|fim_suffix|>",
            "<|fim_middle|>",
            (
                "<|endoftext|>",
                "<|file_sep|>",
                "<|fim_prefix|>",
                "<|fim_suffix|>",
                "<|fim_middle|>",
                "<|im_end|>",
                "<|repo_name|>",
                "<|fim_pad|>",
            ),
        ),
        FimFormat(
            "codegemma",
            "<|fim_prefix|>",
            "<|fim_suffix|>",
            "<|fim_middle|>",
            ("<|file_separator|>", "<|fim_prefix|>", "<|fim_suffix|>", "<|fim_middle|>", "<eos>"),
        ),
        FimFormat(
            "starcoder2",
            "<fim_prefix>",
            "<fim_suffix>",
            "<fim_middle>",
            ("<|endoftext|>", "<file_sep>", "<fim_prefix>", "<fim_suffix>", "<fim_middle>"),
        ),
        FimFormat(
            "deepseek-coder",
            "<｜fim▁begin｜>",
            "<｜fim▁hole｜>",
            "<｜fim▁end｜>",
            ("<｜end▁of▁sentence｜>", "<｜fim▁begin｜>", "<｜fim▁hole｜>", "<｜fim▁end｜>", "<|EOT|>"),
        ),
    )
}


def fim_format(model: str) -> FimFormat:
    """The format for a model name or path, by family name (``Qwen/Qwen2.5-Coder-7B`` → qwen2.5-coder)."""
    lowered = model.lower()
    for family in ("qwen2.5-coder", "codegemma", "starcoder2", "deepseek-coder"):
        if family in lowered or family.replace(".", "") in lowered:
            return FORMATS[family]
    raise ValueError(f"no FIM format known for model {model!r}; known families: {', '.join(FORMATS)}")
