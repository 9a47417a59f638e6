"""Validation records: which skill code passed simulation on which seeds (``skills/library/validation/``).

Data only; the episodes that produce them run in :mod:`lerobot_policy_recent.recent_plugin.authoring.sim_validation`.
Grounding serves a skill only with a record that matches its code (:func:`~lerobot_policy_recent.skills.repository.serve_skill`).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

LIBRARY = Path(__file__).with_name("library")  # the bundled skills (``repository`` serves them)


def records_dir(library: Path = LIBRARY) -> Path:
    """Validation records travel with their skills: ``<library>/validation/<skill>.json``."""
    return library / "validation"


RECORDS = records_dir(LIBRARY)


@dataclass
class ValidationRecord:
    skill: str
    code_sha256: str
    robot: str
    task: str
    seeds: list[int]
    passed: list[int] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)  # seed -> wall time of its episode
    failures: dict[str, str] = field(default_factory=dict)  # seed -> reason
    validated_at: str = ""

    @property
    def validated(self) -> bool:
        return bool(self.seeds) and sorted(self.passed) == sorted(self.seeds)

    def matches(self, code_sha256: str) -> bool:
        """Passed every seed, with exactly this code."""
        return self.validated and self.code_sha256 == code_sha256


def record_path(name: str, records: Path = RECORDS) -> Path:
    return records / f"{name}.json"


def load_record(name: str, records: Path = RECORDS) -> ValidationRecord | None:
    path = record_path(name, records)
    if not path.is_file():
        return None
    try:
        return ValidationRecord(**json.loads(path.read_text()))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: not a validation record ({exc})") from None


def save_record(record: ValidationRecord, records: Path = RECORDS) -> Path:
    path = record_path(record.skill, records)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(asdict(record), indent=2) + "\n")
    return path
