"""The distribution as a user installs it: one import namespace, and LeRobot still finds the plugin.

The wheel is built from this checkout and installed with ``--no-deps`` into a fresh venv whose
dependencies come from the project's venv (a path line in a ``.pth``: that venv's own ``.pth``
files, among them this checkout's editable install, are not processed). Every check runs in a
subprocess whose working directory is outside the checkout.
"""

from __future__ import annotations

import json
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

TOP_LEVEL_NAMES = """
import json, pkgutil, sys
print(json.dumps(sorted({m.name for m in pkgutil.iter_modules()})))
"""

IMPORT_EVERY_MODULE = """
import importlib, json, pkgutil, sys
import lerobot_policy_recent as pkg
failed = {}
names = []
for info in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + "."):
    if ".skills.library." in info.name:  # skill programs: their primitives are bound by the executor
        continue
    names.append(info.name)
    try:
        importlib.import_module(info.name)
    except Exception as error:
        failed[info.name] = repr(error)
print(json.dumps({"path": list(pkg.__path__), "modules": len(names), "failed": failed}))
"""

LEROBOT_DISCOVERY = """
from lerobot.utils.import_utils import register_third_party_plugins
register_third_party_plugins()
from lerobot.configs.policies import PreTrainedConfig
from lerobot.envs.configs import EnvConfig
print(PreTrainedConfig.get_choice_class("recent").__module__, EnvConfig.get_choice_class("recent").__module__)
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A fresh venv with the built wheel, and the project's dependencies reachable; its python."""
    work = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "uv", "build", "--wheel", "--out-dir", str(work / "dist"), str(ROOT)],
        check=True,
        capture_output=True,
    )
    env_dir = work / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / "bin" / "python"
    site = Path(
        subprocess.check_output(
            [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True
        ).strip()
    )
    (site / "project_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    before = _run(python, TOP_LEVEL_NAMES, work)
    (work / "before.json").write_text(before)
    wheel = next((work / "dist").glob("*.whl"))
    subprocess.run(
        [sys.executable, "-m", "uv", "pip", "install", "--no-deps", "--python", str(python), str(wheel)],
        check=True,
        capture_output=True,
    )
    return python


def _run(python: Path, code: str, cwd: Path) -> str:
    done = subprocess.run([python, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip().splitlines()[-1]


def test_the_wheel_adds_only_its_own_top_level_name(installed: Path):
    work = installed.parents[2]
    before = set(json.loads((work / "before.json").read_text()))
    after = set(json.loads(_run(installed, TOP_LEVEL_NAMES, work)))
    assert after - before == {"lerobot_policy_recent"}


def test_every_module_of_the_wheel_imports_under_the_namespace(installed: Path):
    report = json.loads(_run(installed, IMPORT_EVERY_MODULE, installed.parents[2]))
    assert len(report["path"]) == 1 and "site-packages" in report["path"][0]  # the wheel's, not a checkout's
    assert report["modules"] > 80
    assert report["failed"] == {}


def test_lerobot_discovers_the_installed_plugin_and_the_console_script_runs(installed: Path):
    modules = _run(installed, LEROBOT_DISCOVERY, installed.parents[2]).split()
    assert modules == [
        "lerobot_policy_recent.recent_plugin.configuration_recent",
        "lerobot_policy_recent.robosuite_envs.lerobot_env",
    ]
    done = subprocess.run(
        [installed.parent / "recent", "--help"], capture_output=True, text=True, cwd=installed.parents[2]
    )
    assert done.returncode == 0 and "ground" in done.stdout


FOLDERS = ("recent_plugin", "evaluation", "descriptions", "ontology", "skills", "robosuite_envs", "logs", "scripts")


def test_the_editable_install_exposes_no_project_module_under_a_second_name():
    """Only ``src`` is on the path: ``logs`` or ``scripts`` would shadow (or be shadowed by) any other
    package of those generic names, and one module loaded twice has two copies of its state."""
    code = (
        "import importlib.util, json, sys\n"
        f"folders = {FOLDERS!r}\n"
        "print(json.dumps({'second_names': [n for n in folders if importlib.util.find_spec(n)],"
        " 'ours': [importlib.util.find_spec('lerobot_policy_recent.' + n) is not None for n in folders]}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["second_names"] == []
    assert all(report["ours"])


def test_a_static_analyser_resolves_every_project_import():
    """basedpyright (configured in pyproject.toml to check imports only) follows the package's links."""
    done = subprocess.run(
        [Path(sys.executable).parent / "basedpyright", "--outputjson", "src", *FOLDERS],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    report = json.loads(done.stdout)
    unresolved = [
        f"{d['file']}:{d['range']['start']['line'] + 1}: {d['message']}"
        for d in report["generalDiagnostics"]
        if d.get("rule") == "reportMissingImports"
    ]
    assert report["summary"]["filesAnalyzed"] > 150
    assert unresolved == []


def test_a_subpackage_import_does_not_load_lerobot_or_torch():
    """The LM worker and the log readers start in a fraction of a second (LeRobot + torch: ~12 s)."""
    code = "import sys, lerobot_policy_recent.logs.events, lerobot_policy_recent.recent_plugin.infillers.llama_worker; print('torch' in sys.modules, 'lerobot' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False"]
