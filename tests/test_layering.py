"""Data flows one way: every import, including those inside functions, points down the layers, and no module cycles.

The layers, lowest first, follow the method's data flow (ontology → diagnosis → refactoring unit
→ infiller → validation → executor → action); ``docs/architecture.md`` draws the same map.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NAMESPACE = "lerobot_policy_recent"

# Lowest first. A module may import its own layer and the layers below it, never one above.
LAYERS: tuple[tuple[str, ...], ...] = (
    # leaves: the failure taxonomy, the cache dir, the run-time budget of skill code, data-only files
    ("recent_plugin.failures", "recent_plugin.cache", "recent_plugin.sandbox", "recent_plugin.typed_json"),
    ("robosuite_envs",),  # the world: embodiments, primitives, tasks and suites, envs
    ("ontology",),  # specs, the knowledge graph, diagnosis, skill-code analysis
    ("skills",),  # skill data and validation records
    ("logs",),  # typed events and the sinks that observe them
    ("recent_plugin.refactoring",),  # the unit cut around a conflict, its FIM prompt
    ("recent_plugin.models", "recent_plugin.infillers"),  # what fills a unit
    ("recent_plugin.grounding",),  # the gate, the retry loop, pre-execution grounding
    ("recent_plugin.executor",),
    ("recent_plugin.insitu", "recent_plugin.baselines"),  # run-time adaptation, RECENT's and the baselines'
    ("recent_plugin.methods",),  # RECENT, its ablations and the baselines as registered strategies
    ("recent_plugin.settings", "recent_plugin.agent"),  # the settings tree; the agent that takes it
    ("recent_plugin.episode",),
    ("recent_plugin.configuration_recent", "recent_plugin.modeling_recent", "recent_plugin.processor_recent"),
    ("recent_plugin.evaluation", "recent_plugin.authoring"),  # run many episodes: benchmarks, skill validation
    ("scripts",),  # the `recent` command line
)


def _modules() -> dict[str, Path]:
    out = {}
    for top in ("recent_plugin", "ontology", "skills", "robosuite_envs", "logs", "scripts"):
        for path in (ROOT / top).rglob("*.py"):
            if "library" in path.relative_to(ROOT).parts:  # skill programs import nothing
                continue
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = path
    return out


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(NAMESPACE + "."):
            found.add(node.module.removeprefix(NAMESPACE + "."))
        elif isinstance(node, ast.Import):
            found |= {a.name.removeprefix(NAMESPACE + ".") for a in node.names if a.name.startswith(NAMESPACE + ".")}
    return found


def _layer(module: str) -> int:
    for level, prefixes in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return level
    if module in ("recent_plugin",):
        return 0
    raise AssertionError(f"{module} is in no layer: add it to LAYERS (and to docs/architecture.md)")


def _resolve(imported: str, modules: dict[str, Path]) -> str:
    """The module an import names (``from pkg import mod`` names the package; that is enough here)."""
    while imported not in modules and "." in imported:
        imported = imported.rsplit(".", 1)[0]
    return imported


def test_no_module_imports_a_layer_above_its_own():
    modules = _modules()
    upward = []
    for name, path in modules.items():
        for imported in _imports(path):
            target = _resolve(imported, modules)
            if _layer(target) > _layer(name):
                upward.append(f"{name} (layer {_layer(name)}) imports {target} (layer {_layer(target)})")
    assert upward == []


def test_the_import_graph_has_no_cycles():
    modules = _modules()
    graph = {name: {_resolve(i, modules) for i in _imports(path)} - {name} for name, path in modules.items()}
    state: dict[str, int] = {}  # 1: on the stack, 2: done
    cycles = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" → ".join([*stack[stack.index(nxt) :], nxt]))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert cycles == []


def test_every_module_has_a_layer():
    for name in _modules():
        _layer(name)
