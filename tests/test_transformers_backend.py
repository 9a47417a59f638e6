"""The ``transformers`` backend: FIM in the model's own tokens, greedy spans, counts from its tokenizer.

A tiny Qwen2 with random weights and a byte-level BPE tokenizer trained here on the skill library
(with Qwen2.5-Coder's FIM markers as special tokens) exercises the real transformers code path in
seconds; the slow test grounds a skill with the real 1.5B GGUF, dequantized by transformers.
"""

from __future__ import annotations

import importlib.util

import pytest

from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.recent_plugin.infillers import make_infiller
from lerobot_policy_recent.recent_plugin.infillers.fim_formats import FORMATS
from lerobot_policy_recent.recent_plugin.refactoring.units import unit_from_conflict
from lerobot_policy_recent.skills.repository import LIBRARY

QWEN = FORMATS["qwen2.5-coder"]


@pytest.fixture(scope="module")
def tiny_model_dir(tmp_path_factory):
    import torch
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers
    from transformers import PreTrainedTokenizerFast, Qwen2Config, Qwen2ForCausalLM

    bpe = Tokenizer(models.BPE())
    bpe.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    bpe.decoder = decoders.ByteLevel()
    specials = list(dict.fromkeys([QWEN.prefix, QWEN.suffix, QWEN.middle, *QWEN.stops]))
    trainer = trainers.BpeTrainer(
        vocab_size=600, special_tokens=specials, initial_alphabet=pre_tokenizers.ByteLevel.alphabet()
    )
    bpe.train_from_iterator([p.read_text() for p in sorted(LIBRARY.glob("*.py"))], trainer)
    tokenizer = PreTrainedTokenizerFast(tokenizer_object=bpe, eos_token="<|endoftext|>")
    torch.manual_seed(0)
    config = Qwen2Config(
        vocab_size=len(tokenizer),
        hidden_size=32,
        intermediate_size=64,
        num_hidden_layers=2,
        num_attention_heads=2,
        num_key_value_heads=1,
        max_position_embeddings=2048,
    )
    directory = tmp_path_factory.mktemp("models") / "tiny-qwen2.5-coder"
    Qwen2ForCausalLM(config).save_pretrained(directory)
    tokenizer.save_pretrained(directory)
    return directory


def test_fim_markers_are_single_special_tokens_and_spans_are_counted(tiny_model_dir, ontology, put_in_bin):
    infiller = make_infiller("transformers", str(tiny_model_dir), device="cpu", n_threads=2)
    assert infiller.name == "transformers" and infiller.format.family == "qwen2.5-coder"
    ids = infiller.tokenizer(QWEN.render("a", "b"), add_special_tokens=False)["input_ids"]
    assert len(ids) == 5  # <|fim_prefix|> a <|fim_suffix|> b <|fim_middle|>
    conflict = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e").conflicts[0]
    completion = infiller.infill(unit_from_conflict(put_in_bin.code, conflict, ontology.target("UR5e")))
    assert 0 < completion.generated_tokens <= 64 and completion.seconds > 0
    assert completion.prompt_tokens > 100  # the function window with the hint comments
    assert "\n" not in completion.text  # a one-statement span ends at its newline
    assert infiller.count_tokens("open_ur5_ee(env, task)") == len(
        infiller.tokenizer("open_ur5_ee(env, task)", add_special_tokens=False)["input_ids"]
    )


def test_random_weights_are_rejected_by_validation_not_executed(tiny_model_dir, ontology, put_in_bin):
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill

    infiller = make_infiller("transformers", str(tiny_model_dir), device="cpu")
    grounded = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, infiller, max_retries=1)
    assert not grounded.valid and grounded.calls and not any(c.accepted for c in grounded.calls)
    assert grounded.generated_tokens == sum(c.generated_tokens for c in grounded.calls) > 0


def test_bad_options_are_named(tiny_model_dir):
    with pytest.raises(ValueError, match="dtype 'float8'"):
        make_infiller("transformers", str(tiny_model_dir), dtype="float8")
    with pytest.raises(ValueError, match="needs a CUDA device"):
        make_infiller("transformers", str(tiny_model_dir), device="cpu", quantization="4bit")
    with pytest.raises(FileNotFoundError, match="no GGUF file"):
        make_infiller("transformers", "/nowhere/model.gguf")


def _cuda() -> bool:
    import torch

    return torch.cuda.is_available()


@pytest.mark.skipif(not _cuda(), reason="needs a CUDA GPU (runs on the lent GPU machine, not in CI)")
@pytest.mark.parametrize("dtype", ["auto", "float16", "bfloat16", "float32"])
def test_cuda_is_chosen_and_every_dtype_infills_the_same_span_each_time(tiny_model_dir, ontology, put_in_bin, dtype):
    from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, cut_unit

    infiller = make_infiller("transformers", str(tiny_model_dir), dtype=dtype)  # device=None: CUDA when present
    weights = next(infiller.lm.parameters())
    assert infiller.device == "cuda" and weights.device.type == "cuda"
    assert str(weights.dtype) == f"torch.{'float16' if dtype == 'auto' else dtype}"
    code = put_in_bin.code
    start = code.index("pick(")
    end = code.index("\n", start)
    hints = Hints(
        target=ontology.target("UR5e"),
        original_call=code[start:end],
        substitute_call="ur5_grasp_at(env, task, grasp_pos=obj_pos)",
    )
    unit = cut_unit(code, start, end, "api_substitution", hints, substitute="ur5_grasp_at")
    completions = [infiller.infill(unit) for _ in range(3)]
    assert completions[0].generated_tokens > 0 and len({c.text for c in completions}) == 1
    if importlib.util.find_spec("bitsandbytes") is None:  # the error says what to install
        with pytest.raises(RuntimeError, match="needs bitsandbytes"):
            make_infiller("transformers", str(tiny_model_dir), quantization="8bit")


@pytest.mark.slow
def test_real_gguf_through_transformers_grounds_put_in_bin(ontology, put_in_bin):
    """The 1.5B GGUF dequantized to fp32 on the CPU (minutes): the paper's stack, slowly."""
    from lerobot_policy_recent.recent_plugin.grounding.grounder import ground_skill

    infiller = make_infiller("transformers", "qwen2.5-coder-1.5b", device="cpu", n_threads=2)
    grounded = ground_skill(put_in_bin, ontology.target("UR5e"), ontology, infiller)
    assert grounded.valid, grounded.verdict
    assert "ur5_grasp_at(" in grounded.code and "pick(" not in grounded.code
