"""Greedy decoding for llama.cpp with prompt-lookup drafts, verified in one batch.

A grounded span mostly copies text that is already in its prompt (the substitute's name and
signature from the hint comments, argument names from the surrounding code). After each token the
decoder looks up the last few generated tokens in the prompt and proposes what followed them
there; one batched forward pass scores the whole draft, and greedy sampling (with the span's
grammar) keeps the prefix the model itself would have produced. The output is the same as plain
greedy decoding. A rejected draft still costs its batch, so the draft length adapts: it doubles
after a draft the model took whole and shrinks to what it took after one it refused. The longest
match (up to 6 tokens) picks the draft. The hint's call is a draft source too: a run-time patch
writes it out with line breaks where the hint has "; then ", and it is drafted as the span writes
it, its later lines at the body's indentation (``FimPrompt.draft``; drafted without, every line
break refused the draft). A draft from the hint's call may run to 64 tokens
(``MAX_EXPECTED_DRAFT``), so a push sweep's call is verified in one batch. What each choice saved
in decoding time is in docs/history.md ("Decoding on a CPU", "Run-time patches").

The grammar is checked the way llama.cpp's own common sampler does it: the unconstrained argmax
is tested alone, and only when the grammar refuses it are more candidates constrained, the best
ones first (a grammar pass over the whole vocabulary costs far more than testing the argmax alone).
Seeded sampling (a temperature above 0) asks the grammar only about the tokens whose weight can
show in a float64 draw, those within ``NEGLIGIBLE`` of the best admitted one: at temperature 0.2
a few dozen instead of 150k, and the same token is drawn.

The KV cache is kept between calls: a prompt that shares its start with the previous one (the
same skill's next span) only evaluates what differs. Earlier prompts' states are saved too
(:mod:`~lerobot_policy_recent.recent_plugin.infillers.prompt_states`): a prompt that shares a longer start with one of
them than with the last prompt starts from that state instead.

Only a shared start that is a whole number of ``REUSE_ALIGN`` tokens is reused, and every batch
of a prompt starts at such a multiple. llama.cpp's CPU kernels compute a batch's rows in groups
and the rows left over at a batch's end another way, so a prompt resumed where an earlier one
diverged, mid-group, decoded differently from the same prompt evaluated cold: an episode's LM
answers depended on which episodes ran before it in the worker (measured in docs/llm_runtime.md).
Aligned, every reused cell is computed as a cold evaluation computes it, and the answers are the
same whatever came before. The alignment is a multiple of the groups seen, with room for wider ones.
"""

from __future__ import annotations

import ctypes
import math
import time
from dataclasses import dataclass

import numpy as np

from lerobot_policy_recent.recent_plugin.infillers.prompt_states import PromptStates, shared_start


@dataclass(frozen=True)
class Decoded:
    text: str
    generated_tokens: int  # sampled tokens, as llama.cpp's own completion counts them
    prompt_tokens: int
    evaluated_prompt_tokens: int  # the part of the prompt not already in the KV cache
    prompt_seconds: float = 0.0  # evaluating that part
    generation_seconds: float = 0.0  # sampling the completion
    context_full: bool = False  # the prompt left no room in the model's context: nothing was generated


REUSE_ALIGN = 32  # a reused start, and every prompt batch's start, is a multiple of this many tokens
MAX_NGRAM = 6  # the longest tail matched to find a draft
MAX_DRAFT = 48  # the longest draft from the prompt: a refused batch costs about as much as a dozen single tokens
# The longest draft from the expected text (the hint's call): a push sweep's call, 54 to 56 tokens, is
# then verified in one batch, not two (a batch of any size streams all the weights once).
MAX_EXPECTED_DRAFT = 64


def _longest_match(haystack: np.ndarray, tail: np.ndarray, max_ngram: int) -> tuple[int, int]:
    """``(n, i)``: the latest ``i`` where ``haystack[i - n + 1 : i + 1]`` is the last ``n`` tokens of
    ``tail``, with ``n`` as large as there is (at most ``max_ngram``); ``(0, -1)`` where none is."""
    ends = np.flatnonzero(haystack == tail[-1])
    if not ends.size:
        return 0, -1
    found, n = ends, 1
    while n < min(max_ngram, len(tail)):
        ends = ends[ends >= n]
        ends = ends[haystack[ends - n] == tail[-1 - n]]
        if not ends.size:
            break
        found, n = ends, n + 1
    return n, int(found[-1])


def draft_from_context(
    context: list[int],
    *,
    max_ngram: int = MAX_NGRAM,
    max_draft: int = MAX_DRAFT,
    expected: list[int] | tuple[int, ...] = (),
    max_expected: int = MAX_EXPECTED_DRAFT,
) -> list[int]:
    """The tokens that followed the latest earlier occurrence of the context's last n-gram (longest n
    first), in the context or in ``expected`` (text the span is likely to copy: the hint's call, with
    the line breaks the span would have), at most ``max_draft`` or ``max_expected`` of them. A match
    in ``expected`` wins a tie."""
    tokens = np.asarray(context)
    if len(tokens) < 2:
        return []
    n, end = _longest_match(tokens[:-1], tokens, max_ngram)
    source, most = tokens, max_draft
    if len(expected) > 1:
        known = np.asarray(expected)
        k, known_end = _longest_match(known[:-1], tokens, max_ngram)
        if k and k >= n:
            source, n, end, most = known, k, known_end, max_expected
    return source[end + 1 : end + 1 + most].tolist() if n else []


# A token whose scaled logit is this far below the best admitted one weighs exp(-60) ≈ 1e-26 of it:
# all 150k of them together stay under float64's resolution, so leaving them out draws the same token.
NEGLIGIBLE = 60.0


class GreedyGrammarSampler:
    """Greedy choice under a GBNF grammar: the argmax if the grammar admits it, else the best admitted token.

    With a ``temperature`` above 0 it samples instead, from the grammar-admitted softmax at that
    temperature, drawing from ``rng`` (one draw per position, in order: a seeded generator gives the
    same tokens for the same logits, and draft verification samples what sequential decoding would).
    """

    def __init__(self, llm, grammar, *, temperature: float = 0.0, rng: np.random.Generator | None = None):
        import llama_cpp
        from llama_cpp import _internals

        self._api = llama_cpp
        self._ctx = llm._ctx.ctx
        self._n_vocab = llm.n_vocab()
        self._grammar = (
            llama_cpp.llama_sampler_init_grammar(
                llm._model.vocab, grammar._grammar.encode("utf-8"), grammar._root.encode("utf-8")
            )
            if grammar is not None
            else None
        )
        self._one = llama_cpp.llama_token_data(0, 0.0, 0.0)
        self._single = llama_cpp.llama_token_data_array(
            data=ctypes.pointer(self._one), size=1, selected=-1, sorted=False
        )
        self._all = _internals.LlamaTokenDataArray(n_vocab=self._n_vocab) if grammar is not None else None
        self.temperature = temperature
        self.rng = rng if rng is not None else np.random.default_rng(0)

    def sample(self, idx: int) -> int:
        """The token at output ``idx`` of the last batch (-1: its last); the grammar takes it."""
        api = self._api
        logits = np.ctypeslib.as_array(api.llama_get_logits_ith(self._ctx, idx), shape=(self._n_vocab,))
        if self.temperature > 0:
            return self._sampled(logits)
        token = int(np.argmax(logits))
        if self._grammar is None:
            return token
        self._one.id, self._one.logit, self._one.p = token, float(logits[token]), 0.0
        self._single.size, self._single.selected = 1, -1
        api.llama_sampler_apply(self._grammar, ctypes.byref(self._single))
        if not math.isfinite(self._one.logit):  # refused: the best token the grammar admits
            token = self._best_admitted(logits)
        api.llama_sampler_accept(self._grammar, token)
        return token

    def _best_admitted(self, logits: np.ndarray) -> int:
        """The highest-scoring token the grammar admits (the lowest id among equals), asking it about
        the best 64 tokens first, then 16 times as many, until it admits one."""
        k = 64
        while True:
            floor = np.partition(logits, -k)[-k] if k < len(logits) else -np.inf
            ids = np.flatnonzero(logits >= floor)
            values = self._admitted(ids, logits)
            if np.isfinite(values).any():
                return int(ids[np.argmax(values)])
            if k >= len(logits):
                raise ValueError("the grammar admits no token here")
            k *= 16

    def _sampled(self, logits: np.ndarray) -> int:
        scaled = np.asarray(logits, dtype=np.float64) / self.temperature
        ids, values = self._candidates(scaled, logits)
        top = values[np.isfinite(values)].max()
        weights = np.where(np.isfinite(values), np.exp(values - top), 0.0)
        choice = int(self.rng.choice(len(weights), p=weights / weights.sum()))
        token = int(ids[choice])
        if self._grammar is not None:
            self._api.llama_sampler_accept(self._grammar, token)
        return token

    def _candidates(self, scaled: np.ndarray, logits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tokens that can be drawn, in vocabulary order, and their scaled logits (-inf: the grammar refuses).

        Only tokens within ``NEGLIGIBLE`` of the best one the grammar admits are looked at: the rest
        weigh too little to change a float64 draw. The grammar is asked about the tokens near the
        overall best first, and about more only when it refused the best ones."""
        floor = scaled.max() - NEGLIGIBLE
        ids = np.flatnonzero(scaled >= floor)
        values = self._admitted(ids, logits) / self.temperature
        while True:
            admitted = values[np.isfinite(values)]
            needed = admitted.max() - NEGLIGIBLE if admitted.size else -np.inf
            if needed >= floor:
                return ids, values
            more = np.flatnonzero((scaled < floor) & (scaled >= needed))
            floor = needed
            if more.size == 0:
                if not admitted.size:
                    raise ValueError("the grammar admits no token here")
                return ids, values
            order = np.argsort(np.concatenate([ids, more]), kind="stable")
            ids = np.concatenate([ids, more])[order]
            values = np.concatenate([values, self._admitted(more, logits) / self.temperature])[order]

    def _admitted(self, ids: np.ndarray, logits: np.ndarray) -> np.ndarray:
        """The logits of ``ids`` as float64, -inf where the grammar refuses the token (all of them without one)."""
        values = np.asarray(logits[ids], dtype=np.float64)
        if self._grammar is None:
            return values
        data, k = self._all.candidates_data, len(ids)
        data.id[:k] = ids
        data.logit[:k] = logits[ids]
        data.p[:k] = 0.0
        self._all.candidates.size, self._all.candidates.sorted, self._all.candidates.selected = k, False, -1
        self._api.llama_sampler_apply(self._grammar, ctypes.byref(self._all.candidates))
        return np.where(np.isfinite(data.logit[:k]), values, -np.inf)

    def close(self) -> None:
        if self._grammar is not None:
            self._api.llama_sampler_free(self._grammar)
            self._grammar = None


def _aligned(n: int) -> int:
    return n - n % REUSE_ALIGN


class LookupDecoder:
    """Greedy (grammar-constrained) decoding with prompt-lookup drafts on a ``llama_cpp.Llama``."""

    def __init__(
        self,
        llm,
        *,
        max_ngram: int = MAX_NGRAM,
        max_draft: int = MAX_DRAFT,
        max_expected: int = MAX_EXPECTED_DRAFT,
        states: PromptStates | None = None,
    ):
        self.llm = llm
        self.max_ngram = max_ngram
        self.max_draft = max_draft
        self.max_expected = max_expected
        self.states = states if states is not None else PromptStates(0)
        self._aligned = 0  # leading cached tokens a cold evaluation computes alike (the cells that may be reused)
        self._left: bytes = b""  # the cache's tokens as this decoder left them (another user of the model resets it)

    def _start_from(self, prompt: list[int]) -> int:
        """Put the longest start of ``prompt`` that the KV cache or a saved state holds, a multiple of
        ``REUSE_ALIGN``, into the cache; its length.

        At least the prompt's last token is left to evaluate, so its logits are fresh."""
        tokens = np.asarray(prompt[:-1], dtype=np.intc)
        cached = np.asarray(self._cached(), dtype=np.intc)
        if cached.tobytes() != self._left:  # evaluated by someone else, in other batches
            self._aligned = 0
        keep = _aligned(min(shared_start(cached, tokens), self._aligned))
        found = self.states.best(tokens)
        if found is not None:
            usable = _aligned(min(found[1], len(found[0].tokens)))
            if usable > keep and self._restore(found[0].tokens, found[0].data, found[0].size):
                self.states.restored += 1
                keep = usable
        self._truncate(keep)
        return keep

    def _restore(self, tokens: np.ndarray, data, size: int) -> bool:
        import llama_cpp

        llm = self.llm
        llm._ctx.kv_cache_seq_rm(0, -1, -1)
        llm.n_tokens = 0
        if llama_cpp.llama_state_seq_set_data(llm._ctx.ctx, data, size, 0) != size:
            llm._ctx.kv_cache_seq_rm(0, -1, -1)  # a state that did not load leaves an empty cache, never a wrong one
            return False
        llm.input_ids[: len(tokens)] = tokens
        llm.n_tokens = len(tokens)
        self._aligned = _aligned(len(tokens))  # saved after its prompt was evaluated in aligned batches
        return True

    def _save(self, prompt: list[int]) -> None:
        import llama_cpp

        if self.states.budget_bytes <= 0:
            return
        ctx = self.llm._ctx.ctx
        size = llama_cpp.llama_state_seq_get_size(ctx, 0)
        data = (ctypes.c_uint8 * size)()
        if llama_cpp.llama_state_seq_get_data(ctx, data, size, 0) == size:
            self.states.save(np.asarray(prompt, dtype=np.intc), data, size)

    def _cached(self) -> list[int]:
        return list(self.llm.input_ids[: self.llm.n_tokens])

    def _truncate(self, n: int) -> None:
        self.llm._ctx.kv_cache_seq_rm(-1, n, -1)
        self.llm.n_tokens = n
        self._aligned = min(self._aligned, n)

    def _evaluate_prompt(self, prompt: list[int], keep: int) -> None:
        """Evaluate ``prompt`` after its first ``keep`` tokens (a multiple of ``REUSE_ALIGN``), in
        batches that each start at a multiple of it."""
        size = max(REUSE_ALIGN, self.llm.n_batch - self.llm.n_batch % REUSE_ALIGN)
        for start in range(keep, len(prompt), size):
            self._decode(prompt[start : start + size], all_logits=False)
        self._aligned = _aligned(len(prompt))  # the rows left over at the end were computed another way

    def _decode(self, tokens: list[int], *, all_logits: bool) -> None:
        llm = self.llm
        for i in range(0, len(tokens), llm.n_batch):
            chunk = tokens[i : i + llm.n_batch]
            llm._batch.set_batch(batch=chunk, n_past=llm.n_tokens, logits_all=all_logits)
            llm._ctx.decode(llm._batch)
            llm.input_ids[llm.n_tokens : llm.n_tokens + len(chunk)] = chunk
            llm.n_tokens += len(chunk)

    def generate(
        self,
        prompt: list[int],
        *,
        max_tokens: int,
        stops: tuple[str, ...],
        grammar=None,
        temperature: float = 0.0,
        seed: int = 0,
        expected: list[int] | tuple[int, ...] = (),
    ) -> Decoded:
        """``expected``: tokens the completion is likely to copy, drafted from as well (the output does not change)."""
        import llama_cpp

        llm = self.llm
        context = min(llm.n_ctx(), len(llm.input_ids))  # llama.cpp pads its context; the binding's arrays are not
        room = context - len(prompt)  # the completion and its drafts share the context with the prompt
        if room < 2:
            return Decoded("", 0, len(prompt), 0, context_full=True)
        max_tokens = min(max_tokens, room - 1)
        started = time.perf_counter()
        keep = self._start_from(prompt)
        self._evaluate_prompt(prompt, keep)
        self._save(prompt)
        prompt_seconds = time.perf_counter() - started
        sampler = GreedyGrammarSampler(llm, grammar, temperature=temperature, rng=np.random.default_rng(seed))
        vocab = llm._model.vocab

        out: list[int] = []

        def finished(token: int) -> bool:
            """Take ``token``; True when the span is complete (end of generation, a stop text, the length cap)."""
            if llama_cpp.llama_vocab_is_eog(vocab, token):
                return True
            out.append(token)
            text = llm.detokenize(out, prev_tokens=prompt).decode("utf-8", errors="ignore")
            return len(out) >= max_tokens or any(s in text for s in stops)

        try:
            token = sampler.sample(-1)
            length = top = max(self.max_draft, self.max_expected)
            while not finished(token):
                draft = draft_from_context(
                    prompt + out,
                    max_ngram=self.max_ngram,
                    max_draft=min(length, self.max_draft),
                    expected=expected,
                    max_expected=min(length, self.max_expected),
                )
                draft = draft[: max(0, min(max_tokens - len(out), context - llm.n_tokens - 1))]
                base = llm.n_tokens
                self._decode([token, *draft], all_logits=True)
                accepted, done = 0, False
                for i in range(len(draft) + 1):
                    token = sampler.sample(i)  # what greedy decoding says after batch[: i + 1]
                    if i < len(draft) and token == draft[i]:
                        accepted += 1
                        if finished(token):
                            done = True
                            break
                        continue
                    break  # ``token`` is the model's own next token, not yet in the cache
                self._truncate(base + 1 + accepted)  # drop the draft tokens greedy decoding did not produce
                if draft:
                    length = min(top, 2 * length) if accepted == len(draft) else max(1, accepted)
                if done:
                    break
        finally:
            sampler.close()
            self._left = np.asarray(self._cached(), dtype=np.intc).tobytes()
        text = llm.detokenize(out, prev_tokens=prompt).decode("utf-8", errors="ignore")
        for stop in stops:
            if stop in text:
                text = text[: text.index(stop)]
        generation_seconds = time.perf_counter() - started - prompt_seconds
        return Decoded(text, len(out), len(prompt), len(prompt) - keep, prompt_seconds, generation_seconds)
