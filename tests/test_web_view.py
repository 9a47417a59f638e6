"""What a user sees: the main job's kind of recording, opened in Rerun's web viewer in a real browser."""

from __future__ import annotations

import pytest

from lerobot_policy_recent.logs.web_view import browser, screenshot


@pytest.mark.slow
def test_a_recording_renders_in_the_web_viewer(tmp_path, ontology):
    if browser() is None:
        pytest.skip("no Chromium on the PATH (apt-get install chromium); CI need not have one")
    from PIL import Image

    from lerobot_policy_recent.logs.layout import LogLayout
    from lerobot_policy_recent.logs.recorder import Recorder
    from lerobot_policy_recent.recent_plugin.agent import RecentAgent
    from lerobot_policy_recent.recent_plugin.episode import run_episode
    from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
    from lerobot_policy_recent.recent_plugin.settings import RecentSettings

    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology)
    with Recorder(tmp_path / "logs", ["rerun"]) as recorder:
        run_episode(agent, "cube_in_bin", "UR5e", seed=3, recorder=recorder)
    shot = screenshot(LogLayout(tmp_path / "logs").rrd(0), tmp_path / "viewer.png", load_seconds=25)
    image = Image.open(shot).convert("RGB")
    assert image.size[0] >= 1200
    # the page is the viewer with its panels drawn, not the loading screen: many distinct colours
    assert len(set(image.resize((200, 100)).getdata())) > 500
