"""``RecentSettings``: the one settings tree of grounding and execution.

The ``recent`` CLI builds its options from these dataclasses (``--infiller.type=rule``,
``--method.type=cap``, ``--max_retries=3``), and ``RecentConfig`` extends them with LeRobot's
policy fields, so ``lerobot-eval --policy.infiller.type=rule`` is the same option. A run records
``draccus.encode`` of the resolved tree, and :func:`settings_flags` turns that dump back into the
flags that reproduce it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import get_type_hints

import draccus

from lerobot_policy_recent.recent_plugin.infillers.configs import InfillerConfig, LlamaCppConfig
from lerobot_policy_recent.recent_plugin.methods import Method
from lerobot_policy_recent.recent_plugin.methods.recent import RecentFastPath
from lerobot_policy_recent.recent_plugin.sandbox import SkillBudget


@dataclass
class RecentSettings:
    """Which LM, which method, and the budgets of grounding and execution."""

    infiller: InfillerConfig = field(default_factory=LlamaCppConfig)  # the LM that fills the units, or rule
    # The product's default asks the LM only what the ontology leaves open (``recent+fast-path``); the
    # paper's method (``recent``: the LM writes every conflicting span), its ablations and the
    # baselines are named methods
    method: Method = field(default_factory=RecentFastPath)
    max_retries: int = 2  # retries per rejected span
    # reactive repairs of failed segments, per skill: RECENT's (its repairs re-read and retry, mostly rendered
    # without the LM); a baseline's repairs are all LM calls, so its loop runs until the task's LM budget
    # is spent, and this caps it only where there is no budget (--max_lm_calls=0, the rule backend)
    max_repairs: int = 2
    # LM calls per task, grounding and run time together, the same for every method; 0: no limit. A paper-length
    # task gets TaskSpec.lm_calls_per_primitive calls per primitive call of its skills where that is more
    max_lm_calls: int = 24
    lm_seed: int = 0  # the LM's sampling seed (the episode seed is the env's)
    # seeded sampling, each episode seeded by lm_seed and its own seed, so seeds are real repetitions (0.2: Codex's
    # pass@1 temperature); 0: greedy
    temperature: float = 0.2
    max_skill_steps: int = 3000  # control steps a skill may take before it is stopped
    skill_budget: SkillBudget = field(default_factory=SkillBudget)  # Python time and memory a skill's code may use
    # a directory of your skills (NAME.py + NAME.yaml, records in validation/), served before the bundled
    # skills of the same name; None: the bundled skills alone
    skill_library: str | None = None

    def __post_init__(self):
        for name in ("max_retries", "max_repairs", "max_lm_calls", "temperature"):
            if getattr(self, name) < 0:
                raise ValueError(f"--{name} must be >= 0, got {getattr(self, name)}")
        if self.max_skill_steps < 1:
            raise ValueError(f"--max_skill_steps must be >= 1, got {self.max_skill_steps}")
        if self.skill_library is not None and not Path(self.skill_library).is_dir():
            raise ValueError(f"--skill_library: {self.skill_library!r} is not a directory")

    def to_dict(self) -> dict:
        """The resolved tree as plain data (what a run records)."""
        types = get_type_hints(RecentSettings)
        return {f.name: draccus.encode(getattr(self, f.name), types[f.name]) for f in fields(RecentSettings)}


def settings_flags(tree: dict, prefix: str = "") -> list[str]:
    """``{"infiller": {"type": "rule"}, "max_retries": 2}`` → ``["--infiller.type=rule", "--max_retries=2"]``."""
    flags = []
    for key, value in tree.items():
        if isinstance(value, dict):
            flags += settings_flags(value, f"{prefix}{key}.")
        elif value is not None:
            flags.append(f"--{prefix}{key}={str(value).lower() if isinstance(value, bool) else value}")
    return flags


def parse_settings(flags: list[str]) -> RecentSettings:
    """The tree from ``--path=value`` flags (draccus decodes and checks types and choices); a bad
    value is a :class:`ValueError` that names the option."""
    try:
        return draccus.parse(RecentSettings, args=flags)
    except draccus.utils.ParsingError as error:
        cause = error.__cause__ or error.__context__
        where = ".".join(getattr(error, "key_path", ()) or ())
        what = str(cause) if isinstance(cause, ValueError) else getattr(error, "message", str(error))
        raise ValueError(f"--{where}: {what}" if where else what) from None
