"""Deterministic construction of the skill ontology from MJCF, primitive metadata and skill code.

Relations come from fixed matching rules over effects, preconditions and parameter roles; no rule
names a robot pair or a task, so a new embodiment is a metadata file and two MJCF paths.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pyoxigraph as ox

from lerobot_policy_recent.ontology.mjcf import ArmFacts, GripperFacts, read_arm, read_gripper
from lerobot_policy_recent.ontology.skill_code import call_sites
from lerobot_policy_recent.ontology.specs import (
    ApiSpec,
    ConditionSpec,
    PrimitiveSpec,
    SpecError,
    Waypoint,
    check_against_vocabulary,
    load_api_spec,
    load_conditions,
)
from lerobot_policy_recent.ontology.target import Target

RC = "https://w3id.org/recent/ontology#"
INST = "https://w3id.org/recent/instance/"
RDF_TYPE = ox.NamedNode("http://www.w3.org/1999/02/22-rdf-syntax-ns#type")
SCHEMA_PATH = Path(__file__).with_name("schema.ttl")

# Capability inference from hardware: what a grasp mechanism or an arm implies by itself.
MECHANISM_CAPABILITIES = {
    "parallel_jaw": ("grasp_object", "release_object", "open_fingers", "close_fingers"),
    "multi_finger": ("grasp_object", "release_object", "open_fingers", "close_fingers"),
    "suction": ("attach_object", "detach_object", "activate_suction", "deactivate_suction"),
    "none": (),
}
ARM_CAPABILITIES = ("move_end_effector", "orient_end_effector")
# Every primitive takes the robot session and the task context first; they are parameters too.
CONTEXT_PARAMETERS = (("env", "robot_session", "robot_handle"), ("task", "task_context", "task_handle"))


def hardware_capabilities(arm: ArmFacts, grip: GripperFacts) -> set[str]:
    """Capabilities implied by the MJCF alone, before any primitive is considered."""
    caps = set(MECHANISM_CAPABILITIES[grip.mechanism])
    if arm.dof >= 6:
        caps |= {*ARM_CAPABILITIES, "six_dof_positioning"}
    if arm.dof >= 7:
        caps.add("redundant_kinematics")
    if grip.force_sensor:
        caps.add("force_torque_sensing")
    if grip.joints:
        caps.add("finger_state_sensing")
    return caps


def rc(term: str) -> ox.NamedNode:
    return ox.NamedNode(RC + term)


def inst(*parts: str) -> ox.NamedNode:
    return ox.NamedNode(INST + "/".join(parts))


@dataclass(frozen=True)
class EmbodimentSource:
    """The only per-robot inputs: a name, its primitive metadata file, robot and gripper MJCF, and
    whether skills are written for it (a *source* robot; substitutions run between source and others)."""

    name: str
    api_spec: Path
    robot_mjcf: str
    gripper_mjcf: str
    source: bool = False


@dataclass(frozen=True)
class SkillSource:
    name: str
    code: str
    path: str = "<skill>"


@dataclass
class Ontology:
    store: ox.Store
    apis: dict[str, ApiSpec]
    arms: dict[str, ArmFacts]
    grippers: dict[str, GripperFacts]
    conditions: dict[str, ConditionSpec]
    build_seconds: float = 0.0
    counts: dict[str, int] = field(default_factory=dict)

    def robot_names(self) -> list[str]:
        return list(self.apis)

    def api(self, robot: str) -> ApiSpec:
        try:
            return self.apis[robot]
        except KeyError:
            raise KeyError(f"unknown robot {robot!r}; known robots: {', '.join(self.apis)}") from None

    def target(self, robot: str) -> Target:
        """``robot`` resolved once into the facts grounding and execution use (unknown robots listed)."""
        return Target(robot, self.api(robot), self.arms[robot], self.grippers[robot])

    def substitutes(self, source: str, primitive: str, target: str) -> list[PrimitiveSpec]:
        """Primitives of ``target`` that ``source.primitive`` is ``substitutableBy`` (SPARQL over the graph)."""
        return self._related(source, primitive, "substitutableBy", target)

    def path_tracers(self, source: str, primitive: str, target: str) -> list[PrimitiveSpec]:
        """Moves of ``target`` that can trace ``source.primitive``'s end-effector path (``tracedBy``)."""
        return self._related(source, primitive, "tracedBy", target)

    def path_of(self, capability: str) -> tuple[Waypoint, ...]:
        """The end-effector path a primitive providing ``capability`` declares (a push's), or none."""
        return next(
            (p.path for api in self.apis.values() for p in api.primitives if capability in p.capabilities and p.path),
            (),
        )

    def _related(self, source: str, primitive: str, relation: str, target: str) -> list[PrimitiveSpec]:
        query = f"""
            PREFIX rc: <{RC}>
            SELECT ?name WHERE {{
                <{inst(source, primitive).value}> rc:{relation} ?q .
                <{inst(target).value}> rc:hasPrimitive ?q .
                ?q rc:name ?name .
            }} ORDER BY ?name"""
        api = self.api(target)
        return [p for s in self.store.query(query) if (p := api.get(s["name"].value)) is not None]

    def content_hash(self) -> str:
        """The sha256 of the graph's triples in a canonical order: the same for the same inputs in any
        process (Turtle groups objects in set order, which changes from one process to the next)."""
        triples = self.store.dump(format=ox.RdfFormat.N_TRIPLES, from_graph=ox.DefaultGraph()).decode()
        return hashlib.sha256("\n".join(sorted(triples.splitlines())).encode()).hexdigest()

    def to_turtle(self) -> str:
        prefixes = {
            "rc": RC,
            "inst": INST,
            "rdf": "http://www.w3.org/1999/02/22-rdf-syntax-ns#",
            "rdfs": "http://www.w3.org/2000/01/rdf-schema#",
            "owl": "http://www.w3.org/2002/07/owl#",
            "xsd": "http://www.w3.org/2001/XMLSchema#",
        }
        return self.store.dump(format=ox.RdfFormat.TURTLE, from_graph=ox.DefaultGraph(), prefixes=prefixes).decode()

    def stats(self) -> dict[str, float | int]:
        return {**self.counts, "triples": len(self.store), "build_seconds": round(self.build_seconds, 4)}


def default_embodiment_sources() -> list[EmbodimentSource]:
    from lerobot_policy_recent.descriptions.apis import api_spec_path
    from lerobot_policy_recent.descriptions.embodiments import EMBODIMENTS, SOURCE_EMBODIMENTS

    return [
        EmbodimentSource(
            e.name, api_spec_path(e.api), e.robot_mjcf, e.gripper_mjcf, source=e.name in SOURCE_EMBODIMENTS
        )
        for e in EMBODIMENTS.values()
    ]


def build_ontology(
    embodiments: Iterable[EmbodimentSource] | None = None,
    skills: Iterable[SkillSource] = (),
    schema: Path = SCHEMA_PATH,
) -> Ontology:
    started = time.perf_counter()
    embodiments = list(embodiments) if embodiments is not None else default_embodiment_sources()
    quads: list[ox.Quad] = []

    def add(s: ox.NamedNode, p: ox.NamedNode, o) -> None:
        quads.append(ox.Quad(s, p, o if not isinstance(o, str | int | float | bool) else _literal(o)))

    apis: dict[str, ApiSpec] = {}
    arms: dict[str, ArmFacts] = {}
    grippers: dict[str, GripperFacts] = {}
    capabilities: set[str] = set()
    conditions: set[str] = set()
    vocabulary = load_conditions()
    n_params = 0
    for src in embodiments:
        api = load_api_spec(src.api_spec)
        if api.embodiment != src.name:
            raise SpecError(src.api_spec, "embodiment", f"says {api.embodiment!r} but is registered for {src.name!r}")
        if src.name in apis:
            raise SpecError(src.api_spec, "embodiment", f"{src.name!r} is registered twice")
        check_against_vocabulary(api, vocabulary)
        apis[src.name] = api
        arms[src.name] = arm = read_arm(src.robot_mjcf)
        grippers[src.name] = grip = read_gripper(src.gripper_mjcf)
        robot, arm_node, ee = inst(src.name), inst(src.name, "arm"), inst(src.name, "end_effector")
        add(robot, RDF_TYPE, rc("Robot"))
        add(robot, rc("name"), src.name)
        add(robot, rc("hasArm"), arm_node)
        add(arm_node, RDF_TYPE, rc("Arm"))
        add(arm_node, rc("dof"), arm.dof)
        add(arm_node, rc("reach"), arm.reach)
        for joint in arm.joints:
            node = inst(src.name, "joint", joint.name)
            add(arm_node, rc("hasJoint"), node)
            add(node, RDF_TYPE, rc("Joint"))
            add(node, rc("lowerLimit"), joint.lower)
            add(node, rc("upperLimit"), joint.upper)
        add(robot, rc("hasEndEffector"), ee)
        add(ee, RDF_TYPE, rc("EndEffector"))
        add(ee, rc("graspMechanism"), grip.mechanism)
        if grip.stroke is not None:
            add(ee, rc("stroke"), grip.stroke)
        inferred = hardware_capabilities(arm, grip)
        for prim in api.primitives:
            node = inst(src.name, prim.name)
            add(robot, rc("hasPrimitive"), node)
            add(node, RDF_TYPE, rc("Primitive"))
            add(node, rc("name"), prim.name)
            for pname, ptype, role in CONTEXT_PARAMETERS:
                pnode = inst(src.name, prim.name, pname)
                n_params += 1
                add(node, rc("hasParameter"), pnode)
                add(pnode, RDF_TYPE, rc("Parameter"))
                add(pnode, rc("paramType"), ptype)
                add(pnode, rc("paramRole"), role)
                add(pnode, rc("required"), True)
            for param in prim.parameters:
                pnode = inst(src.name, prim.name, param.name)
                n_params += 1
                add(node, rc("hasParameter"), pnode)
                add(pnode, RDF_TYPE, rc("Parameter"))
                add(pnode, rc("name"), param.name)
                add(pnode, rc("paramType"), param.type)
                add(pnode, rc("paramRole"), param.role)
                add(pnode, rc("required"), param.required)
                if param.unit:
                    add(pnode, rc("unit"), param.unit)
                if not param.required:
                    add(pnode, rc("defaultValue"), repr(param.default))
                if param.range:
                    add(pnode, rc("minValue"), float(param.range[0]))
                    add(pnode, rc("maxValue"), float(param.range[1]))
            for cond in prim.preconditions:
                add(node, rc("hasPrecondition"), inst("condition", cond))
            for cond in prim.effects:
                add(node, rc("hasEffect"), inst("condition", cond))
            for cap in prim.capabilities:
                add(node, rc("provides"), inst("capability", cap))
            for k, waypoint in enumerate(prim.path):
                wnode = inst(src.name, prim.name, f"waypoint{k}")
                add(node, rc("hasWaypoint"), wnode)
                add(wnode, RDF_TYPE, rc("Waypoint"))
                add(wnode, rc("order"), k)
                add(wnode, rc("paramRole"), waypoint.role)
                for axis, value in zip(("dx", "dy", "dz"), waypoint.offset, strict=True):
                    add(wnode, rc(axis), value)
            inferred |= prim.capabilities
            conditions |= prim.preconditions | prim.effects
        for cap in sorted(inferred):
            add(robot, rc("provides"), inst("capability", cap))
        capabilities |= inferred

    for cap in sorted(capabilities):
        add(inst("capability", cap), RDF_TYPE, rc("Capability"))
    for cond in sorted(conditions):
        node, spec = inst("condition", cond), vocabulary[cond]
        add(node, RDF_TYPE, rc("Condition"))
        add(node, rc("conditionKind"), spec.kind)
        if spec.check:
            add(node, rc("runtimeCheck"), spec.check)
        for other in sorted(spec.excludes):
            add(node, rc("excludes"), inst("condition", other))

    prims = [(emb, p) for emb, api in apis.items() for p in api.primitives]
    sources = {src.name for src in embodiments if src.source}
    relations = 0
    for group in _by_function(prims).values():
        for emb_a, a in group:
            for emb_b, b in group:
                if a is b:
                    continue
                if emb_a == emb_b:
                    relation = "functionalEquivalent"
                elif emb_a in sources or emb_b in sources:
                    relation = "substitutableBy"
                else:
                    continue  # target↔target pairs are not needed to ground source skills (keeps the build linear)
                add(inst(emb_a, a.name), rc(relation), inst(emb_b, b.name))
                relations += 1
    for emb, prim, move in _path_tracers(apis, sources):
        add(inst(emb, prim.name), rc("tracedBy"), inst(move.embodiment, move.name))
        relations += 1

    for skill in skills:
        node = inst("skill", skill.name)
        add(node, RDF_TYPE, rc("Skill"))
        add(node, rc("name"), skill.name)
        previous = None
        for i, site in enumerate(call_sites(skill.code, skill.path)):
            providers = [(emb, prim) for emb, api in apis.items() if (prim := api.get(site.name)) is not None]
            if not providers:
                continue  # a helper or task query, not a primitive
            site_node = inst("skill", skill.name, f"call{i}")
            add(node, rc("hasCallSite"), site_node)
            add(site_node, RDF_TYPE, rc("CallSite"))
            add(site_node, rc("line"), site.span.line)
            add(site_node, rc("controlContext"), site.context)
            for keyword, expression in site.arguments:
                add(site_node, rc("bindsArgument"), f"{keyword}={expression}")
            if previous is not None:
                add(previous, rc("nextCallSite"), site_node)
            previous = site_node
            for emb, prim in providers:
                add(site_node, rc("calls"), inst(emb, prim.name))
                for cap in prim.capabilities:
                    add(node, rc("requires"), inst("capability", cap))

    store = ox.Store()
    try:
        store.load(Path(schema).read_bytes(), format=ox.RdfFormat.TURTLE)
    except (SyntaxError, ValueError, OSError) as exc:
        raise SpecError(schema, "turtle", f"cannot be loaded: {exc}") from None
    store.extend(quads)
    counts = {
        "robots": len(apis),
        "primitives": len(prims),
        "capabilities": len(capabilities),
        "parameters": n_params,
        "preconditions": sum(len(p.preconditions) for _, p in prims),
        "effects": sum(len(p.effects) for _, p in prims),
        "substitution_relations": relations,
    }
    return Ontology(store, apis, arms, grippers, vocabulary, time.perf_counter() - started, counts)


def _by_function(prims: list[tuple[str, PrimitiveSpec]]) -> dict[frozenset[str], list[tuple[str, PrimitiveSpec]]]:
    """The matching rule: primitives with equal, non-empty effects do the same thing. Preconditions a
    substitute adds are not a veto: the diagnosis turns them into run-time checks (warnings)."""
    groups: dict[frozenset[str], list[tuple[str, PrimitiveSpec]]] = {}
    for emb, prim in prims:
        if prim.effects:
            groups.setdefault(prim.effects, []).append((emb, prim))
    return groups


def _path_tracers(apis: dict[str, ApiSpec], sources: set[str]) -> list[tuple[str, PrimitiveSpec, PrimitiveSpec]]:
    """(source robot, primitive with a path, target move) where the target has nothing with the
    primitive's effects but can move its end effector to a point: it can trace the path instead."""
    out = []
    for emb in sorted(sources & apis.keys()):
        for prim in apis[emb].primitives:
            for target, api in apis.items():
                if target == emb or any(p.effects == prim.effects for p in api.primitives):
                    continue
                out += [(emb, prim, move) for move in tracing_moves(api, prim)]
    return out


def tracing_moves(api: ApiSpec, prim: PrimitiveSpec) -> list[PrimitiveSpec]:
    """The moves of ``api`` that can trace ``prim``'s end-effector path: ``prim`` declares one, and
    ``api`` can close (or let go) where the path does, not only move along it."""
    if not prim.path or not all(api.actuator(step.effect) for step in prim.path if step.actuation):
        return []
    return api.point_moves()


def _literal(value: str | int | float | bool) -> ox.Literal:
    if isinstance(value, bool):
        return ox.Literal(str(value).lower(), datatype=ox.NamedNode("http://www.w3.org/2001/XMLSchema#boolean"))
    if isinstance(value, int):
        return ox.Literal(str(value), datatype=ox.NamedNode("http://www.w3.org/2001/XMLSchema#integer"))
    if isinstance(value, float):
        return ox.Literal(repr(value), datatype=ox.NamedNode("http://www.w3.org/2001/XMLSchema#double"))
    return ox.Literal(value)
