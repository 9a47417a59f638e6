"""The offline skill repository: Panda reference skills as plain Python plus metadata.

A skill file holds one function ``entry(env, task)`` written against the source robot's
primitive API, with no imports: the executor binds the primitives of the robot it runs on.
"""

from __future__ import annotations

import ast
import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path

import yaml

from lerobot_policy_recent.descriptions.apis import api_spec_path
from lerobot_policy_recent.descriptions.embodiments import get_embodiment
from lerobot_policy_recent.ontology.skill_code import CallCount, CallSite, call_sites, count_calls, parse_skill
from lerobot_policy_recent.ontology.specs import ApiSpec, load_api_spec
from lerobot_policy_recent.skills.records import LIBRARY, load_record, records_dir


class SkillNotFoundError(KeyError):
    pass


class SkillNotValidatedError(RuntimeError):
    """The skill has no passing validation record for its current code."""


@dataclass(frozen=True)
class StateEffect:
    """What a skill leaves in the perceived state of an object one of its parameters names: a
    drawer's opening (m), a lid's angle (rad), a button lit (0/1), the share of an area wiped.

    Declared by the skill's author from what the code does (it pulls 12 cm: the drawer ends at
    least 10 cm out), never from an evaluation's thresholds; checked once the skill has run.
    """

    parameter: str  # the entry's parameter that names the object
    at_least: float | None = None
    at_most: float | None = None

    def unmet(self, state: float) -> bool:
        return (self.at_least is not None and state < self.at_least) or (
            self.at_most is not None and state > self.at_most
        )

    @property
    def wanted(self) -> str:
        return f"at least {self.at_least:g}" if self.at_least is not None else f"at most {self.at_most:g}"


@dataclass(frozen=True)
class Placement:
    """Where a skill leaves an object it moves: over the perceived box of another its parameters name
    (the cube in the zone, the block on the tower), checked once the skill has run."""

    parameter: str  # the entry's parameter that names the object moved
    over: str  # the one that names where it ends
    # where on it, when the skill puts it at a spot (a slot of a row): metres across the table from
    # the other's perceived centre; None: anywhere over its box
    at: tuple[float, float] | None = None
    # the whole object ends within the other's box (a pen's walls, a bin's), not only its centre: a block
    # swept to the pen's open side, half of it outside, had its centre over the pen's box
    inside: bool = False


@dataclass(frozen=True)
class Skill:
    name: str
    entry: str
    subtask: str
    source_embodiment: str
    intent: str
    code: str
    path: Path
    preconditions: tuple[str, ...] = ()
    effects: tuple[str, ...] = ()
    capabilities: tuple[str, ...] = ()  # what the source robot must be able to do (union over its call sites)
    state_effects: tuple[StateEffect, ...] = ()  # what it leaves in the perceived state of the objects it acts on
    placements: tuple[Placement, ...] = ()  # where it leaves the objects it moves

    @property
    def code_sha256(self) -> str:
        return hashlib.sha256(self.code.encode()).hexdigest()

    @property
    def placed_over(self) -> dict[str, str]:
        """Where each object the skill moves ends, for an object with one placement: the receptacle
        the ontology gives a place by name where no one position places the drop point."""
        over: dict[str, set[str]] = {}
        for placement in self.placements:
            over.setdefault(placement.parameter, set()).add(placement.over)
        return {moved: next(iter(ends)) for moved, ends in over.items() if len(ends) == 1}


def list_skills(library: Path = LIBRARY) -> list[str]:
    """The skills of one directory (a ``.py`` with its ``.yaml``)."""
    return sorted(p.stem for p in library.glob("*.py") if p.with_suffix(".yaml").is_file())


def skill_home(name: str, library: Path = LIBRARY) -> Path:
    """The directory that serves ``name``: a user's ``library`` where it holds the skill, else the
    bundled one. A user's skill replaces the bundled skill of its name (the tasks' plans name their
    skills), and the rest of a task's plan is still served, so a library of one skill runs."""
    for directory in dict.fromkeys((library, LIBRARY)):
        if name in list_skills(directory):
            return directory
    known = served_skills(library)
    raise SkillNotFoundError(f"unknown skill {name!r}; known skills: {', '.join(known) or '(none)'}")


def served_skills(library: Path = LIBRARY) -> list[str]:
    """Every skill a run with ``library`` serves: its own and the bundled ones it does not replace."""
    return sorted({*list_skills(library), *list_skills(LIBRARY)})


def load_skill(name: str, library: Path = LIBRARY) -> Skill:
    code_path, meta_path = library / f"{name}.py", library / f"{name}.yaml"
    if not code_path.is_file() or not meta_path.is_file():
        raise SkillNotFoundError(f"unknown skill {name!r}; known skills: {', '.join(list_skills(library)) or '(none)'}")
    meta = yaml.safe_load(meta_path.read_text()) or {}
    missing = [k for k in ("entry", "subtask", "source_embodiment", "intent") if k not in meta]
    if missing:
        raise ValueError(f"{meta_path}: missing field(s) {', '.join(missing)}")
    code = code_path.read_text()
    tree = parse_skill(code, str(code_path))
    entry = next((node for node in tree.body if getattr(node, "name", None) == meta["entry"]), None)
    if not isinstance(entry, ast.FunctionDef):
        raise ValueError(f"{meta_path}: entry {meta['entry']!r} is not a function defined in {code_path.name}")
    parameters = {a.arg for a in entry.args.args} - {"env", "task"}
    return Skill(
        name=name,
        entry=meta["entry"],
        subtask=meta["subtask"],
        source_embodiment=meta["source_embodiment"],
        intent=meta["intent"],
        code=code,
        path=code_path,
        preconditions=_names(meta, "preconditions", meta_path),
        effects=_names(meta, "effects", meta_path),
        capabilities=_names(meta, "capabilities", meta_path),
        state_effects=_state_effects(meta, meta_path, parameters),
        placements=_placements(meta, meta_path, parameters),
    )


def load_skills(library: Path = LIBRARY) -> tuple[list[Skill], dict[str, str]]:
    """Every skill a run with ``library`` serves (:func:`served_skills`) that loads, and, by name,
    why each of the others does not.

    One broken file disables its own skill, with the reason naming the file and the field, and
    nothing else: the rest of the library, and every command that reads it, keeps working.
    """
    skills, broken = [], {}
    for name in served_skills(library):
        try:
            skills.append(load_skill(name, skill_home(name, library)))
        except (ValueError, SyntaxError, yaml.YAMLError) as error:  # SkillCodeError is a ValueError
            broken[name] = str(error)
    return skills, broken


def _names(meta: dict, key: str, path: Path) -> tuple[str, ...]:
    value = meta.get(key) or []
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ValueError(f"{path}: field {key!r} must be a list of names, got {value!r}")
    return tuple(value)


def _state_effects(meta: dict, path: Path, parameters: set[str]) -> tuple[StateEffect, ...]:
    """``state_effects: [{object: drawer, at_least: 0.10}]``: each names a parameter of the entry and one bound."""
    value = meta.get("state_effects") or []
    if not isinstance(value, list):
        raise ValueError(f"{path}: field 'state_effects' must be a list, got {value!r}")
    effects = []
    for item in value:
        bounds = {k: v for k, v in item.items() if k in ("at_least", "at_most")} if isinstance(item, dict) else {}
        if (
            not isinstance(item, dict)
            or set(item) - {"object", "at_least", "at_most"}
            or not isinstance(item.get("object"), str)
            or item["object"] not in parameters
            or len(bounds) != 1
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in bounds.values())
        ):
            raise ValueError(
                f"{path}: field 'state_effects' entry {item!r} must be {{object: <one of {sorted(parameters)}>, "
                "at_least: <number>}} or {{object: ..., at_most: <number>}}"
            )
        effects.append(StateEffect(item["object"], **{k: float(v) for k, v in bounds.items()}))
    return tuple(effects)


def _placements(meta: dict, path: Path, parameters: set[str]) -> tuple[Placement, ...]:
    """``placements: [{object: obj, over: region}]``: both name parameters of the entry; ``at: [dx, dy]``
    names the spot on it (a row's slot), in metres from its centre; ``inside: true``, that the whole
    object ends within the other's box."""
    value = meta.get("placements") or []
    if not isinstance(value, list):
        raise ValueError(f"{path}: field 'placements' must be a list, got {value!r}")
    placements = []
    for item in value:
        names = {k: v for k, v in item.items() if k not in ("at", "inside")} if isinstance(item, dict) else None
        if (
            names is None
            or set(names) != {"object", "over"}
            or not all(isinstance(v, str) and v in parameters for v in names.values())
        ):
            raise ValueError(
                f"{path}: field 'placements' entry {item!r} must be {{object: <param>, over: <param>}} (and an "
                f"optional at: [dx, dy] and inside: true), each one of {sorted(parameters)}"
            )
        inside = item.get("inside", False)
        if not isinstance(inside, bool):
            raise ValueError(
                f"{path}: field 'placements' entry {item!r}: 'inside' must be true or false, got {inside!r}"
            )
        at = item.get("at")
        if at is not None and not (
            isinstance(at, list)
            and len(at) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in at)
        ):
            raise ValueError(f"{path}: field 'placements' entry {item!r}: 'at' must be [dx, dy] in metres, got {at!r}")
        spot = None if at is None else (float(at[0]), float(at[1]))
        placements.append(Placement(item["object"], item["over"], spot, inside))
    return tuple(placements)


def source_call_sites(skill: Skill) -> list[CallSite]:
    """The call sites the ontology sees: primitives of the source robot's API, in source order."""
    api = source_api(skill)
    return [site for site in call_sites(skill.code, str(skill.path)) if api.get(site.name) is not None]


def derived_capabilities(skill: Skill) -> list[str]:
    """Capabilities of the primitives the code calls, read from the source API's metadata."""
    api = source_api(skill)
    return sorted({cap for site in source_call_sites(skill) for cap in api.get(site.name).capabilities})


def skill_calls(skill: Skill) -> CallCount:
    """The primitive calls (and position reads) the skill makes, counted as the paper counts them."""
    return _counted_calls(skill.code, skill.entry, skill.source_embodiment)


@functools.lru_cache(maxsize=256)
def _counted_calls(code: str, entry: str, source_embodiment: str) -> CallCount:
    """Counted once per code: every episode's LM budget asks again (~10 ms a skill: the API spec is read)."""
    api = load_api_spec(api_spec_path(get_embodiment(source_embodiment).api))
    return count_calls(code, entry, set(api.names()))


def task_calls(plan_skills: list[str], library: Path = LIBRARY) -> CallCount:
    """The calls a task's plan makes: the sum over the reference skills of its subtasks."""
    total = CallCount(0, 0)
    for name in plan_skills:
        total += skill_calls(load_skill(name, skill_home(name, library)))
    return total


def source_api(skill: Skill) -> ApiSpec:
    return load_api_spec(api_spec_path(get_embodiment(skill.source_embodiment).api))


def serve_skill(name: str, library: Path = LIBRARY, *, require_validated: bool = True) -> Skill:
    """The skill for grounding: only with a passing validation record for exactly this code.

    ``require_validated=False`` is the paper's "w/o offline validation" ablation. ``library``: a
    user's directory (:func:`skill_home`); a skill's record lies beside it, in its ``validation/``.
    """
    home = skill_home(name, library)
    skill = load_skill(name, home)
    if require_validated:
        record = load_record(name, records_dir(home))
        if record is None or not record.matches(skill.code_sha256):
            why = (
                "it was never validated"
                if record is None
                else "its code changed since it was validated"
                if record.code_sha256 != skill.code_sha256
                else f"it failed validation on seeds {sorted(set(record.seeds) - set(record.passed))}"
            )
            user = "" if home == LIBRARY else f" --skill_library {home}"
            raise SkillNotValidatedError(
                f"skill {name!r} ({home / (name + '.py')}) is not served: {why}; "
                f"run `recent skills validate --skill {name}{user}`"
            )
    return skill
