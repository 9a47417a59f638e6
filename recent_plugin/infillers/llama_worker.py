"""llama.cpp in a worker process: a native crash becomes an explained error, not a dead robot.

The agent talks to one child process that holds the loaded model (:class:`LlamaSession`). Each
request is a method call sent over a socket pair; the child answers with the result or with its
Python exception. If the child dies (a segfault or an illegal instruction in llama.cpp's CPU
kernels, or a kill), the call that was waiting raises :class:`LMWorkerCrashed`, which names the
signal, the CPU, the kernels, the wheel and the fix; the episode ends with that message in its
logs. A worker that died between calls is reported by the next call the same way. The call after
a report starts a fresh worker, so a long benchmark loses only the episode in flight.

Cost, measured in ``benchmarks/llm_runtime_bench.py`` (BENCHMARKS.md "LM runtime"): a few hundred
microseconds per call against seconds of prompt evaluation, and about a second more to start.

The worker is also where the model's prompt states live (the KV cache and the saved states of
earlier prompts): one worker serves every episode of its process (and of its Ray actor), so an
episode's LM calls start from what earlier episodes evaluated.

``python -m lerobot_policy_recent.recent_plugin.infillers.llama_worker FD MODEL OPTIONS_JSON`` is the child's entry.
"""

from __future__ import annotations

import builtins
import json
import os
import signal
import socket
import subprocess
import sys
import time
import traceback
import weakref
from multiprocessing.connection import Connection
from pathlib import Path
from typing import NoReturn

from lerobot_policy_recent.recent_plugin.cache import cache_dir
from lerobot_policy_recent.recent_plugin.infillers.llama_runtime import VARIANT_ENV, cpu_description, wheel_description

START_TIMEOUT_S = 300.0  # loading a GGUF takes 1-3 s; this only bounds a child that hangs before answering


class LMWorkerCrashed(RuntimeError):
    """The llama.cpp worker process died; the message says how, on what, and what to do."""


class LMWorkerError(RuntimeError):
    """The worker raised a Python exception that has no builtin counterpart here."""


def crash_message(returncode: int | None, doing: str, info: dict | None) -> str:
    """Why the LM is gone, in words a user can act on."""
    if returncode is None:
        how = "stopped answering"
    elif returncode < 0:
        try:
            how = f"was killed by {signal.Signals(-returncode).name}"
        except ValueError:
            how = f"was killed by signal {-returncode}"
    else:
        how = f"exited with status {returncode}"
    return f"the llama.cpp LM worker {how} while {doing}. {runtime_and_fix(info)}"


def runtime_and_fix(info: dict | None) -> str:
    """The CPU, the kernels and the wheel involved, and what to do about them."""
    kernels = (info or {}).get("cpu_kernels_path") or (info or {}).get("cpu_kernels") or "not loaded yet"
    return (
        f"CPU: {cpu_description()}. Kernels: {kernels}. Wheel: {wheel_description()}. "
        f"Fix: run `bash scripts/setup.sh` (it rebuilds llama-cpp-python with run-time-selected CPU kernels "
        f"and checks the LM before it says ready), or `recent model check` to see what fails; "
        f"{VARIANT_ENV}=haswell forces the AVX2 kernels; `--backend rule` runs without an LM."
    )


class LlamaWorker:
    """The parent's handle on the worker: the same calls as :class:`LlamaSession`, across a process."""

    def __init__(
        self, model_path: str, *, env: dict[str, str] | None = None, site: str | None = None, **session_options
    ):
        """``session_options`` are :class:`LlamaSession`'s (``n_threads``, ``n_ctx``, ``seed``,
        ``state_bytes``), handed to the child as they are. ``env``: more environment for the child
        (e.g. a forced CPU variant); ``site``: a directory whose ``llama_cpp`` the child imports
        first (the runtime benchmark compares builds this way)."""
        self._args = [model_path, json.dumps(session_options)]
        self._env, self._site = dict(env or {}), site
        self._info: dict | None = None
        self._conn: Connection | None = None
        self._proc: subprocess.Popen | None = None
        self._start()

    # ------------------------------------------------------------------ lifecycle
    def _start(self) -> None:
        ours, theirs = socket.socketpair()
        env = {**os.environ, **self._env}
        env["PYTHONPATH"] = os.pathsep.join(p for p in [self._site, *sys.path, env.get("PYTHONPATH")] if p)
        notes = worker_log()
        notes.parent.mkdir(parents=True, exist_ok=True)
        with open(notes, "ab") as stderr:  # llama.cpp's banners go here, not to the user's terminal
            stderr.write(f"--- LM worker started {time.strftime('%Y-%m-%d %H:%M:%S')}\n".encode())
            stderr.flush()
            self._proc = subprocess.Popen(
                [sys.executable, "-m", __name__, str(theirs.fileno()), *self._args],
                pass_fds=(theirs.fileno(),),
                env=env,
                stdin=subprocess.DEVNULL,
                stderr=stderr,
            )
        theirs.close()
        self._conn = Connection(ours.detach())
        self._finalizer = weakref.finalize(self, _stop, self._proc, self._conn)
        if not self._conn.poll(START_TIMEOUT_S):
            self._died("loading the model")
        try:
            self._info = self._receive("loading the model")
        except LMWorkerCrashed:
            raise
        except Exception:  # the model did not load (a bad file, an unusable variant): the worker has exited
            self.close()
            raise

    @property
    def pid(self) -> int | None:
        return self._proc.pid if self._proc is not None else None

    @property
    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def close(self) -> None:
        """Stop the worker (it also stops when this handle is collected or the parent exits)."""
        if self._proc is not None:
            self._finalizer()
            self._proc = self._conn = None

    # ------------------------------------------------------------------ calls
    def _call(self, method: str, *args, **kwargs):
        if self._proc is not None and self._proc.poll() is not None:
            self._died("idle between calls")  # every death is reported once; the call after it gets a fresh worker
        if self._proc is None:
            self._start()
        doing = f"answering {method}()"
        try:
            self._conn.send((method, args, kwargs))
        except (OSError, EOFError):
            self._died(doing)
        return self._receive(doing)

    def _receive(self, doing: str):
        try:
            status, payload = self._conn.recv()
        except (OSError, EOFError):
            self._died(doing)
        if status == "ok":
            return payload
        kind, message, remote_traceback = payload
        exc_type = getattr(builtins, kind, None)  # ValueError stays a ValueError; anything else is wrapped
        if isinstance(exc_type, type) and issubclass(exc_type, Exception):
            raise exc_type(f"{message} (in the LM worker)")
        raise LMWorkerError(f"{kind}: {message}\n{remote_traceback}")

    def _died(self, doing: str) -> NoReturn:
        returncode = None
        if self._proc is not None:
            try:
                returncode = self._proc.wait(timeout=5)
            except subprocess.TimeoutExpired:  # alive but silent: ours is the kill, not the cause
                self._proc.kill()
                self._proc.wait()
        info = self._info
        self.close()
        raise LMWorkerCrashed(crash_message(returncode, doing, info) + _last_notes())

    def info(self) -> dict:
        return dict(self._info or {})

    def tokenize(self, text: str, special: bool = False) -> list[int]:
        return self._call("tokenize", text, special)

    def generate(self, text: str, **options):
        """:meth:`LlamaSession.generate` in the worker (``max_tokens``, ``stops``, ``gbnf``, ``temperature``,
        ``seed``, ``draft_text``)."""
        return self._call("generate", text, **options)

    def speed(self, prompt: str, *, repeats: int = 3, gen_tokens: int = 64) -> dict[str, float]:
        return self._call("speed", prompt, repeats=repeats, gen_tokens=gen_tokens)

    def forget_prompt_states(self) -> None:
        return self._call("forget_prompt_states")

    def prompt_state_stats(self) -> dict[str, int]:
        return self._call("prompt_state_stats")


def worker_log() -> Path:
    """Where LM workers write their stderr (llama.cpp's notes and any crash report), appended per start."""
    return cache_dir() / "logs" / "llm_worker.log"


def _last_notes(lines: int = 8) -> str:
    """The end of the workers' log, for a crash message (what llama.cpp said before it died)."""
    try:
        tail = worker_log().read_text(errors="replace").splitlines()[-lines:]
    except OSError:
        return ""
    return f"\nthe worker's last output ({worker_log()}):\n  " + "\n  ".join(tail) if tail else ""


def _stop(proc: subprocess.Popen, conn: Connection) -> None:
    try:
        conn.send(("close", (), {}))
    except (OSError, EOFError, ValueError):
        pass
    conn.close()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


# ---------------------------------------------------------------------------------------------- the child
CALLS = ("tokenize", "generate", "speed", "info", "forget_prompt_states", "prompt_state_stats")


def serve(conn: Connection, model_path: str, session_options: dict) -> None:
    """Load the model, say ready with its info, then answer calls until told to close (or the parent goes)."""
    from lerobot_policy_recent.recent_plugin.infillers.llama_session import LlamaSession

    try:
        session = LlamaSession(model_path, **session_options)
        conn.send(("ok", session.info()))
    except Exception as exc:  # noqa: BLE001 - a load error travels to the parent as its own exception
        conn.send(("error", (type(exc).__name__, str(exc), traceback.format_exc())))
        return
    while True:
        try:
            method, args, kwargs = conn.recv()
        except (EOFError, OSError):
            return  # the parent is gone
        if method == "close":
            return
        try:
            if method not in CALLS:
                raise ValueError(f"unknown LM worker call {method!r}")
            conn.send(("ok", getattr(session, method)(*args, **kwargs)))
        except Exception as exc:  # noqa: BLE001 - every Python error is the caller's to handle
            conn.send(("error", (type(exc).__name__, str(exc), traceback.format_exc())))


def main(argv: list[str]) -> None:
    fd, model_path, session_options = argv
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle; it then closes us
    serve(Connection(int(fd)), model_path, json.loads(session_options))


if __name__ == "__main__":
    main(sys.argv[1:])
