"""Recording and replay: each artefact read back with its own library, counts agreeing across logs.

One run with two episodes is recorded once per module: a successful one with in-situ patches
(UR5e, variations on, rule backend) and one whose grounding fails on purpose (scripted spans with
a hallucinated kwarg, an empty continuation and an import).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from doubles import ScriptedInfiller

from lerobot_policy_recent.logs.layout import LogLayout
from lerobot_policy_recent.logs.readers import decoded_protobuf, read_mcap, read_rrd, read_table
from lerobot_policy_recent.logs.recorder import Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.episode import run_episode
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings

TASK = "kinematic/cube_on_plate"


@pytest.fixture(scope="module")
def run(tmp_path_factory, ontology):
    root = tmp_path_factory.mktemp("logs")
    good = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology)
    broken = RecentAgent(
        RecentSettings(infiller=RuleConfig(), method=method_named("recent"), max_retries=2),  # the LM writes every span
        ontology=ontology,
        infiller=ScriptedInfiller(
            tokens=5,
            texts=[
                "ur5_release_at(env, task, place_pos=drop_pos)",
                "ur5_grasp_at(env, task, grasp_pos=obj_pos, approach_distance=0.1)",  # hallucinated kwarg
                "",  # empty continuation
                "import os",  # non-executable
            ],
        ),
    )
    with Recorder(root) as recorder:
        results = [
            run_episode(good, TASK, "UR5e", seed=0, variations="on", recorder=recorder),
            run_episode(broken, "cube_in_bin", "UR5e", seed=0, max_steps=30, recorder=recorder),
        ]
    return root, results


def test_episodes_are_committed_with_their_results(run):
    root, (good, broken) = run
    layout = LogLayout(root)
    assert layout.committed() == [0, 1]
    rows = [read_table(layout.results(i))[0] for i in (0, 1)]
    assert rows[0]["success"] is True and rows[0]["ei"] == good.ei == 2 and rows[0]["num_frames"] == good.steps
    assert rows[1]["success"] is False and rows[1]["failure_category"] == "non_executable"
    assert rows[1]["num_frames"] == broken.steps < 30  # nothing to run: it held still, then settled


def test_mcap_holds_foxglove_messages_and_json_events(run):
    root, (good, _) = run
    path = LogLayout(root).mcap(0)
    contents = read_mcap(path)
    assert contents.complete and contents.steps == good.steps
    assert contents.topics["/tf"] == contents.topics["/joint_states"] == good.steps
    events = contents.events
    assert events[0]["task_id"] == TASK and events[-1]["success"] is True
    names = [e.get("skill") for e in events if "skill" in e]
    assert set(names) == {"place_on_plate"}
    transforms = decoded_protobuf(path, "/tf")
    assert len(transforms) == good.steps
    children = {t.child_frame_id for t in transforms[0].transforms}
    assert {"eef", "cube", "plate"} <= children and all(t.parent_frame_id == "world" for t in transforms[0].transforms)
    joints = decoded_protobuf(path, "/joint_states")[-1].joints  # the UR5e's six arm joints, then the gripper
    assert [j.name for j in joints] == [f"joint{i}" for i in range(6)] + ["gripper"]
    assert any(abs(j.position) > 0.1 for j in joints[:6])
    logs = decoded_protobuf(path, "/log")
    assert len(logs) == len(events)
    assert any(log.name == "check_verdict" and "object_unmoved" in log.message for log in logs)
    stamps = [log.timestamp.seconds * 10**9 + log.timestamp.nanos for log in logs]
    assert stamps == sorted(stamps) and stamps[0] > 1.6e18  # nanoseconds since the epoch


def test_rerun_opens_the_mcap(run):
    from rerun.chunk import McapReader

    root, _ = run
    entities = {chunk.entity_path for chunk in McapReader(str(LogLayout(root).mcap(0))).stream().collect().stream()}
    assert {"/tf", "/log", "/joint_states", "/action", "/recent/patch_applied", "/recent/check_verdict"} <= entities
    # the simulator's ground truth of the grasp goes to the logs (never to the policy), beside what the gripper sensed
    assert {"/recent/held_changed", "/gripper_sensors"} <= entities


def test_rerun_recording_matches_the_mcap(run):
    from lerobot_policy_recent.logs.replay import rerun_executable

    root, (good, _) = run
    path = LogLayout(root).rrd(0)
    contents = read_rrd(path)
    assert contents.steps == good.steps and contents.rows["/world/eef"] == contents.rows["/joints"] == good.steps
    assert contents.events == len(read_mcap(LogLayout(root).mcap(0)).events)
    assert contents.rows["/skill/code"] == 3  # the grounding patch and two in-situ patches
    subprocess.run([rerun_executable(), "rrd", "verify", str(path)], check=True, capture_output=True)


def test_datasets_load_and_join_on_episode_index(run):
    import datasets
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, (good, broken) = run
    layout = LogLayout(root)
    events = datasets.load_dataset("parquet", data_files=str(layout.events_dir / "*.parquet"), split="train")
    results = datasets.load_dataset("parquet", data_files=str(layout.results_dir / "*.parquet"), split="train")
    frames = LeRobotDataset("local/recent_episodes", root=layout.dataset_dir, video_backend="pyav")
    assert frames.num_episodes == 2 and frames.num_frames == good.steps + broken.steps
    assert sorted(results["episode_index"]) == [0, 1]
    mcap_events = read_mcap(layout.mcap(0)).events
    episode0 = [row for row in events if row["episode_index"] == 0]
    assert [row["event"] for row in episode0] == [e["event"] for e in mcap_events]
    # every event joins a frame: those after the last action (final subtask, result) join the last one
    assert [row["frame_index"] for row in episode0] == [min(e["frame_index"], good.steps - 1) for e in mcap_events]
    assert all(0 <= row["frame_index"] < (good.steps if row["episode_index"] == 0 else broken.steps) for row in events)
    patch = next(row for row in episode0 if row["event"] == "patch_applied" and row["kind"] == "revise")
    frame = frames[patch["frame_index"]]  # events join the frames on (episode_index, frame_index)
    assert int(frame["episode_index"]) == 0 and int(frame["frame_index"]) == patch["frame_index"]
    np.testing.assert_allclose(frames[0]["action"].numpy(), read_mcap_action(layout.mcap(0)), atol=1e-6)
    features = frames.meta.features
    assert features["observation.state"]["names"][7:9] == ["gripper_opening", "finger_contact_left"]
    assert features["observation.state"]["names"][12:14] == ["eef_contact", "joint0_pos"]
    assert features["observation.state"]["names"][-1] == "joint6_vel"
    assert features["observation.environment_state"]["names"][:3] == ["slot0_x", "slot0_y", "slot0_z"]
    assert features["action"]["names"][-1] == "gripper"
    last_good, last_broken = frames[good.steps - 1], frames[good.steps + broken.steps - 1]
    assert bool(last_good["next.done"]) and bool(last_good["next.success"]) == bool(good.success)
    assert float(last_good["next.reward"]) == (1.0 if good.success else 0.0)
    assert bool(last_broken["next.done"]) and not bool(last_broken["next.success"])
    assert not bool(frames[0]["next.done"]) and float(frames[0]["next.reward"]) == 0.0
    assert frames[0]["task"] and "[recent" not in frames[0]["task"]  # the plain instruction; metadata has columns


def test_loading_the_dataset_with_lerobot_defaults_prints_no_traceback(run):
    """LeRobot's default video decoder (torchcodec) loads: setup installs FFmpeg's libraries."""
    import shutil

    if shutil.which("ffmpeg") is None:
        pytest.skip("FFmpeg is not installed (setup installs it where it may use apt-get)")
    root, (good, broken) = run
    code = (
        "import sys; from lerobot.datasets.lerobot_dataset import LeRobotDataset\n"
        f"d = LeRobotDataset('local/recent_episodes', root={str(LogLayout(root).dataset_dir)!r})\n"
        "print(d.num_frames, d[0]['task'])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd="/")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr and "cannot be loaded" not in done.stderr, done.stderr[-2000:]
    assert done.stdout.split()[0] == str(good.steps + broken.steps)


def read_mcap_action(path: Path) -> list[float]:
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        for _s, _c, message in make_reader(stream).iter_messages(topics=["/action"]):
            return json.loads(message.data)["action"]
    raise AssertionError("no action")


def test_verify_finds_the_logs_consistent_and_replay_rebuilds_the_recording(run, tmp_path):
    from lerobot_policy_recent.logs.replay import replay_episode
    from lerobot_policy_recent.logs.verify import verify

    root, (good, broken) = run
    report = verify(root)
    assert report.ok, (report.problems, [e.problems for e in report.episodes])
    assert [e.steps["dataset"] for e in report.episodes] == [good.steps, broken.steps]
    replayed = read_rrd(replay_episode(root, 0, tmp_path / "replay.rrd"))
    assert replayed.steps == good.steps and replayed.events == read_rrd(LogLayout(root).rrd(0)).events


def test_replay_rebuilds_the_live_recording_from_the_mcap_alone(run, tmp_path, capsys):
    """Every entity gets the rows the live sink logged, from the MCAP's messages only; so does the CLI."""
    from lerobot_policy_recent.scripts.cli import main

    root, (good, _) = run
    layout = LogLayout(root)
    out = tmp_path / "from_mcap.rrd"
    assert main(["replay", str(layout.mcap(0)), "--no-viewer", "--out", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    rebuilt, live = read_rrd(out), read_rrd(layout.rrd(0))
    assert rebuilt.rows == live.rows and rebuilt.steps == good.steps


def test_a_cut_mcap_replays_with_a_warning_of_what_was_lost(run, tmp_path, capsys):
    from mcap.writer import Writer

    from lerobot_policy_recent.logs.readers import salvage_mcap_records
    from lerobot_policy_recent.scripts.cli import main

    root, _ = run
    live = tmp_path / "live.mcap"  # the file as a running episode writes it: unchunked, flushed every step
    with open(live, "wb") as stream:
        writer = Writer(stream, use_chunking=False)
        writer.start()
        for record in salvage_mcap_records(LogLayout(root).mcap(0)):
            kind = type(record).__name__
            if kind == "Schema":
                writer.register_schema(record.name, record.encoding, record.data)
            elif kind == "Channel":
                writer.register_channel(record.topic, record.message_encoding, record.schema_id, record.metadata)
            elif kind == "Message":
                writer.add_message(
                    record.channel_id, record.log_time, record.data, record.publish_time, record.sequence
                )
        writer.finish()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(live.read_bytes()[: live.stat().st_size * 2 // 3])
    assert main(["replay", str(cut), "--out", str(tmp_path / "cut.rrd"), "--no-viewer"]) == 0
    err = capsys.readouterr().err
    assert f"warning: {cut} was cut short" in err and "whatever came after it is lost" in err


class _Planted:
    """What a planted pickle would run when loaded: it creates a file."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_planted_file_in_a_log_directory_runs_nothing(tmp_path, capsys):
    """A journal of an earlier version (pickle), or a file made to look like one of ours, is refused by name."""
    import pickle

    from lerobot_policy_recent.logs.journal import JournalError
    from lerobot_policy_recent.scripts.cli import main

    marker = tmp_path / "ran"
    pending = LogLayout(tmp_path / "logs").pending_dir
    pending.mkdir(parents=True)
    planted = pending / "episode_000005.pkl"
    planted.write_bytes(pickle.dumps(_Planted(str(marker))))
    with pytest.raises(JournalError, match=rf"{planted}: a journal of an earlier version \(pickle\)"):
        Recorder(tmp_path / "logs")
    assert main(["logs", "verify", str(tmp_path / "logs")]) == 1
    assert f"{planted}: a journal of an earlier version" in capsys.readouterr().out
    planted.unlink()
    disguised = pending / "episode_000006.npz"
    np.savez(disguised, meta=np.array([_Planted(str(marker))], dtype=object))
    with pytest.raises(JournalError, match=rf"{disguised}: not a journal written by this version"):
        Recorder(tmp_path / "logs")
    assert not marker.exists()  # nothing in either file ran


def test_failure_report_lists_the_injected_categories(run, tmp_path):
    from lerobot_policy_recent.logs.failure_report import failure_table, plot_failures

    root, _ = run
    table = failure_table([root])
    assert dict(table.counts["rejected spans"]) == {
        "hallucinated_kwarg": 1,
        "empty_continuation": 1,
        "non_executable": 1,
    }
    assert dict(table.counts["failed episodes"]) == {"non_executable": 1}
    assert "| hallucinated_kwarg | 1 | 0 | 0 |" in table.markdown()
    png = plot_failures(table, tmp_path / "failures.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_upload_pushes_dataset_tables_and_card_to_the_hub(run):
    from lerobot_policy_recent.logs.upload import upload

    root, _ = run
    hub = RecordingHub()
    url = upload(root, "someone/recent-runs", private=True, api=hub)
    assert url.endswith("someone/recent-runs") and hub.private is True
    assert {"meta/info.json", "grounding_events/episode_000000.parquet", "results/episode_000001.parquet"} <= hub.files
    assert not any(f.startswith(("mcap/", "rerun/")) for f in hub.files)
    card = hub.card
    assert "config_name: grounding_events" in card and "2 episodes (1 successful)" in card
    assert hub.tags == ["v3.0"]


@pytest.mark.skipif(not os.environ.get("HF_TOKEN"), reason="needs HF_TOKEN and a network to reach the Hub")
def test_upload_to_the_real_hub(run):  # pragma: no cover - no machine here reaches the Hub
    from huggingface_hub import HfApi

    from lerobot_policy_recent.logs.upload import upload

    root, _ = run
    user = HfApi().whoami()["name"]
    upload(root, f"{user}/recent-logs-test", private=True)


class RecordingHub:
    """Stands in for ``huggingface_hub.HfApi``: records what would be pushed."""

    def __init__(self):
        self.files: set[str] = set()
        self.card = ""
        self.tags: list[str] = []
        self.private = None

    def create_repo(self, repo_id, *, repo_type, private, exist_ok):
        assert repo_type == "dataset"
        self.private = private
        return f"https://huggingface.co/datasets/{repo_id}"

    def upload_file(self, *, path_or_fileobj, path_in_repo, repo_id, repo_type):
        self.card = Path(path_or_fileobj).read_text()
        self.files.add(path_in_repo)

    def upload_folder(self, *, folder_path, repo_id, repo_type, path_in_repo=""):
        for path in Path(folder_path).rglob("*"):
            if path.is_file():
                self.files.add(str(Path(path_in_repo) / path.relative_to(folder_path)))

    def create_tag(self, repo_id, *, tag, repo_type, exist_ok):
        self.tags.append(tag)


class BrokenSink:
    def begin(self, start):
        pass

    def event(self, stamped):
        pass

    def step(self, step):
        raise OSError("disk full")

    def end(self, result):
        pass

    def close(self):
        pass


def test_a_failing_sink_is_switched_off_and_the_episode_goes_on(tmp_path, ontology):
    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology)
    recorder = Recorder(tmp_path, ["mcap"])
    recorder.sinks.append(BrokenSink())
    with recorder:
        result = run_episode(agent, "kinematic/press_button", "UR5e", seed=0, recorder=recorder)
    assert result.success
    assert recorder.failed == {"BrokenSink": "OSError: disk full"}
    assert read_mcap(LogLayout(tmp_path).mcap(0)).steps == result.steps
    assert LogLayout(tmp_path).committed() == [0]  # committed without the dataset sink too
    assert Recorder(tmp_path, ["mcap"]).last_episode is None and LogLayout(tmp_path).next_episode() == 1


@pytest.mark.skipif(sys.platform != "linux", reason="a thread's own priority is Linux's")
def test_the_dataset_writer_works_on_what_the_robot_and_its_lm_leave_idle(tmp_path):
    """It encodes an ended episode's video while the next episode runs: at the least CPU priority."""
    from lerobot_policy_recent.logs.dataset_sink import WRITER_NICENESS, DatasetSink

    sink = DatasetSink(LogLayout(tmp_path))
    try:
        deadline = time.monotonic() + 30
        while os.getpriority(os.PRIO_PROCESS, sink._writer.native_id) != WRITER_NICENESS:
            assert time.monotonic() < deadline, "the writer thread kept its priority"
            time.sleep(0.01)
        assert os.nice(0) != WRITER_NICENESS  # the thread's own, not the process's
    finally:
        sink.close()


CHILD = """
import sys
from lerobot_policy_recent.logs.recorder import Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.recent_plugin.episode import run_episode
recorder = Recorder(sys.argv[1])
run_episode(RecentAgent(RecentSettings(infiller=RuleConfig())), "kinematic/tidy_bench", "UR5e", seed=0, recorder=recorder)
"""


def test_sigkill_mid_episode_then_recover_salvages_everything_flushed(tmp_path):
    from lerobot_policy_recent.logs.verify import recover, verify

    layout = LogLayout(tmp_path)
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path)], cwd=Path(__file__).parents[1])
    try:
        seen = None
        deadline = time.time() + 240
        while time.time() < deadline and child.poll() is None:
            if layout.mcap(0).exists():
                contents = read_mcap(layout.mcap(0))
                if contents.steps >= 120:
                    seen = contents
                    break
            time.sleep(0.5)
        assert seen is not None, "the episode never got 120 steps into its log"
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
    assert not verify(tmp_path).ok  # the interrupted episode is reported
    salvaged = recover(tmp_path)
    assert len(salvaged) == 2
    assert all(s.steps >= 1 and s.events >= 1 for s in salvaged)  # it says what it salvaged
    recovered = read_mcap(layout.mcap_dir / "episode_000000.recovered.mcap")
    assert recovered.complete
    assert recovered.steps >= seen.steps and len(recovered.events) >= len(seen.events)
    assert recovered.events[: len(seen.events)] == seen.events
    rrd = next(s for s in salvaged if s.target.endswith(".rrd"))
    assert rrd.how == "rebuilt from MCAP"  # a kill loses at most the step in flight, in the recording too
    assert (rrd.steps, rrd.events) == (recovered.steps, len(recovered.events))
    assert verify(tmp_path).ok  # recovered files are accounted for
    Recorder(tmp_path, ["mcap"]).close()  # the next run sets the interrupted files aside
    assert sorted(p.suffix for p in layout.interrupted_dir.iterdir()) == [".mcap", ".mcap", ".rrd", ".rrd"]


COMMIT_CHILD = """
import os, signal, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot_policy_recent.logs import dataset_sink
from lerobot_policy_recent.logs.recorder import Recorder
from lerobot_policy_recent.recent_plugin.agent import RecentAgent
from lerobot_policy_recent.recent_plugin.infillers.configs import RuleConfig
from lerobot_policy_recent.recent_plugin.methods import method_named
from lerobot_policy_recent.recent_plugin.settings import RecentSettings
from lerobot_policy_recent.recent_plugin.episode import run_episode

def die(*_args, **_kwargs):
    os.kill(os.getpid(), signal.SIGKILL)

def then_die(original, when=lambda *a, **k: True):
    def wrapped(*args, **kwargs):
        out = original(*args, **kwargs)
        if when(*args, **kwargs):
            die()
        return out
    return wrapped

point = sys.argv[2]
agent = RecentAgent(RecentSettings(infiller=RuleConfig()))
recorder = Recorder(sys.argv[1])
run_episode(agent, "kinematic/press_button", "UR5e", seed=0, max_steps=25, recorder=recorder)
while dataset_sink.os.path.exists(recorder.layout.journal(0)):  # episode 0 is committed before the kill
    import time; time.sleep(0.05)
if point == "ended":  # after the last step: the episode ended, its commit never started
    dataset_sink.commit = die
elif point == "mid_write":  # LeRobot wrote the episode's files into the staging copy, not its metadata
    LeRobotDataset.save_episode = then_die(LeRobotDataset.save_episode)
elif point == "before_swap":  # the staging copy is complete, the dataset not yet swapped
    dataset_sink.os.replace = then_die(dataset_sink.os.replace, lambda src, dst: str(dst).endswith(".ready"))
elif point == "mid_swap":  # the old dataset moved aside, the new one not yet in place
    dataset_sink.os.replace = then_die(dataset_sink.os.replace, lambda src, dst: str(dst).endswith(".old"))
elif point == "before_result":  # the dataset holds the episode, the result row is not written
    dataset_sink.write_parquet_atomically = then_die(
        dataset_sink.write_parquet_atomically, lambda rows, path: "grounding_events" in str(path)
    )
run_episode(agent, "kinematic/press_button", "UR5e", seed=1, max_steps=25, recorder=recorder)
recorder.close()
print("not killed")
"""


@pytest.mark.parametrize(
    "point",
    [
        "ended",
        "mid_write",
        pytest.param("before_swap", marks=pytest.mark.slow),
        "mid_swap",
        pytest.param("before_result", marks=pytest.mark.slow),
    ],
)
def test_a_kill_during_the_dataset_commit_loses_no_finished_episode(tmp_path, point):
    """SIGKILL at each stage of an ended episode's commit; the next recorder finishes it, once."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_policy_recent.logs.dataset_sink import log_episodes
    from lerobot_policy_recent.logs.verify import verify

    child = subprocess.run(
        [sys.executable, "-c", COMMIT_CHILD, str(tmp_path), point],
        cwd=Path(__file__).parents[1],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert child.returncode == -signal.SIGKILL, child.stdout[-500:] + child.stderr[-2000:]
    layout = LogLayout(tmp_path)
    assert layout.committed() == [0]  # killed before episode 1's result row
    Recorder(tmp_path).close()  # the next run recovers what had ended
    assert layout.committed() == [0, 1] and not list(layout.pending_dir.glob("*"))
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith("dataset.")]  # no staging left
    dataset = LeRobotDataset("local/recent_episodes", root=layout.dataset_dir, video_backend="pyav")
    assert dataset.num_episodes == 2 and log_episodes(layout.dataset_dir) == [0, 1]  # whole, and once
    rows = [read_table(layout.results(i))[0]["num_frames"] for i in (0, 1)]
    assert dataset.num_frames == sum(rows)
    report = verify(tmp_path)
    assert report.ok, (report.problems, [e.problems for e in report.episodes])


def test_a_camera_is_logged_as_video(tmp_path, ontology):
    """With a camera, the dataset holds the front view as LeRobot video (AV1 in mp4), one frame per step."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    agent = RecentAgent(RecentSettings(infiller=RuleConfig()), ontology=ontology)
    with Recorder(tmp_path, ["dataset"]) as recorder:
        result = run_episode(
            agent, "kinematic/press_button", "UR5e", seed=0, max_steps=12, recorder=recorder, camera=True
        )
    dataset = LeRobotDataset("local/recent_episodes", root=LogLayout(tmp_path).dataset_dir, video_backend="pyav")
    assert dataset.meta.video_keys == ["observation.images.front"] and dataset.num_frames == result.steps
    assert list((LogLayout(tmp_path).dataset_dir / "videos").rglob("*.mp4"))
    frame = dataset[result.steps - 1]["observation.images.front"]
    assert tuple(frame.shape) == (3, 84, 84) and float(frame.std()) > 0.01  # a rendered scene, not a blank
    from lerobot_policy_recent.logs.replay import replay_episode

    replayed = read_rrd(replay_episode(tmp_path, 0, tmp_path / "replay.rrd"))  # the camera comes back from video
    assert replayed.steps == result.steps and replayed.rows["/camera/front"] == result.steps


RERUN_CHILD = """
import sys, time
import numpy as np
from lerobot_policy_recent.logs.events import EpisodeStarted, Stamped, Step
from lerobot_policy_recent.logs.rerun_sink import FLUSH_S, RerunSink
from lerobot_policy_recent.robosuite_envs.observation import AGENT_POS_DIM, ENV_STATE_DIM

sink = RerunSink(lambda _i: __import__("pathlib").Path(sys.argv[1]))
sink.begin(Stamped(EpisodeStarted("kinematic/press_button", "UR5e", 0, object_names=["button"]), 0, 0, time.time_ns()))
for i in range(int(sys.argv[2])):
    sink.step(Step(0, i, i / 20, time.time_ns(), np.zeros(AGENT_POS_DIM), np.zeros(ENV_STATE_DIM), np.zeros(7)))
    time.sleep(FLUSH_S / 4)
print("stepped", flush=True)
time.sleep(600)
"""


def test_a_killed_rerun_recording_keeps_all_but_its_last_moments(tmp_path):
    """No event and no end: the steps still reach the file within FLUSH_S, so a SIGKILL loses only those."""
    from lerobot_policy_recent.logs.rerun_sink import BATCH
    from lerobot_policy_recent.logs.verify import recover_rrd

    steps = 20  # fewer than a batch: only the time bound can have sent them
    assert steps < BATCH
    path = tmp_path / "episode_000000.rrd"
    child = subprocess.Popen(
        [sys.executable, "-c", RERUN_CHILD, str(path), str(steps)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline().strip() == "stepped"
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
    recover_rrd(path, tmp_path / "recovered.rrd")
    kept = read_rrd(tmp_path / "recovered.rrd").rows["/world/eef"]
    assert steps - 4 <= kept <= steps  # at most the last FLUSH_S of steps (4 steps here) is lost


def test_recovery_writes_each_schema_and_channel_once(run, tmp_path):
    """A finished file repeats its schemas and channels in the summary; a file cut short during that
    summary hands both copies to recovery, which must still register each once."""
    from mcap.reader import make_reader

    from lerobot_policy_recent.logs.verify import recover_mcap

    root, (good, _) = run
    source = LogLayout(root).mcap(0)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(source.read_bytes()[:-40])  # the footer and the end of the summary gone
    recovered = tmp_path / "recovered.mcap"
    recover_mcap(cut, recovered)
    with open(recovered, "rb") as stream:
        summary = make_reader(stream).get_summary()
    topics = [c.topic for c in summary.channels.values()]
    assert len(topics) == len(set(topics)) and len(summary.schemas) == len({s.name for s in summary.schemas.values()})
    assert read_mcap(recovered).steps == good.steps


def test_log_commands_refuse_what_they_cannot_do_and_say_so(run, tmp_path, capsys, monkeypatch):
    """Each bad input exits non-zero with one line, and nothing is created or claimed."""
    from lerobot_policy_recent.scripts.cli import main

    root, _ = run
    rrd = LogLayout(root).rrd(0)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    cases = [
        (["failures", "report", str(tmp_path / "typo")], "no such log directory"),
        (["replay", str(rrd), "--no-viewer", "--out", str(tmp_path / "x.rrd")], "is a Rerun recording already"),
        (["replay", str(rrd), "--no-viewer"], "nothing to do"),
        (["replay", str(rrd)], "no display"),
        (["replay", str(tmp_path / "missing.rrd")], "does not exist"),
        (["upload", str(root), "--repo-id", "badname"], "is not ORG/NAME"),
        (["upload", str(tmp_path), "--repo-id", "me/runs", "--dry-run"], "holds no finished episodes"),
    ]
    for argv, said in cases:
        assert main(argv) == 2, argv
        assert said in capsys.readouterr().err, argv
    assert not (tmp_path / "typo").exists() and not (tmp_path / "x.rrd").exists()


def test_upload_checks_the_token_first_and_a_dry_run_lists_what_would_go(run, tmp_path, capsys, monkeypatch):
    from lerobot_policy_recent.scripts.cli import main

    root, _ = run
    assert main(["upload", str(root), "--repo-id", "me/runs", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "would push" in out and "grounding_events" in out and "nothing was pushed" in out
    monkeypatch.delenv("HF_TOKEN", raising=False)
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))  # no stored token either
    assert main(["upload", str(root), "--repo-id", "me/runs"]) == 2
    assert "no Hugging Face token" in capsys.readouterr().err
