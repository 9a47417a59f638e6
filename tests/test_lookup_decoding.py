"""Prompt-lookup decoding: drafts come from the prompt, and the output is plain greedy decoding's."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
from doubles import sweep_unit

from lerobot_policy_recent.ontology.diagnosis import diagnose
from lerobot_policy_recent.recent_plugin.infillers import lookup_decoding
from lerobot_policy_recent.recent_plugin.infillers.llamacpp import QWEN
from lerobot_policy_recent.recent_plugin.infillers.lookup_decoding import draft_from_context
from lerobot_policy_recent.recent_plugin.refactoring.fim_prompt import STATEMENT_LINE, build_prompt
from lerobot_policy_recent.recent_plugin.refactoring.units import Hints, cut_unit, unit_from_conflict


def test_draft_continues_the_latest_match_of_the_longest_ngram():
    context = [1, 2, 3, 9, 9, 1, 2, 3, 4, 5, 6, 7, 0, 2, 3]
    assert draft_from_context(context, max_ngram=3, max_draft=3) == [4, 5, 6]  # "2 3" last seen before "4 5 6"
    assert draft_from_context([5, 6, 7], max_ngram=3) == []  # nothing repeats
    assert draft_from_context([7, 1, 7], max_ngram=2, max_draft=4) == [1, 7]  # falls back to a 1-gram


def test_expected_text_is_drafted_from_and_wins_a_tie():
    context = [5, 1, 2, 8, 9, 1, 2]
    assert draft_from_context(context, max_draft=2) == [8, 9]
    assert draft_from_context(context, max_draft=2, expected=[1, 2, 3, 4]) == [3, 4]  # the hint's call
    assert draft_from_context(context, max_draft=2, expected=[2, 3, 4]) == [8, 9]  # a longer match wins
    assert draft_from_context([5, 6], expected=[6, 7, 8]) == [7, 8]  # found only in the expected text


def test_a_draft_from_the_expected_text_may_run_longer():
    """The hint's call is what a run-time patch writes: its draft runs to ``max_expected``, past ``max_draft``."""
    expected = list(range(100, 200))
    assert draft_from_context([1, 100], max_draft=4, expected=expected, max_expected=8) == list(range(101, 109))
    assert draft_from_context([100, 1, 100], max_draft=4, expected=[], max_expected=8) == [1, 100]


def _greedy(llm, text: str, max_tokens: int, stops, grammar) -> str:
    llm.reset()
    out = llm.create_completion(
        text, max_tokens=max_tokens, temperature=0.0, top_k=1, stop=list(stops), grammar=grammar
    )
    return out["choices"][0]["text"]


@pytest.mark.parametrize("robot", ["UR5e", "Suction"])
def test_lookup_decoding_matches_plain_greedy_decoding(ontology, put_in_bin, llama_session, robot):
    """Same FIM prompt, same grammar: the drafts only change how fast the tokens come."""
    diagnosis = diagnose(ontology, put_in_bin.name, put_in_bin.code, robot, source=put_in_bin.source_embodiment)
    session = llama_session
    for conflict in diagnosis.conflicts:
        unit = unit_from_conflict(put_in_bin.code, conflict, ontology.target(robot))
        prompt = build_prompt(unit, len(session.tokenize(unit.span)))
        text = QWEN.render(prompt.prefix, prompt.suffix)
        stops = (*prompt.stop, *QWEN.stops)
        grammar = session.grammar(STATEMENT_LINE)
        reference = _greedy(session.llm, text, prompt.max_tokens, stops, grammar)
        decoded = session.decoder.generate(
            session.tokenize(text, special=True),
            max_tokens=prompt.max_tokens,
            stops=stops,
            grammar=grammar,
            expected=session.tokenize(unit.hints.substitute_call or ""),
        )
        assert decoded.text == reference


class FullGrammarPass(lookup_decoding.GreedyGrammarSampler):
    """The reference: the grammar judges every one of the 150k tokens before each choice."""

    def _judged(self, logits):
        self._all.copy_logits(logits)
        self._api.llama_sampler_apply(self._grammar, ctypes.byref(self._all.candidates))
        return np.asarray(self._all.candidates_data.logit, dtype=np.float64)

    def _candidates(self, scaled, logits):
        ids = np.arange(len(logits))
        return ids, (scaled if self._grammar is None else self._judged(logits) / self.temperature)

    def _best_admitted(self, logits):
        return int(np.argmax(self._judged(logits)))


def test_the_grammar_judges_only_the_tokens_a_draw_can_reach(ontology, put_in_bin, llama_session, monkeypatch):
    """Sampling asks the grammar about the tokens near the best admitted one, greedy decoding about the
    best ones first; both choose exactly what judging all 150k tokens chooses. Cases: the statement
    grammar at the default temperature 0.2 and at 1.0, greedy, and a grammar (digits only) that
    refuses nearly every likely token."""
    session = llama_session
    diagnosis = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e", source=put_in_bin.source_embodiment)
    unit = unit_from_conflict(put_in_bin.code, diagnosis.conflicts[-1], ontology.target("UR5e"))
    prompt = build_prompt(unit, len(session.tokenize(unit.span)))
    text = QWEN.render(prompt.prefix, prompt.suffix)
    stops = (*prompt.stop, *QWEN.stops)
    cases = [(STATEMENT_LINE, t, seed) for t in (0.2, 1.0) for seed in (1, 2, 3)]
    cases += [(STATEMENT_LINE, 0.0, 0), (r"root ::= [0-9]+", 0.0, 0), (r"root ::= [0-9]+", 0.2, 4)]

    def decode_all():
        return [
            session.generate(text, max_tokens=12, stops=stops, gbnf=gbnf, temperature=t, seed=seed).text
            for gbnf, t, seed in cases
        ]

    windowed = decode_all()
    monkeypatch.setattr(lookup_decoding, "GreedyGrammarSampler", FullGrammarPass)
    assert decode_all() == windowed
    assert all(w.isdigit() for w in windowed[-2:])  # the grammar held where it refused the model's favourites


GROUNDED = '''def place_on_plate(env, task, obj="cube", target="plate"):
    """Pick `obj` and set it down on the middle of the plate `target`."""
    obj_pos = task.get_object_position(obj)
    plate_pos = task.get_object_position(target)
    open_ur5_ee(env, task)
    ur5_grasp_at(env, task, grasp_pos=obj_pos)
    drop_pos = [plate_pos[0], plate_pos[1], plate_pos[2] + 0.035]
    ur5_release_at(env, task, place_pos=drop_pos)
'''


def test_a_span_ends_where_the_model_ends_it(llama_infiller, ontology):
    """The statement grammar admits the model's end token: an in-situ sweep is the call and nothing
    more (a grammar that demanded the newline ran on with ' # <the call again>' to the length cap)."""
    sweep = "ur5_push_to(env, task, contact_pos=[0.178, 0.069, 0.854], goal_pos=[0.178, -0.056, 0.854])"
    observation = "obstacle (slab, 0.10 m wide) lies at [0.178, -0.024, 0.834] on the release target"
    unit = sweep_unit(GROUNDED, "ur5_release_at", ontology.target("UR5e"), sweep, observation)
    completion = llama_infiller.infill(unit)
    assert completion.text == sweep
    assert completion.generated_tokens <= llama_infiller.count_tokens(sweep) + 1


def test_seeded_sampling_repeats_a_seed_and_varies_across_seeds(llama_infiller, ontology):
    """Through the LM worker: a seed draws the same span again from the same model state; other seeds
    draw others; the grammar still holds (a statement, never a comment)."""
    start = GROUNDED.index("open_ur5_ee")
    end = GROUNDED.index("\n", start)
    hints = Hints(target=ontology.target("UR5e"), original_call=GROUNDED[start:end], reason="open the hand")
    unit = cut_unit(GROUNDED, start, end, "api_substitution", hints)
    llama_infiller.infill(unit)  # the prompt is in the cache from here on: every call below starts alike
    greedy = llama_infiller.infill(unit).text  # (the first may have started from another test's saved state)
    texts = [llama_infiller.infill(unit, temperature=1.0, seed=seed).text for seed in (1, 2, 3, 4, 5, 1)]
    assert texts[0] == texts[-1]  # a seed replays
    assert len(set(texts)) > 1  # seeds are repetitions, not copies
    assert all(t and not t.lstrip().startswith("#") for t in texts)
    assert llama_infiller.infill(unit).text == greedy  # greedy stays greedy


def test_a_prompt_starts_from_the_saved_state_it_shares_most_with(ontology, put_in_bin, llama_session):
    """Prompt A, then an unrelated prompt B, then A again with another hint: the third call starts from
    A's saved state (the KV cache held B), evaluates only what differs, and decodes exactly what a cold
    evaluation of the whole prompt decodes."""
    session = llama_session
    diagnosis = diagnose(ontology, put_in_bin.name, put_in_bin.code, "UR5e", source=put_in_bin.source_embodiment)
    conflict = diagnosis.conflicts[-1]
    first = unit_from_conflict(put_in_bin.code, conflict, ontology.target("UR5e"))
    retry = unit_from_conflict(put_in_bin.code, conflict, ontology.target("UR5e"), feedback="wrong call", attempt=1)
    texts = [QWEN.render(p.prefix, p.suffix) for p in (build_prompt(u, 20) for u in (first, retry))]
    unrelated = QWEN.render("def area(w, h):\n    return ", "\n")
    stops = QWEN.stops

    session.forget_prompt_states()
    session.generate(texts[0], max_tokens=4, stops=stops)
    session.generate(unrelated, max_tokens=4, stops=stops)
    restored_before = session.prompt_state_stats()["restored"]
    again = session.generate(texts[1], max_tokens=24, stops=stops)
    tokens = session.tokenize(texts[1], special=True)
    shared = next(
        i for i, (a, b) in enumerate(zip(session.tokenize(texts[0], special=True), tokens, strict=False)) if a != b
    )
    assert session.prompt_state_stats()["restored"] == restored_before + 1
    assert again.evaluated_prompt_tokens == len(tokens) - (shared - shared % lookup_decoding.REUSE_ALIGN)

    session.forget_prompt_states()
    cold = session.generate(texts[1], max_tokens=24, stops=stops)
    assert cold.evaluated_prompt_tokens == len(tokens)
    assert again.text == cold.text


def test_a_prompt_is_scored_alike_whatever_the_cache_held_before(llama_session):
    """What ran before a call must not change its answer (an episode's record would depend on the
    episodes before it in the worker). llama.cpp's logits depend on where a prompt was cut into
    batches, so a prompt resumed from wherever an earlier one diverged (here at token 137) scored
    differently from a cold run (by up to 0.36 in a logit). Resumed only at aligned starts, the
    prompt's next-token logits are bit for bit the same: cold, from the live cache, and from a saved state."""
    import llama_cpp

    session = llama_session
    code = open(lookup_decoding.__file__).read()[:6000]
    prompt = session.tokenize(code)[:300]
    other = prompt[:137] + session.tokenize("# something else entirely\n" * 4)
    assert other[137] != prompt[137] and 137 % lookup_decoding.REUSE_ALIGN
    unrelated = session.tokenize("def area(w, h):\n    return w * h\n" * 3)

    def scored(*before: list[int]) -> np.ndarray:
        session.forget_prompt_states()
        for tokens in (*before, prompt):
            decoded = session.decoder.generate(tokens, max_tokens=1, stops=())  # one token: the prompt's logits stay
        n_vocab = session.llm.n_vocab()
        logits = llama_cpp.llama_get_logits_ith(session.llm._ctx.ctx, -1)
        return decoded, np.ctypeslib.as_array(logits, shape=(n_vocab,)).copy()

    cold, cold_logits = scored()
    live, live_logits = scored(other)
    restored = session.prompt_state_stats()["restored"]
    saved, saved_logits = scored(other, unrelated)
    assert (
        cold.evaluated_prompt_tokens == 300
        and live.evaluated_prompt_tokens == saved.evaluated_prompt_tokens == 300 - 128
    )
    assert session.prompt_state_stats()["restored"] == restored + 1  # the third prompt started from a saved state
    assert np.array_equal(cold_logits, live_logits) and np.array_equal(cold_logits, saved_logits)


def test_a_completion_stops_at_the_end_of_the_context_and_a_prompt_that_fills_it_gets_none():
    """A long regeneration prompt once overran llama.cpp's context mid-draft (llama_decode returned 1)
    and broke the episode off; now the completion is cut where the context ends, and a prompt that
    leaves no room is answered with nothing, for the method to judge."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_session import LlamaSession
    from lerobot_policy_recent.recent_plugin.models import model_path

    session = LlamaSession(str(model_path("qwen2.5-coder-1.5b")), n_ctx=96, state_bytes=0)
    counting = session.tokenize(", ".join(str(i) for i in range(1, 18)) + ",")  # drafts find every next number
    assert 40 < len(counting) < 80
    decoded = session.decoder.generate(counting, max_tokens=200, stops=())
    assert not decoded.context_full and 0 < decoded.generated_tokens <= 96 - len(counting)
    full = session.decoder.generate(counting * 2, max_tokens=200, stops=())
    assert full.context_full and full.text == "" and full.generated_tokens == 0
