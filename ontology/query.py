"""The query operator Q(skill, robot) = ⟨C, P, E, I⟩.

C: capabilities the skill requires (those provided by the source primitives it calls),
P / E: the preconditions and effects of those calls, and I: the robot-conditioned interface —
for every required capability, the robot's primitives that provide it, with typed parameters.
Capabilities no primitive of the robot provides are the embodiment gaps D then reasons about.
"""

from __future__ import annotations

from dataclasses import dataclass

from lerobot_policy_recent.ontology.builder import RC, Ontology, inst
from lerobot_policy_recent.ontology.skill_code import call_sites
from lerobot_policy_recent.ontology.specs import PrimitiveSpec


@dataclass(frozen=True)
class SkillQuery:
    skill: str
    robot: str
    capabilities: frozenset[str]
    preconditions: frozenset[str]
    effects: frozenset[str]
    interface: dict[str, tuple[PrimitiveSpec, ...]]  # capability -> primitives of the robot

    @property
    def gaps(self) -> frozenset[str]:
        return frozenset(cap for cap, prims in self.interface.items() if not prims)

    def to_json(self) -> dict:
        return {
            "skill": self.skill,
            "robot": self.robot,
            "capabilities": sorted(self.capabilities),
            "preconditions": sorted(self.preconditions),
            "effects": sorted(self.effects),
            "interface": {
                cap: [
                    {
                        "primitive": p.name,
                        "signature": p.signature(),
                        "parameters": [
                            {"name": q.name, "type": q.type, "unit": q.unit, "role": q.role} for q in p.parameters
                        ],
                    }
                    for p in prims
                ]
                for cap, prims in sorted(self.interface.items())
            },
            "gaps": sorted(self.gaps),
        }


def query(onto: Ontology, skill_name: str, code: str, robot: str, source: str = "Panda") -> SkillQuery:
    source_api = onto.api(source)
    called = [p for site in call_sites(code, skill_name) if (p := source_api.get(site.name)) is not None]
    capabilities = frozenset().union(*(p.capabilities for p in called)) if called else frozenset()
    interface = {cap: tuple(_providers(onto, robot, cap)) for cap in sorted(capabilities)}
    return SkillQuery(
        skill=skill_name,
        robot=robot,
        capabilities=capabilities,
        preconditions=frozenset().union(*(p.preconditions for p in called)) if called else frozenset(),
        effects=frozenset().union(*(p.effects for p in called)) if called else frozenset(),
        interface=interface,
    )


def _providers(onto: Ontology, robot: str, capability: str) -> list[PrimitiveSpec]:
    rows = onto.store.query(
        f"""PREFIX rc: <{RC}>
        SELECT ?name WHERE {{
            <{inst(robot).value}> rc:hasPrimitive ?p .
            ?p rc:provides <{inst("capability", capability).value}> ; rc:name ?name .
        }} ORDER BY ?name"""
    )
    api = onto.api(robot)
    return [p for row in rows if (p := api.get(row["name"].value)) is not None]
