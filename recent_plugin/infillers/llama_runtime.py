"""Which llama.cpp CPU kernels this process runs: chosen when the library loads, never at build time.

The project builds llama-cpp-python with ``GGML_NATIVE=OFF GGML_BACKEND_DL=ON GGML_CPU_ALL_VARIANTS=ON``
(``pyproject.toml``): the CPU kernels are shared libraries ``libggml-cpu-<variant>.so`` beside
``libllama.so``, one per instruction-set level (``x64`` … ``haswell`` (AVX2) … ``zen4`` (AVX-512 +
VNNI + BF16) … ``sapphirerapids`` (+ AMX)). A wheel built on one host therefore runs on every x86-64
host: each variant reports a score of 0 where the CPU lacks one of its instructions, and the best
supported one is loaded here, before the model.

AMX variants are left out unless asked for by name: on an AMX-capable Xeon, llama.cpp's AMX
kernels crashed in ``llama_decode`` while the same CPU ran AVX-512 + VNNI + BF16 kernels correctly
and at the same generation speed (docs/llm_runtime.md).

``RECENT_LLAMA_CPU_VARIANT=<variant>`` forces a variant (e.g. ``haswell`` for AVX2 only, or
``sapphirerapids`` to try AMX); a variant the CPU cannot run is refused with an error.
"""

from __future__ import annotations

import ctypes
import os
import platform
import re
from dataclasses import dataclass, field
from pathlib import Path

VARIANT_ENV = "RECENT_LLAMA_CPU_VARIANT"
AMX_VARIANTS = frozenset({"sapphirerapids"})  # llama.cpp's only x86 variant with AMX tiles
_VARIANT_RE = re.compile(r"^libggml-cpu-(.+?)\.so(\.\d+)*$")
_FLAGS_SHOWN = re.compile(r"^(avx2|avx512\w*|amx\w*|avx_vnni|fma|f16c)$")


class CpuKernelsError(RuntimeError):
    """No CPU kernels of the installed llama.cpp can run here (or the forced one cannot)."""


@dataclass(frozen=True)
class CpuKernels:
    """What was loaded: the variant, its library and score, and what else the build offered."""

    variant: str  # e.g. "zen4"; "built-in" for a llama.cpp built without run-time variants
    path: str | None
    score: int
    scores: dict[str, int] = field(default_factory=dict)  # variant -> score on this CPU (0: cannot run here)
    left_out: tuple[str, ...] = ()  # variants not tried: AMX unless forced

    def describe(self) -> str:
        if self.variant == "built-in":
            return (
                "built-in CPU kernels (a llama.cpp build without run-time variants: tied to the CPU it was built for)"
            )
        return f"CPU kernels '{self.variant}' ({Path(self.path or '').name})"


def package_dir() -> Path:
    """The installed ``llama_cpp`` package, found without importing (and so without loading) it."""
    import importlib.util

    spec = importlib.util.find_spec("llama_cpp")
    if spec is None or not spec.submodule_search_locations:
        raise CpuKernelsError("llama-cpp-python is not installed; run `bash scripts/setup.sh`")
    return Path(next(iter(spec.submodule_search_locations)))


def variant_libraries(lib_dir: Path | None = None) -> dict[str, Path]:
    """The CPU-kernel variants the installed build ships, by name (empty for a build without variants)."""
    lib_dir = lib_dir or package_dir() / "lib"
    found = {}
    for path in sorted(lib_dir.glob("libggml-cpu-*.so*")):
        if (m := _VARIANT_RE.match(path.name)) and not path.is_symlink():
            found[m.group(1)] = path
    return found


def choose_variant(scores: dict[str, int], forced: str | None = None) -> str:
    """The variant to load: ``forced`` if the CPU can run it, else the best-scoring non-AMX one."""
    if forced:
        if forced not in scores:
            known = ", ".join(sorted(scores)) or "none"
            raise CpuKernelsError(f"{VARIANT_ENV}={forced}: this llama.cpp build has no such variant (it has: {known})")
        if scores[forced] <= 0:
            raise CpuKernelsError(f"{VARIANT_ENV}={forced}: this CPU lacks instructions that variant needs")
        return forced
    usable = {name: s for name, s in scores.items() if s > 0 and name not in AMX_VARIANTS}
    if not usable:
        raise CpuKernelsError(
            "none of llama.cpp's CPU-kernel variants can run on this CPU "
            f"({cpu_description()}); scores: {scores or 'no variants found'}"
        )
    return max(usable, key=lambda name: (usable[name], name))


def _score(path: Path) -> int:
    """The variant's own verdict on this CPU: 0 if it needs an instruction the CPU lacks."""
    lib = ctypes.CDLL(str(path), mode=os.RTLD_LOCAL)
    lib.ggml_backend_score.restype = ctypes.c_int
    return int(lib.ggml_backend_score())


_LOADED: CpuKernels | None = None


def load_cpu_kernels() -> CpuKernels:
    """Load the chosen CPU kernels into this process (once); call before the first ``llama_cpp.Llama``."""
    global _LOADED
    if _LOADED is not None:
        return _LOADED
    libggml = _libllamas_ggml()
    if libggml.ggml_backend_reg_count() > 0:  # a build whose CPU kernels are linked in (no variants)
        _LOADED = CpuKernels("built-in", None, 0)
        return _LOADED
    variants = variant_libraries(package_dir() / "lib")
    if not variants:
        raise CpuKernelsError(f"llama.cpp has no CPU kernels to load: no libggml-cpu-*.so in {package_dir() / 'lib'}")
    forced = os.environ.get(VARIANT_ENV, "").strip() or None
    left_out = tuple(sorted(name for name in variants if name in AMX_VARIANTS and name != forced))
    scores = {name: _score(path) for name, path in variants.items() if name not in left_out}
    name = choose_variant(scores, forced)
    if not libggml.ggml_backend_load(str(variants[name]).encode()):
        raise CpuKernelsError(f"llama.cpp could not load its CPU kernels {variants[name]}")
    _LOADED = CpuKernels(name, str(variants[name]), scores[name], scores, left_out)
    return _LOADED


def _libllamas_ggml() -> ctypes.CDLL:
    """The libggml that libllama itself linked (its registry is the one a model load consults).

    The wheel holds ``libggml.so`` and ``libggml.so.0`` as two copies, not a symlink, and
    ``llama_cpp._ggml`` loads the first: a backend registered there is invisible to libllama, which
    resolves its ``DT_NEEDED`` ``libggml.so.0`` next to itself. Opening that path returns its handle.
    """
    import llama_cpp.llama_cpp  # noqa: F401  (loads libllama and, with it, its libggml)

    lib_dir = package_dir() / "lib"
    path = next((p for p in (lib_dir / "libggml.so.0", lib_dir / "libggml.so") if p.exists()), None)
    if path is None:
        raise CpuKernelsError(f"no libggml.so in {lib_dir}: is llama-cpp-python installed completely?")
    libggml = ctypes.CDLL(str(path))
    libggml.ggml_backend_reg_count.restype = ctypes.c_size_t
    libggml.ggml_backend_load.argtypes = [ctypes.c_char_p]
    libggml.ggml_backend_load.restype = ctypes.c_void_p
    return libggml


def cpu_description() -> str:
    """The CPU's model name and the vector-instruction flags that decide which kernels can run."""
    model, flags = platform.processor() or platform.machine(), []
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and model in {"", platform.machine()}:
                model = value.strip()
            elif key.strip() == "flags" and not flags:
                flags = [f for f in value.split() if _FLAGS_SHOWN.match(f)]
    except OSError:
        pass
    return f"{model}; flags: {' '.join(flags) or 'no AVX2'}"


def wheel_description() -> str:
    """llama-cpp-python's version and where it is installed (what a fix has to rebuild)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        installed = version("llama-cpp-python")
    except PackageNotFoundError:
        installed = "not installed"
    try:
        where = str(package_dir())
    except CpuKernelsError:
        where = "-"
    return f"llama-cpp-python {installed} at {where}"
