"""Result writers: exact CSV round trip, run.json fields, plots, a readable MCAP file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from fmionnx.results.csvfile import read_csv, write_csv
from fmionnx.results.mcap_record import McapRecorder
from fmionnx.runtime.result import RunResult, RunStatus


def _result() -> RunResult:
    time = np.arange(5) * 0.1
    return RunResult(
        system="demo",
        backend="inprocess",
        status=RunStatus.COMPLETED,
        start=0.0,
        stop=0.4,
        step=0.1,
        steps_done=4,
        wall_time=0.01,
        time=time,
        signals={"a.y": np.array([0.1, 1 / 3, np.pi, -1e-300, 2.5e17]), "b.x[0]": np.ones(5)},
    )


def test_csv_round_trips_every_float_exactly(tmp_path: Path) -> None:
    result = _result()
    path = write_csv(result, tmp_path / "results.csv")
    table = read_csv(path)
    assert list(table) == ["time", "a.y", "b.x[0]"]
    np.testing.assert_array_equal(table["a.y"], result.signals["a.y"])
    np.testing.assert_array_equal(table["time"], result.time)


def test_mcap_holds_ros2_images_and_json_signals(tmp_path: Path) -> None:
    recorder = McapRecorder(tmp_path / "run.mcap")
    image = np.zeros((4, 6, 3), dtype=np.uint8)
    image[..., 0] = 200
    recorder.frame("world", "front", 0.1, image)
    recorder.finish(_result())
    with (tmp_path / "run.mcap").open("rb") as stream:
        reader = make_reader(stream)
        messages = list(reader.iter_messages())
    topics = [channel.topic for _, channel, _ in messages]
    assert topics.count("/world/front") == 1
    assert topics.count("/signals") == 5
    schema, _, message = next(m for m in messages if m[1].topic == "/world/front")
    assert schema is not None
    assert schema.name == "sensor_msgs/msg/Image"
    assert message.log_time == 100_000_000
    last = json.loads(messages[-1][2].data)
    assert last["time"] == 0.4
    assert last["a.y"] == 2.5e17
