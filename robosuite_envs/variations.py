"""Environmental variations: switchable, seeded changes to the world that a skill must cope with.

:func:`plan_variations` decides *what* changes and *when* from the task and the episode's RNG;
the env (:mod:`lerobot_policy_recent.robosuite_envs.tabletop`) applies the plan to the simulation.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from lerobot_policy_recent.robosuite_envs.objects import get_kind
from lerobot_policy_recent.robosuite_envs.tasks import TaskSpec

VARIATIONS: dict[str, str] = {
    "pose_perturbation": "the manipulated object is displaced 4-6 cm after planning, before the grasp",
    "sensing_noise": "Gaussian noise (sigma 4 mm) on the observed object positions",
    "obstacle": "a non-graspable slab lands in the placement target mid-task (sweep it, do not pick it)",
    "slippery": "graspable objects get low friction and slip from grasps",
    "heavy": "graspable objects weigh eight times more",
    "non_flat": "the manipulated block is replaced by a ball of the same width (no face for suction)",
    "porous": "the manipulated object is porous: a suction cup cannot seal on it",
    "far_target": "the placement target moves outside the smaller robot's workspace",
}
ON = ("pose_perturbation", "sensing_noise", "obstacle")  # the paper's perturbations: `--variations on`
MIX = "mix"
# `--variations mix` (the benchmark's default): each episode draws every variation independently,
# on with this probability, from its task and seed, so all eight are in play in stated shares.
MIX_SHARES: dict[str, float] = {
    "pose_perturbation": 0.5,
    "sensing_noise": 0.5,
    "obstacle": 0.4,
    "slippery": 0.2,
    "heavy": 0.2,
    "non_flat": 0.2,
    "porous": 0.2,
    "far_target": 0.1,
}

NOISE_SIGMA = 0.004
PERTURB_STEPS = (2, 6)  # after the skill read the object's position, before the approach starts
OBSTACLE_STEPS = (40, 60)  # mid-task: while the object is being fetched
FAR_TARGET_XY = (0.33, 0.31)  # beyond a UR5e's reach from the table-side base at (-0.56, 0)
TARGET_KINDS = ("plate", "region", "bin", "pen")
OBSTACLE = "obstacle"


def parse_variations(text: str | None) -> tuple[str, ...]:
    """``""``/``"off"``/``"none"`` → none; ``"on"`` → the paper's set; ``"all"``; ``"mix"`` (drawn per
    episode, :func:`episode_variations`); or a comma list."""
    text = (text or "").strip()
    if text in ("", "off", "none"):
        return ()
    if text == "on":
        return ON
    if text == MIX:
        return (MIX,)
    if text == "all":
        return tuple(VARIATIONS)
    names = tuple(dict.fromkeys(t.strip() for t in text.split(",") if t.strip()))
    unknown = [n for n in names if n not in VARIATIONS]
    if unknown:
        raise ValueError(
            f"unknown variation(s) {', '.join(unknown)}; known: {', '.join(VARIATIONS)} (or on, all, mix, off)"
        )
    return names


def episode_variations(variations: tuple[str, ...], task_id: str, seed: int | None) -> tuple[str, ...]:
    """The variations of one episode: ``variations`` as given, or for ``mix`` a draw seeded by the task
    and the seed (the same episode always gets the same set; each variation is on with its share)."""
    if variations != (MIX,):
        return variations
    rng = np.random.default_rng([zlib.crc32(task_id.encode()), seed or 0])
    draws = rng.random(len(MIX_SHARES))
    return tuple(name for (name, share), u in zip(MIX_SHARES.items(), draws, strict=True) if u < share)


def manipulated_object(task: TaskSpec) -> str | None:
    """The first graspable object the plan acts on (what perturbation, slipping and suction target)."""
    for step in task.plan:
        for name in step.args.values():
            if name in task.object_names() and get_kind(task.spec(name).kind).graspable:
                return name
    return None


def target_object(task: TaskSpec) -> str | None:
    """The first placement target of the plan (a plate, region, bin or pen) — where obstacles land."""
    for step in task.plan:
        for name in step.args.values():
            if name in task.object_names() and task.spec(name).kind in TARGET_KINDS:
                return name
    return None


@dataclass(frozen=True)
class VariationPlan:
    """One episode's concrete variations."""

    enabled: tuple[str, ...]
    perturb_object: str | None = None
    perturb_step: int = -1
    perturb_offset: tuple[float, float] = (0.0, 0.0)
    obstacle_target: str | None = None
    obstacle_step: int = -1
    noise_sigma: float = 0.0
    friction_scale: float = 1.0
    mass_scale: float = 1.0
    far_target: str | None = None


def plan_variations(task: TaskSpec, enabled: tuple[str, ...], rng: np.random.Generator) -> VariationPlan:
    """Draw this episode's variations; the same seed gives the same plan."""
    draws = {
        "angle": rng.uniform(0, 2 * np.pi),
        "distance": rng.uniform(0.04, 0.06),
        "perturb_step": int(rng.integers(*PERTURB_STEPS)),
        "obstacle_step": int(rng.integers(*OBSTACLE_STEPS)),
    }  # drawn unconditionally so enabling one variation does not shift another's draws
    manipulated, target = manipulated_object(task), target_object(task)
    has_obstacle = OBSTACLE in task.object_names()
    return VariationPlan(
        enabled=enabled,
        perturb_object=manipulated if "pose_perturbation" in enabled else None,
        perturb_step=draws["perturb_step"],
        perturb_offset=(
            float(draws["distance"] * np.cos(draws["angle"])),
            float(draws["distance"] * np.sin(draws["angle"])),
        ),
        obstacle_target=target if "obstacle" in enabled and has_obstacle else None,
        obstacle_step=draws["obstacle_step"],
        noise_sigma=NOISE_SIGMA if "sensing_noise" in enabled else 0.0,
        friction_scale=0.08 if "slippery" in enabled else 1.0,
        mass_scale=8.0 if "heavy" in enabled else 1.0,
        far_target=target if "far_target" in enabled else None,
    )
