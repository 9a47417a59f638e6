"""Data flows one way: every import, including those inside functions, points down the layers, and no module cycles.

The layers, lowest first, follow the method's data flow (ontology → diagnosis → refactoring unit
→ infiller → validation → executor → action); ``docs/architecture.md`` draws the same map.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NAMESPACE = "lerobot_policy_recent"

# Lowest first. A module may import its own layer and the layers below it, never one above.
LAYERS: tuple[tuple[str, ...], ...] = (
    # leaves: the failure taxonomy, the cache dir, the run-time budget of skill code, data-only files, optional deps
    (
        "recent_plugin.failures",
        "recent_plugin.cache",
        "recent_plugin.sandbox",
        "recent_plugin.typed_json",
        "recent_plugin.extras",
    ),
    ("descriptions",),  # robot descriptions: data (robot files, API files, the frames vocabulary)
    ("ontology",),  # specs, the knowledge graph, diagnosis, skill-code analysis
    ("robosuite_envs",),  # the world: the simulator side of the primitives, tasks and suites, envs
    ("skills",),  # skill data and validation records
    ("logs",),  # typed events and the sinks that observe them
    ("recent_plugin.refactoring",),  # the unit cut around a conflict, its FIM prompt
    ("recent_plugin.models", "recent_plugin.infillers"),  # what fills a unit
    ("recent_plugin.grounding",),  # the gate, the retry loop, pre-execution grounding
    ("recent_plugin.executor",),
    ("recent_plugin.insitu",),  # run-time adaptation
    ("recent_plugin.methods",),  # RECENT as a registered strategy (the harness registers the others)
    ("recent_plugin.settings", "recent_plugin.agent"),  # the settings tree; the agent that takes it
    ("recent_plugin.episode",),
    ("recent_plugin.configuration_recent", "recent_plugin.modeling_recent", "recent_plugin.processor_recent"),
    ("recent_plugin.authoring",),  # skill validation and generation: episodes of the policy
    ("evaluation",),  # the benchmark harness: runner, Ray engine, report, headline, baselines, ablations
    ("scripts",),  # the `recent` command line
)
FOLDERS = ("descriptions", "recent_plugin", "ontology", "skills", "robosuite_envs", "logs", "evaluation", "scripts")


def _modules() -> dict[str, Path]:
    out = {}
    for top in FOLDERS:
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


def _absolute_imports(path: Path) -> list[str]:
    """Every module ``path`` imports by an absolute name, inside functions too."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append(node.module)
    return found


def _top(module: str) -> str:
    return module.split(".")[0]


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


def test_no_module_imports_a_folder_by_a_second_top_level_name():
    """``import logs`` would load a module a second time (or someone else's ``logs``): only the namespace."""
    second = [
        f"{name} imports {m}"
        for name, path in _modules().items()
        for m in _absolute_imports(path)
        if _top(m) in FOLDERS
    ]
    assert second == []


def test_reading_the_robot_descriptions_and_the_ontology_changes_nothing_in_the_process():
    """No simulator import and no environment variable set: the knowledge layer is data and queries."""
    code = (
        "import json, os, sys\n"
        "before = dict(os.environ)\n"
        "from lerobot_policy_recent.ontology.builder import build_ontology\n"
        "build_ontology()\n"
        "loaded = sorted(m for m in ('robosuite', 'mujoco') if m in sys.modules)\n"
        "changed = sorted(k for k in set(os.environ) | set(before) if os.environ.get(k) != before.get(k))\n"
        "print(json.dumps([loaded, changed]))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == [[], []]


def test_only_the_harness_imports_the_bench_extra():
    """Ray and matplotlib are the optional ``bench`` extra: the policy, the world and the logs run
    without them (a plot elsewhere asks for matplotlib through ``extras.optional``, which names the extra)."""
    found = [
        f"{name} imports {m}"
        for name, path in _modules().items()
        if _top(name) != "evaluation"
        for m in _absolute_imports(path)
        if _top(m) in {"ray", "matplotlib"}
    ]
    assert found == []


def test_every_module_has_a_layer():
    for name in _modules():
        _layer(name)
