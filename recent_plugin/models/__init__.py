"""Offline code language models: which ones we know, and how they are provisioned."""

from lerobot_policy_recent.recent_plugin.models.fetch import (
    ModelIntegrityError,
    ensure_model,
    fetch_model,
    model_path,
    model_sha256,
)
from lerobot_policy_recent.recent_plugin.models.registry import MODELS, ModelSpec, get_model_spec

__all__ = [
    "MODELS",
    "ModelIntegrityError",
    "ModelSpec",
    "ensure_model",
    "fetch_model",
    "get_model_spec",
    "model_path",
    "model_sha256",
]
