"""Saved llama.cpp prompt states: the KV cache of earlier prompts, kept so a later prompt starts from one.

On a CPU, what an LM call costs is evaluating its prompt. The KV cache holds only the last
prompt, so a call reuses nothing when another skill's call came in between: an in-situ patch of
``put_in_bin`` after ``place_on_plate`` was grounded, the same check's patch in the next episode.
After each prompt is evaluated its sequence state (the KV cells, ~28 KB a token for the 1.5B) is
saved here; the next prompt starts from the saved state it shares the longest start with, and
evaluates only the rest. The store is an LRU bounded in bytes.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

STATE_BUDGET_BYTES = 256 * 2**20  # ~9,000 prompt tokens of the 1.5B's KV cache; the model itself is 1.2 GB


@dataclass(frozen=True)
class SavedState:
    tokens: np.ndarray  # the prompt the state was saved after
    data: object  # the opaque sequence state (a ctypes byte array)
    size: int


def shared_start(a: np.ndarray, b: np.ndarray) -> int:
    """How many leading tokens ``a`` and ``b`` share."""
    n = min(len(a), len(b))
    differ = np.flatnonzero(a[:n] != b[:n])
    return int(differ[0]) if len(differ) else n


class PromptStates:
    """An LRU of saved prompt states, bounded by ``budget_bytes`` (0: keep none)."""

    def __init__(self, budget_bytes: int = STATE_BUDGET_BYTES):
        self.budget_bytes = budget_bytes
        self._states: OrderedDict[bytes, SavedState] = OrderedDict()
        self._bytes = 0
        self.restored = 0  # how many prompts started from a saved state (for benchmarks)

    def __len__(self) -> int:
        return len(self._states)

    @property
    def bytes(self) -> int:
        return self._bytes

    def best(self, prompt: np.ndarray) -> tuple[SavedState, int] | None:
        """The saved state sharing the longest start with ``prompt``, and how long that start is."""
        found, longest = None, 0
        for state in self._states.values():
            shared = shared_start(state.tokens, prompt)
            if shared > longest:
                found, longest = state, shared
        if found is None:
            return None
        self._states.move_to_end(found.tokens.tobytes())
        return found, longest

    def save(self, tokens: np.ndarray, data: object, size: int) -> None:
        """Keep ``data`` as the state after ``tokens``; evict the least recently used beyond the budget."""
        if size > self.budget_bytes:
            return
        for key in [k for k, s in self._states.items() if shared_start(s.tokens, tokens) == len(s.tokens)]:
            self._bytes -= self._states.pop(key).size  # a state the new one extends is never the better start
        key = tokens.tobytes()
        self._states[key] = SavedState(tokens.copy(), data, size)
        self._bytes += size
        while self._bytes > self.budget_bytes:
            _, evicted = self._states.popitem(last=False)
            self._bytes -= evicted.size

    def clear(self) -> None:
        self._states.clear()
        self._bytes = 0
