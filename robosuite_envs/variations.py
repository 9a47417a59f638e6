"""Environmental variations: switchable, seeded changes to the world that a skill must cope with.

:func:`plan_variations` decides *what* changes and *when* from the task and the episode's RNG;
the env (:mod:`lerobot_policy_recent.robosuite_envs.tabletop`) applies the plan to the simulation.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, replace

import numpy as np

from lerobot_policy_recent.robosuite_envs.objects import get_kind
from lerobot_policy_recent.robosuite_envs.observation import POSITION_SIGMA
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
    "odd_obstacle": "the obstacle that lands mid-task is a wider slab, a crate or an upright post, of a drawn size and "
    "mass (0.05-1.5 kg): shapes the checks were never written for",
    "far_perturbation": "as pose_perturbation, twice as far (8-12 cm): a magnitude the paper's perturbation never reaches",
    "seal_failure": "the manipulated object's face leaks once a suction cup has carried it 1.5 s: it drops, and no cup "
    "seals on it again (discovered mid-task; finger grippers are unaffected)",
}
ON = ("pose_perturbation", "sensing_noise", "obstacle")  # the paper's perturbations: `--variations on`
MIX = "mix"
# `--variations mix` (the benchmark's default): each episode draws every variation independently,
# on with this probability, from its task and seed, so all of them are in play in stated shares.
MIX_SHARES: dict[str, float] = {
    "pose_perturbation": 0.5,
    "sensing_noise": 0.5,
    "obstacle": 0.4,
    "slippery": 0.2,
    "heavy": 0.2,
    "non_flat": 0.2,
    "porous": 0.2,
    "far_target": 0.1,
    "odd_obstacle": 0.2,  # drawn after the first eight: adding them left those draws as they were
    "far_perturbation": 0.1,
    "seal_failure": 0.1,
}

NOISE_SIGMA = POSITION_SIGMA  # the perception as its accuracy states it
PERTURB_STEPS = (2, 6)  # after the skill read the object's position, before the approach starts
OBSTACLE_STEPS = (40, 60)  # mid-task: while the object is being fetched
FAR_TARGET_XY = (0.33, 0.31)  # beyond a UR5e's reach from the table-side base at (-0.56, 0)
TARGET_KINDS = ("plate", "region", "bin", "pen")
OBSTACLE = "obstacle"
OBSTACLES = ("obstacle", "odd_obstacle")  # variations that drop the scene's obstacle on the target
PERTURBATIONS = ("pose_perturbation", "far_perturbation")
# odd_obstacle's shapes: (kind, smallest extents, largest extents), x = y for the post (its diameter)
ODD_OBSTACLES = (
    ("slab", (0.12, 0.12, 0.015), (0.16, 0.16, 0.025)),  # wider and thinner than the 10 x 10 x 3 cm slab
    ("crate", (0.06, 0.06, 0.05), (0.08, 0.08, 0.07)),  # narrower than a hand's stroke, and tall
    ("post", (0.05, 0.05, 0.07), (0.07, 0.07, 0.10)),  # round, and tips over when pushed high
)
ODD_MASS_KG = (0.05, 1.5)


@dataclass(frozen=True)
class OddObstacle:
    kind: str
    size: tuple[float, float, float]
    mass_kg: float


def odd_obstacle(task_id: str, seed: int | None) -> OddObstacle:
    """The odd obstacle of one episode, from its own stream (the other variations' draws are untouched)."""
    rng = np.random.default_rng([zlib.crc32(b"odd_obstacle"), zlib.crc32(task_id.encode()), seed or 0])
    kind, low, high = ODD_OBSTACLES[int(rng.integers(len(ODD_OBSTACLES)))]
    size = rng.uniform(low, high)
    if kind != "slab":
        size[1] = size[0]  # a square crate, a round post
    return OddObstacle(kind, tuple(round(float(v), 4) for v in size), round(float(rng.uniform(*ODD_MASS_KG)), 3))


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
    leak_object: str | None = None  # seal_failure: the object whose seal fails while a cup carries it


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
    distance = draws["distance"] * (2.0 if "far_perturbation" in enabled else 1.0)
    return VariationPlan(
        enabled=enabled,
        perturb_object=manipulated if set(PERTURBATIONS) & set(enabled) else None,
        perturb_step=draws["perturb_step"],
        perturb_offset=(float(distance * np.cos(draws["angle"])), float(distance * np.sin(draws["angle"]))),
        obstacle_target=target if set(OBSTACLES) & set(enabled) and has_obstacle else None,
        obstacle_step=draws["obstacle_step"],
        noise_sigma=NOISE_SIGMA if "sensing_noise" in enabled else 0.0,
        friction_scale=0.08 if "slippery" in enabled else 1.0,
        mass_scale=8.0 if "heavy" in enabled else 1.0,
        far_target=target if "far_target" in enabled else None,
        leak_object=manipulated if "seal_failure" in enabled else None,
    )


def apply_build_variations(task: TaskSpec, variations: tuple[str, ...], seed: int | None = None) -> TaskSpec:
    """Variations that change the models themselves (shape, surface, the odd obstacle drawn for ``seed``)
    before the scene is built: an env whose built task differs must be built anew."""
    target = manipulated_object(task)
    if not ({"non_flat", "porous", "odd_obstacle"} & set(variations)):
        return task
    objects = []
    for spec in task.objects:
        if spec.name == OBSTACLE and "odd_obstacle" in variations:
            odd = odd_obstacle(task.task_id, seed)
            spec = replace(spec, kind=odd.kind, size=odd.size, mass_kg=odd.mass_kg)
        if spec.name == target and "non_flat" in variations and spec.kind == "box":
            spec = replace(spec, kind="sphere", size=(spec.size[0],) * 3)
        if spec.name == target and "porous" in variations:
            spec = replace(spec, surface="porous")
        objects.append(spec)
    return replace(task, objects=tuple(objects))
