"""Grounded skills on disk, so a second process grounding the same skill for the same robot reads it back.

A grounding is keyed by everything that could change it: the skill's code, the target, the
ontology (built from every robot's API spec and MJCF, so a changed spec changes it), the model's
sha256, the backend's settings, the method and its budgets, and the code that asks the LM and
judges its answers (:func:`grounding_code_digest`: a new prompt format or hint is a new key, not
a stale program read back). A key that differs in any of them
is another file; nothing is ever invalidated in place. The store lives under the project's cache
dir (``$RECENT_GROUNDING_CACHE`` overrides the directory; ``off`` turns it off), is bounded in
size (oldest-read files go first), and ``recent cache clear`` empties it.

Files are JSON, decoded by the types :class:`GroundedSkill` declares
(:mod:`~lerobot_policy_recent.recent_plugin.typed_json`): a file holds data only, so one planted
in the cache can at worst be a wrong grounding of its key, never code that runs on load. One that
does not decode (another version, a truncated write, a file this package did not write) is
dropped with a warning naming it, and the skill is grounded again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
from pathlib import Path

from lerobot_policy_recent.recent_plugin.cache import cache_dir
from lerobot_policy_recent.recent_plugin.grounding.grounder import GroundedSkill
from lerobot_policy_recent.recent_plugin.typed_json import decode, encode

log = logging.getLogger(__name__)

ENV = "RECENT_GROUNDING_CACHE"
FORMAT = 3  # bump when GroundedSkill's shape changes: old files then simply never match (2 and before: pickles)
MAX_BYTES = 256 * 1024 * 1024
SUFFIX = ".grounding"


# What shapes a grounding besides its inputs: the diagnosis and the conversions it renders, how units
# are cut and prompted, how each backend, baseline and ablation asks, and how answers are validated (package
# folders, relative to the package root).
GROUNDING_CODE = (
    "ontology",
    "recent_plugin/refactoring",
    "recent_plugin/infillers",
    "evaluation/baselines",
    "evaluation",
    "recent_plugin/grounding",
)


@functools.cache
def grounding_code_digest(root: Path = Path(__file__).parents[2]) -> str:
    """sha256 (16 hex digits) of the Python sources and YAML data under ``GROUNDING_CODE`` of ``root``, in
    path order (the ontology's condition vocabulary is YAML: a condition checked for every robot is a new key)."""
    digest = hashlib.sha256()
    for folder in GROUNDING_CODE:
        for source in sorted([*(root / folder).glob("*.py"), *(root / folder).glob("*.yaml")]):
            digest.update(f"{folder}/{source.name}\n".encode())
            digest.update(source.read_bytes())
    return digest.hexdigest()[:16]


def store_dir() -> Path | None:
    """Where grounded skills are kept: ``$RECENT_GROUNDING_CACHE``, else ``<cache dir>/groundings``; None if off."""
    value = os.environ.get(ENV, "").strip()
    if value.lower() in ("off", "0", "false", "no"):
        return None
    return Path(value).expanduser() if value else cache_dir() / "groundings"


class GroundingStore:
    """A size-bounded directory of grounded skills, one file per key."""

    def __init__(self, root: Path, max_bytes: int = MAX_BYTES) -> None:
        self.root = root
        self.max_bytes = max_bytes

    def path(self, key: tuple[str, ...]) -> Path:
        digest = hashlib.sha256(json.dumps([FORMAT, *key]).encode()).hexdigest()
        return self.root / f"{digest}{SUFFIX}"

    def get(self, key: tuple[str, ...]) -> GroundedSkill | None:
        path = self.path(key)
        try:
            document = json.loads(path.read_bytes())
            if not isinstance(document, dict) or document.get("format") != FORMAT:
                raise ValueError(f"not a grounding of format {FORMAT}")
            grounded = decode(GroundedSkill, document.get("grounded"))
        except FileNotFoundError:
            return None
        except (ValueError, TypeError, OSError) as exc:  # a file that does not decode is a miss, and is removed
            log.warning("grounding cache: dropping %s (%s: %s)", path, type(exc).__name__, exc)
            path.unlink(missing_ok=True)
            return None
        os.utime(path)  # read recently: evicted last
        return grounded

    def put(self, key: tuple[str, ...], grounded: GroundedSkill) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        path = self.path(key)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        try:
            tmp.write_text(json.dumps({"format": FORMAT, "grounded": encode(grounded)}))
            os.replace(tmp, path)  # whole or not at all: another process never reads half a file
        except OSError as exc:  # a full or read-only disk costs the cache, not the episode
            log.warning("grounding cache: could not write %s (%s)", path, exc)
            tmp.unlink(missing_ok=True)
            return
        self.evict()

    def files(self) -> list[Path]:
        return sorted(self.root.glob(f"*{SUFFIX}"), key=lambda p: p.stat().st_mtime) if self.root.is_dir() else []

    def size(self) -> int:
        return sum(p.stat().st_size for p in self.files())

    def evict(self) -> None:
        """Remove the least recently read files until the store fits ``max_bytes``."""
        files = self.files()
        total = sum(p.stat().st_size for p in files)
        for path in files:
            if total <= self.max_bytes:
                break
            total -= path.stat().st_size
            path.unlink(missing_ok=True)

    def clear(self) -> tuple[int, int]:
        """Remove every stored grounding; (files, bytes) removed."""
        files, size = self.files(), self.size()
        for path in files:
            path.unlink(missing_ok=True)
        return len(files), size


def default_store() -> GroundingStore | None:
    root = store_dir()
    return GroundingStore(root) if root else None
