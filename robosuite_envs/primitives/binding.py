"""Bind a robot's primitives: the functions of the module its API file names, checked against the file.

A robot added as data (a YAML spec and a module of primitives) is cross-checked when its
primitives are first bound: every primitive the YAML declares must be a function of the module
with those parameters, and every primitive of the module must be declared. Otherwise a missing
primitive would ground as valid and fail mid-episode as if the LM had invented a name.
"""

from __future__ import annotations

import inspect
from pathlib import Path

from lerobot_policy_recent.ontology.specs import ApiSpec, PrimitiveSpec, SpecError
from lerobot_policy_recent.ontology.target import Target
from lerobot_policy_recent.robosuite_envs.primitives import module_functions

LEADING = ("env", "task")  # every primitive's first two parameters, bound by the executor
_CHECKED: dict[tuple[str, str], dict[str, object]] = {}  # (module, spec path) -> its checked primitives


def bind_primitives(target: Target) -> dict[str, object]:
    """The callables the executor binds into skill code (the API's ``module``), checked against the spec."""
    api = target.api
    key = (api.module, str(api.path))
    if key not in _CHECKED:
        try:
            functions = module_functions(api.module, Path(api.path).parent)
        except ModuleNotFoundError as error:
            raise SpecError(api.path, "module", f"{api.module!r} cannot be imported ({error})") from None
        problems = api_mismatches(api, functions)
        if problems:
            source = inspect.getsourcefile(next(iter(functions.values()))) if functions else api.module
            raise SpecError(f"{api.path} against {source}", "primitives", "; ".join(problems))
        _CHECKED[key] = functions
    return _CHECKED[key]


def api_mismatches(api: ApiSpec, functions: dict[str, object]) -> list[str]:
    """Where the YAML spec and the module's functions disagree (empty when they match)."""
    declared = {p.name: p for p in api.primitives}
    problems = [
        f"{n}: declared in the YAML, not a function of the module" for n in sorted(set(declared) - set(functions))
    ]
    problems += [
        f"{n}: a function of the module, not declared in the YAML" for n in sorted(set(functions) - set(declared))
    ]
    for name in sorted(set(declared) & set(functions)):
        problems += _signature_mismatches(declared[name], functions[name])
    return problems


def _signature_mismatches(spec: PrimitiveSpec, function: object) -> list[str]:
    params = list(inspect.signature(function).parameters.values())  # type: ignore[arg-type]
    if [p.name for p in params[:2]] != list(LEADING):
        return [f"{spec.name}: its first parameters must be (env, task), not {tuple(p.name for p in params[:2])}"]
    rest = params[2:]
    named = {p.name for p in rest if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    any_keyword = any(p.kind == p.VAR_KEYWORD for p in rest)
    required = {p.name for p in rest if p.default is p.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
    problems = []
    unknown = sorted({p.name for p in spec.parameters} - named) if not any_keyword else []
    if unknown:
        problems.append(f"{spec.name}: the YAML declares {', '.join(unknown)}, which the function does not take")
    optional_in_yaml = sorted(required - {p.name for p in spec.parameters if p.required})
    if optional_in_yaml:
        problems.append(f"{spec.name}: the function requires {', '.join(optional_in_yaml)}, the YAML does not")
    return problems
