"""The paper's optional offline path: a large LLM writes a Panda skill from Q(skill, Panda).

The query holds the subtask, the Panda primitive API (typed signatures and what each does), the
task queries and one validated reference skill as an example. The answer is accepted only if its
code passes the same AST policy grounded code must pass *and* Validate(skill, Panda) on every
seed; only then are the skill, its metadata and its validation record written to the library.
Any OpenAI-compatible ``/v1/chat/completions`` endpoint works (a cloud API, vLLM, llama.cpp).
"""

from __future__ import annotations

import re
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from lerobot_policy_recent.descriptions.apis import api_spec_path, available_apis
from lerobot_policy_recent.ontology.specs import load_api_spec
from lerobot_policy_recent.recent_plugin.authoring.sim_validation import validate
from lerobot_policy_recent.recent_plugin.grounding.gate import validate_program
from lerobot_policy_recent.recent_plugin.infillers.http import post_json
from lerobot_policy_recent.robosuite_envs.primitives import TaskContext
from lerobot_policy_recent.robosuite_envs.subtasks import get_subtask
from lerobot_policy_recent.robosuite_envs.suites import SEEDS, validation_task
from lerobot_policy_recent.skills.records import ValidationRecord, save_record
from lerobot_policy_recent.skills.repository import (
    LIBRARY,
    Skill,
    derived_capabilities,
    list_skills,
    load_skill,
    records_dir,
)

SOURCE = "Panda"
EXAMPLE_SKILL = "put_in_bin"
_CODE_BLOCK = re.compile(r"```(?:python|py)?\s*\n(.*?)```", re.DOTALL)


@dataclass
class GenerationResult:
    subtask: str
    skill: str
    code: str = ""
    stored: bool = False
    reason: str = ""  # why the completion was rejected (empty when stored)
    record: ValidationRecord | None = None
    paths: list[Path] = field(default_factory=list)


def skill_query(subtask: str, library: Path = LIBRARY) -> tuple[str, list[dict[str, str]]]:
    """Q(skill, Panda) as chat messages, and the skill name the task plan expects."""
    task = validation_task(subtask)
    step = task.plan[0]
    api = load_api_spec(api_spec_path(SOURCE.lower()))
    signature = ", ".join(["env", "task", *(f"{role}={obj!r}" for role, obj in step.args.items())])
    primitives = "\n".join(f"- {p.signature()}: {p.description}" for p in api.primitives)
    queries = "\n".join(f"- task.{q}(...)" for q in TaskContext.QUERIES)
    example = ""
    if EXAMPLE_SKILL in list_skills(library) and EXAMPLE_SKILL != step.skill:
        example = f"\nA validated skill, for the style:\n```python\n{load_skill(EXAMPLE_SKILL, library).code}```\n"
    user = (
        f"Write the skill `{step.skill}` for a Franka Panda with a parallel-jaw hand.\n"
        f"Subtask: {get_subtask(subtask).description}\n"
        f"Task instruction: {task.instruction}\n\n"
        f"Primitives (call them as plain functions, always passing env and task first):\n{primitives}\n\n"
        f"World queries:\n{queries}\n{example}\n"
        f"Answer with one Python code block defining exactly `def {step.skill}({signature}):` with a "
        "one-line docstring. No imports, no classes, no other robots' functions, no unbounded loops."
    )
    system = "You write short, readable robot skill code against a given primitive API."
    return step.skill, [{"role": "system", "content": system}, {"role": "user", "content": user}]


def extract_code(answer: str) -> str:
    """The first fenced Python block of the answer, or the whole answer when it has none."""
    match = _CODE_BLOCK.search(answer)
    return (match.group(1) if match else answer).strip() + "\n"


def generate_skill(
    subtask: str,
    *,
    base_url: str,
    model: str,
    api_key: str | None = None,
    library: Path = LIBRARY,
    seeds: tuple[int, ...] = SEEDS,
    force: bool = False,
    temperature: float = 0.2,
    on_episode: Callable[[int, str], None] | None = None,
) -> GenerationResult:
    name, messages = skill_query(subtask, library)
    if not force and name in list_skills(library):
        raise FileExistsError(f"{library / (name + '.py')} exists; pass force=True (--force) to replace it")
    answer = post_json(
        base_url,
        "/v1/chat/completions",
        {"model": model, "messages": messages, "temperature": temperature},
        api_key=api_key,
        timeout_s=300.0,
    )
    text = ((answer.get("choices") or [{}])[0].get("message") or {}).get("content") or ""
    result = GenerationResult(subtask=subtask, skill=name, code=extract_code(text))
    apis = {a: load_api_spec(api_spec_path(a)) for a in available_apis()}
    verdict = validate_program(result.code, apis[SOURCE.lower()], name, {s.embodiment: s for s in apis.values()})
    if not verdict.ok:
        result.reason = f"rejected before running: [{verdict.category}] {verdict.message}"
        return result
    with tempfile.TemporaryDirectory(prefix="recent-candidate-") as tmp:
        candidate = _write_candidate(Path(tmp), name, subtask, result.code, library)
        record = validate(candidate, seeds, on_episode=on_episode)
        result.record = record
        if not record.validated:
            result.reason = "failed Validate(skill, Panda): " + "; ".join(
                f"seed {seed}: {why}" for seed, why in record.failures.items()
            )
            return result
        library.mkdir(parents=True, exist_ok=True)
        result.paths = [
            Path(shutil.copy2(candidate.path, library / candidate.path.name)),
            Path(shutil.copy2(candidate.path.with_suffix(".yaml"), library / f"{name}.yaml")),
            save_record(record, records_dir(library)),
        ]
    result.stored = True
    return result


def _write_candidate(directory: Path, name: str, subtask: str, code: str, library: Path) -> Skill:
    """The generated code with metadata: the subtask's conditions, capabilities read off the code."""
    skills = (load_skill(n, library) for n in list_skills(library))
    reference = next((s for s in skills if s.subtask == subtask), None)
    meta = {
        "name": name,
        "entry": name,
        "subtask": subtask,
        "source_embodiment": SOURCE,
        "intent": reference.intent if reference else get_subtask(subtask).description,
        "preconditions": list(reference.preconditions) if reference else ["object_visible"],
        "effects": list(reference.effects) if reference else [],
        "generated": True,
    }
    (directory / f"{name}.py").write_text(code)
    (directory / f"{name}.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    skill = load_skill(name, directory)
    meta["capabilities"] = derived_capabilities(skill)
    (directory / f"{name}.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    return load_skill(name, directory)
