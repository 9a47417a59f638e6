"""The ``transformers`` backend: the paper's stack — a Hub id or a local model directory, CPU or CUDA.

The FIM string is built in the model family's own tokens (:mod:`fim_formats`) and generation is
greedy, stopped on the family's special tokens and on the span's own end (a one-statement span
ends at its newline). Generated tokens are counted with the model's tokenizer. A GGUF file (one
of ours, or any path) is loaded by dequantizing it (``gguf_file=``): slow on a CPU, and the way to
run the same weights as llama.cpp on a GPU. GBNF grammars are a llama.cpp feature and not used here.
A whole function body (a baseline's program) is asked for through the model's chat template
(:mod:`~lerobot_policy_recent.recent_plugin.refactoring.chat_prompt`; ChatML where the tokenizer has none).
"""

from __future__ import annotations

import time
from pathlib import Path

from lerobot_policy_recent.recent_plugin.infillers.base import Completion
from lerobot_policy_recent.recent_plugin.infillers.fim_formats import FimFormat, fim_format
from lerobot_policy_recent.recent_plugin.refactoring.chat_prompt import (
    build_chat,
    render_chatml,
    span_of_reply,
    writes_whole_body,
)
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import RefactoringUnit

DTYPES = ("auto", "float32", "float16", "bfloat16")
PROMPT_LOOKUP_TOKENS = 8  # a span mostly copies its prompt (see infillers/lookup_decoding.py)
QUANTIZATIONS = (None, "8bit", "4bit")  # bitsandbytes, CUDA only


class TransformersInfiller:
    name = "transformers"
    samples = True

    def __init__(
        self,
        model: str,
        *,
        device: str | None = None,
        dtype: str = "auto",
        quantization: str | None = None,
        fim_family: str | None = None,
        n_threads: int | None = None,
        prompt_window: str = "dataflow",
    ):
        """``model``: a Hub id, a local directory, or a ``.gguf`` file (dequantized on load).

        ``device``: ``cuda``, ``cpu`` or None (CUDA when available). ``dtype``: ``auto`` is fp16 on
        CUDA and fp32 on CPU (bf16 prefill is several times slower on CPUs without AVX512-BF16).
        """
        import torch
        from transformers import AutoModelForCausalLM, AutoTokenizer

        if dtype not in DTYPES:
            raise ValueError(f"dtype {dtype!r} is not one of {', '.join(DTYPES)}")
        if quantization not in QUANTIZATIONS:
            raise ValueError(f"quantization {quantization!r} is not one of 8bit, 4bit (or none)")
        self.device = device or ("cuda" if torch.cuda.is_available() else "cpu")
        if quantization and self.device != "cuda":
            raise ValueError(f"{quantization} quantization (bitsandbytes) needs a CUDA device, not {self.device}")
        self.prompt_window = prompt_window  # how much of a span's function its FIM prompt shows
        if n_threads:
            torch.set_num_threads(n_threads)
        source, gguf = _source(model)
        self.model = Path(gguf).name if gguf else model
        self.format: FimFormat = fim_format(fim_family or model)
        kwargs: dict[str, object] = {"gguf_file": gguf} if gguf else {}
        self.tokenizer = AutoTokenizer.from_pretrained(source, **kwargs)
        torch_dtype = _dtype(dtype, self.device)
        if quantization:
            import importlib.util

            from transformers import BitsAndBytesConfig

            if importlib.util.find_spec("bitsandbytes") is None:
                raise RuntimeError(f"{quantization} quantization needs bitsandbytes: `uv pip install bitsandbytes`")

            kwargs["quantization_config"] = BitsAndBytesConfig(
                load_in_8bit=quantization == "8bit", load_in_4bit=quantization == "4bit"
            )
        self.lm = AutoModelForCausalLM.from_pretrained(source, dtype=torch_dtype, **kwargs)
        if not quantization:
            self.lm.to(self.device)
        self.lm.eval()
        vocab = self.tokenizer.get_vocab()
        self._stop_ids = sorted({vocab[t] for t in self.format.stops if t in vocab})

    def count_tokens(self, text: str) -> int:
        return len(self.tokenizer(text, add_special_tokens=False)["input_ids"])

    def infill(self, unit: RefactoringUnit, *, temperature: float = 0.0, seed: int = 0) -> Completion:
        import torch

        span_tokens = self.count_tokens(unit.span)
        chat = build_chat(unit, span_tokens) if writes_whole_body(unit) else None
        shown = ""
        if chat is not None:  # a program is written, not a span edited: the instruct model's chat
            text_prompt, max_tokens, stops = self._chat_text(chat.messages), chat.max_tokens, ()
            shown = text_prompt  # the chat as the template renders it: system line and instruction included
        else:
            prompt = build_prompt(unit, span_tokens, self.prompt_window)
            text_prompt, max_tokens, stops = (
                self.format.render(prompt.prefix, prompt.suffix),
                prompt.max_tokens,
                prompt.stop,
            )
            shown = prompt.shown()
        encoded = self.tokenizer(text_prompt, return_tensors="pt", add_special_tokens=False).to(self.device)
        started = time.perf_counter()
        sampling = (
            {"do_sample": True, "temperature": temperature, "top_k": 0} if temperature > 0 else {"do_sample": False}
        )
        if temperature > 0:
            torch.manual_seed(seed)  # seeded sampling: the same call draws the same tokens
        with torch.inference_mode():
            out = self.lm.generate(
                **encoded,
                max_new_tokens=max_tokens,
                **sampling,
                eos_token_id=self._stop_ids or None,
                pad_token_id=self._stop_ids[0] if self._stop_ids else None,
                stop_strings=list(stops) or None,
                tokenizer=self.tokenizer,
                prompt_lookup_num_tokens=PROMPT_LOOKUP_TOKENS,  # drafts from the prompt: same greedy output, fewer passes
            )
        seconds = time.perf_counter() - started
        new = out[0, encoded["input_ids"].shape[1] :].tolist()
        while new and new[-1] in self._stop_ids:  # the stop token ends the span, it is not part of it
            new.pop()
        text = self.tokenizer.decode(new, skip_special_tokens=True)
        for stop in stops:  # generation stops *after* a stop string: cut it (and what follows) off
            if stop in text:
                text = text[: text.index(stop)]
        if chat is not None:
            text = span_of_reply(text, unit.indent)
        return Completion(
            text=text,
            generated_tokens=len(new),
            seconds=seconds,
            prompt_tokens=int(encoded["input_ids"].shape[1]),
            prompt=shown,
        )

    def _chat_text(self, messages) -> str:
        """The messages in the model's own chat template (ChatML, Qwen2.5's, where it ships none)."""
        if getattr(self.tokenizer, "chat_template", None):
            return self.tokenizer.apply_chat_template(list(messages), tokenize=False, add_generation_prompt=True)
        return render_chatml(messages)


def _source(model: str) -> tuple[str, str | None]:
    """(directory or Hub id, GGUF file name or None) for a Hub id, a directory, a .gguf path or a known name."""
    from lerobot_policy_recent.recent_plugin.models.registry import MODELS

    if model in MODELS:
        from lerobot_policy_recent.recent_plugin.models import ensure_model

        path = Path(ensure_model(model))
        return str(path.parent), path.name
    if model.endswith(".gguf"):
        path = Path(model).expanduser()
        if not path.is_file():
            raise FileNotFoundError(f"no GGUF file at {path}")
        return str(path.parent), path.name
    return model, None


def _dtype(name: str, device: str):
    import torch

    if name == "auto":
        return torch.float16 if device == "cuda" else torch.float32
    return getattr(torch, name)
