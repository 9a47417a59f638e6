"""Read each log back with its own library: mcap (+ protobuf decoders), Rerun's RrdReader, pyarrow/LeRobot.

Used by ``recent logs verify``, ``recent replay`` and the tests, so all three agree on what a
log holds.
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import pyarrow.parquet as pq


@dataclass(frozen=True)
class McapContents:
    topics: Counter  # messages per topic
    events: list[dict]  # the JSON grounding events, in order
    complete: bool  # the file has its footer (the episode ended or the run closed it)

    @property
    def steps(self) -> int:
        return self.topics.get("/action", 0)


@dataclass(frozen=True)
class McapMessage:
    topic: str
    log_time_ns: int
    data: bytes


def mcap_messages(path: Path) -> tuple[list[McapMessage], bool]:
    """Every message that can be read, in file order, and whether the file is complete (has its
    footer); a file cut short by a crash is read record by record up to the cut."""
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as stream:
            return [
                McapMessage(channel.topic, message.log_time, message.data)
                for _schema, channel, message in make_reader(stream).iter_messages(log_time_order=False)
            ], True
    except Exception:  # noqa: BLE001 - no footer: read the records in file order instead
        pass
    channels: dict[int, str] = {}
    messages = []
    for record in salvage_mcap_records(path):
        kind = type(record).__name__
        if kind == "Channel":
            channels[record.id] = record.topic
        elif kind == "Message":
            messages.append(McapMessage(channels.get(record.channel_id, ""), record.log_time, record.data))
    return messages, False


def read_mcap(path: Path) -> McapContents:
    """Messages per topic and the grounding events; a file cut short by a crash is read up to the cut."""
    messages, complete = mcap_messages(path)
    topics = Counter(m.topic for m in messages)
    events = [json.loads(m.data) for m in messages if m.topic.startswith("/recent/")]
    return McapContents(topics, events, complete)


def decoded_protobuf(path: Path, topic: str) -> list:
    """The messages of one protobuf topic, decoded with their embedded schemas (Foxglove's view)."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [decoded for _s, _c, _m, decoded in reader.iter_decoded_messages(topics=[topic])]


def salvage_mcap_records(path: Path) -> list:
    """The records of a (possibly truncated) MCAP in file order, up to the first damaged one."""
    from mcap.stream_reader import StreamReader

    records = []
    with open(path, "rb") as stream:
        try:
            for record in StreamReader(stream, skip_magic=False, emit_chunks=False).records:
                records.append(record)
        except Exception:  # noqa: BLE001 - a truncated tail is exactly what salvage expects
            pass
    return records


@dataclass(frozen=True)
class RrdContents:
    rows: Counter  # rows per entity path

    @property
    def events(self) -> int:
        return self.rows.get("/events", 0)

    @property
    def steps(self) -> int:
        return self.rows.get("/action", 0)


def read_rrd(path: Path) -> RrdContents:
    from rerun.chunk import RrdReader

    rows = Counter()
    for chunk in RrdReader(str(path)).stream().collect().stream():
        if not chunk.is_static:
            rows[chunk.entity_path] += chunk.num_rows
    return RrdContents(rows)


def read_table(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist()


def dataset_lengths(dataset_dir: Path) -> dict[int, int]:
    """Frames per log episode in the LeRobotDataset (empty when there is none); a dataset episode is
    keyed by the log episode it holds (``meta/recent_episodes.json``), which is its own index where
    the two agree."""
    if not (dataset_dir / "meta" / "info.json").exists():
        return {}
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

    from lerobot_policy_recent.logs.dataset_sink import REPO_ID, log_episodes

    meta = LeRobotDatasetMetadata(REPO_ID, root=dataset_dir)
    lengths = [int(n) for n in meta.episodes["length"]]
    held = log_episodes(dataset_dir)
    keys = held if len(held) == len(lengths) else [int(e) for e in meta.episodes["episode_index"]]
    return dict(zip(keys, lengths, strict=True))
