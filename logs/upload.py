"""``recent upload``: push a run's datasets to the Hugging Face Hub with a dataset card.

The LeRobotDataset goes to the repository root (so ``LeRobotDataset("ORG/NAME")`` loads it, with
the codebase-version tag LeRobot looks for), the grounding events and results beside it as two
more parquet configs. MCAP and Rerun recordings are included with ``recordings=True``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

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


def upload(root: str | Path, repo_id: str, *, private: bool = False, recordings: bool = False, api=None) -> str:
    """Create (or reuse) the dataset repository and upload; returns its URL."""
    from huggingface_hub import HfApi
    from lerobot.datasets.dataset_metadata import CODEBASE_VERSION

    layout = LogLayout(Path(root))
    if not layout.committed():
        raise ValueError(f"{root} holds no finished episodes (nothing under {layout.results_dir})")
    if not (layout.dataset_dir / "meta" / "info.json").exists():
        raise ValueError(f"{layout.dataset_dir} is not a LeRobotDataset; log with the dataset sink on")
    api = api or HfApi()
    url = api.create_repo(repo_id, repo_type="dataset", private=private, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        card = Path(tmp) / "README.md"
        card.write_text(dataset_card(layout, repo_id, recordings))
        api.upload_file(path_or_fileobj=str(card), path_in_repo="README.md", repo_id=repo_id, repo_type="dataset")
    api.upload_folder(folder_path=str(layout.dataset_dir), repo_id=repo_id, repo_type="dataset")
    folders = [layout.events_dir, layout.results_dir] + ([layout.mcap_dir, layout.rerun_dir] if recordings else [])
    for folder in folders:
        if folder.exists():
            api.upload_folder(folder_path=str(folder), path_in_repo=folder.name, repo_id=repo_id, repo_type="dataset")
    api.create_tag(repo_id, tag=CODEBASE_VERSION, repo_type="dataset", exist_ok=True)
    return str(url)
