"""The LM smoke check that setup runs before it says "ready", and CI runs as a test.

It starts the same worker process the agent uses, lets the model fill one tiny FIM span whose
right answer is known, and checks the answer. A worker that dies (a signal in llama.cpp's
kernels), fails to load, or answers wrong fails the check with a message that names the CPU, the
kernels, the wheel and the fix, so nobody meets the problem as a segfault in the middle of a run.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

from lerobot_policy_recent.recent_plugin.infillers.fim_formats import FORMATS

QWEN = FORMATS["qwen2.5-coder"]
PREFIX = 'def add(a, b):\n    """Return the sum of a and b."""\n    return '
SUFFIX = "\n\n\nassert add(2, 3) == 5\n"
RIGHT = {"a+b", "b+a", "(a+b)", "sum((a,b))"}


@dataclass
class LMCheck:
    ok: bool
    model: str
    answer: str = ""
    problem: str = ""
    load_seconds: float = 0.0
    answer_seconds: float = 0.0
    info: dict = field(default_factory=dict)

    def summary(self) -> str:
        if not self.ok:
            return f"LM check FAILED for {self.model}: {self.problem}"
        return (
            f"LM check ok: {self.model} filled `{self.answer}` in {self.answer_seconds:.2f} s "
            f"(loaded in {self.load_seconds:.1f} s) on CPU kernels '{self.info.get('cpu_kernels')}', "
            f"{self.info.get('n_threads')} threads; {self.info.get('wheel')}"
        )

    def to_dict(self) -> dict:
        return asdict(self)


def check_lm(model_path: str, *, n_threads: int | None = None) -> LMCheck:
    """Load ``model_path`` in a worker process and check one known FIM answer; never raises for a bad LM."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_worker import LlamaWorker, LMWorkerCrashed, runtime_and_fix

    name = model_path.rsplit("/", 1)[-1]
    started = time.perf_counter()
    try:
        worker = LlamaWorker(model_path, n_threads=n_threads)
    except LMWorkerCrashed as exc:
        return LMCheck(False, name, problem=str(exc))
    except Exception as exc:  # noqa: BLE001 - a load failure is the check's verdict, not a traceback
        return LMCheck(False, name, problem=f"{type(exc).__name__}: {exc}. {runtime_and_fix(None)}")
    load_seconds = time.perf_counter() - started
    info = worker.info()
    try:
        started = time.perf_counter()
        out = worker.generate(QWEN.render(PREFIX, SUFFIX), max_tokens=8, stops=("\n", *QWEN.stops))
        seconds = time.perf_counter() - started
    except LMWorkerCrashed as exc:
        return LMCheck(False, name, problem=str(exc), load_seconds=load_seconds, info=info)
    finally:
        worker.close()
    answer = out.text.strip()
    if "".join(answer.split()) not in RIGHT:
        problem = (
            f"the model answered {answer!r} where `a + b` is right: the kernels run but compute wrong numbers. "
            + runtime_and_fix(info)
        )
        return LMCheck(False, name, answer, problem, load_seconds, seconds, info)
    return LMCheck(True, name, answer, "", load_seconds, seconds, info)
