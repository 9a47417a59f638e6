"""``recent upload``: push a run's datasets to the Hugging Face Hub with a dataset card.

The LeRobotDataset goes to the repository root (so ``LeRobotDataset("ORG/NAME")`` loads it, with
the codebase-version tag LeRobot looks for), the grounding events and results beside it as two
more parquet configs. MCAP and Rerun recordings are included with ``recordings=True``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import httpx

from lerobot_policy_recent.logs.layout import LogLayout
from lerobot_policy_recent.logs.readers import read_table

CARD = """---
license: apache-2.0
task_categories:
- robotics
tags:
- LeRobot
- RECENT
- robosuite
configs:
- config_name: default
  data_files: data/*/*.parquet
- config_name: grounding_events
  data_files: grounding_events/*.parquet
- config_name: results
  data_files: results/*.parquet
---

# {repo_id}

Episodes of RECENT for LeRobot (`lerobot_policy_recent`) grounding Panda skill code onto other robots
in robosuite: {episodes} episodes ({successes} successful) on {robots}; tasks: {tasks}.

- `data/`, `meta/`: a LeRobotDataset (v3) of observations and actions at {fps} Hz
  (`LeRobotDataset("{repo_id}")`).
- `grounding_events/`: one row per grounding event (diagnosis, infiller call with prompt and
  completion, validation verdict, patch as a unified diff, run-time check, segment start/end/failure,
  episode result), joinable on `episode_index` / `frame_index`.
- `results/`: one row per episode: success, GC, GO, EI, IT, IGT and the failure category.
{recordings}
Replay an episode with its grounding events in Rerun: `recent replay DIR --episode N`.
"""


def dataset_card(layout: LogLayout, repo_id: str, recordings: bool) -> str:
    from lerobot_policy_recent.robosuite_envs.primitives.session import CONTROL_FREQ

    rows = [read_table(layout.results(e))[0] for e in layout.committed()]
    return CARD.format(
        repo_id=repo_id,
        episodes=len(rows),
        successes=sum(1 for r in rows if r["success"]),
        robots=", ".join(sorted({r["robot"] for r in rows})) or "-",
        tasks=", ".join(sorted({r["task_id"] for r in rows})) or "-",
        fps=CONTROL_FREQ,
        recordings="- `mcap/`, `rerun/`: the per-episode MCAP and Rerun recordings.\n" if recordings else "",
    )


def check_repo_id(repo_id: str) -> str:
    """``ORG/NAME`` as the Hub accepts it (``huggingface_hub``'s own check); refused before any request."""
    from huggingface_hub.utils import HFValidationError, validate_repo_id

    try:
        validate_repo_id(repo_id)
    except HFValidationError as error:
        raise ValueError(f"--repo_id {repo_id!r} is not ORG/NAME: {error}") from None
    if "/" not in repo_id:
        raise ValueError(f"--repo_id {repo_id!r} is not ORG/NAME (e.g. my-lab/recent-runs)")
    return repo_id


def upload_plan(root: str | Path, *, recordings: bool = False) -> list[tuple[Path, str]]:
    """The folders that would be pushed, with their place in the repository; refuses a run with nothing to push."""
    layout = LogLayout(Path(root))
    if not Path(root).is_dir():
        raise FileNotFoundError(f"no such log directory: {root}")
    if not layout.committed():
        raise ValueError(f"{root} holds no finished episodes (nothing under {layout.results_dir})")
    if not (layout.dataset_dir / "meta" / "info.json").exists():
        raise ValueError(f"{layout.dataset_dir} is not a LeRobotDataset; log with the dataset sink on")
    folders = [layout.events_dir, layout.results_dir] + ([layout.mcap_dir, layout.rerun_dir] if recordings else [])
    return [(layout.dataset_dir, "")] + [(f, f.name) for f in folders if f.exists()]


def upload(root: str | Path, repo_id: str, *, private: bool = False, recordings: bool = False, api=None) -> str:
    """Create (or reuse) the dataset repository and upload; returns its URL.

    The repo id, the log directory and (for the real Hub) the token are checked before any request;
    a Hub that cannot be reached is one :class:`RuntimeError` saying that nothing was uploaded.
    """
    from lerobot.datasets.dataset_metadata import CODEBASE_VERSION

    check_repo_id(repo_id)
    plan = upload_plan(root, recordings=recordings)
    if api is None:
        from huggingface_hub import HfApi, get_token

        if not get_token():
            raise RuntimeError("no Hugging Face token: run `hf auth login` or set HF_TOKEN (nothing was uploaded)")
        api = HfApi()
    try:
        url = api.create_repo(repo_id, repo_type="dataset", private=private, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            card = Path(tmp) / "README.md"
            card.write_text(dataset_card(LogLayout(Path(root)), repo_id, recordings))
            api.upload_file(path_or_fileobj=str(card), path_in_repo="README.md", repo_id=repo_id, repo_type="dataset")
        for folder, into in plan:
            kwargs = {"path_in_repo": into} if into else {}
            api.upload_folder(folder_path=str(folder), repo_id=repo_id, repo_type="dataset", **kwargs)
        api.create_tag(repo_id, tag=CODEBASE_VERSION, repo_type="dataset", exist_ok=True)
    except (OSError, httpx.HTTPError) as error:  # hub errors are OSErrors; connection errors are httpx's
        raise RuntimeError(
            f"cannot reach the Hugging Face Hub ({type(error).__name__}: {error}); the upload did not finish"
        ) from None
    return str(url)
