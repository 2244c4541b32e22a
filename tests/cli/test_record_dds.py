"""`--record` through the simulated G1 over DDS in its own process: the wall-clock robot run, recorded and read back."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the g1 extra (cyclonedds) is not installed")

from controller.recording import topics
from controller.recording.reader import read_recording
from tests.conftest import g1ctl

pytestmark = pytest.mark.slow


def test_a_walk_through_the_simulated_g1_over_dds_is_recorded(tmp_path: Path, sim_dds_config: Callable[[], Path]) -> None:
    record, report_path = tmp_path / "dds.mcap", tmp_path / "dds.json"
    hardware = str(sim_dds_config())
    result = g1ctl("sim", "--duration", "4", "--hardware", hardware, "--record", str(record), "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["recorder"]["drops"] == 0
    info = g1ctl("log", "info", str(record))
    assert info.returncode == 0 and info.stderr == "" and "on SimulatedDdsBackend" in info.stdout
    # a fall ends a run on hardware: the recording has it where the report has it (none, on a machine with time to spare)
    assert info.stdout.count("session: the robot fell") == report["falls"]
    bus_topic = topics.PAYLOAD_TOPICS["bus"]
    recording = read_recording(record, keep={bus_topic.name})
    ticks = report["recorder"]["ticks"]
    for topic in ("/joints", "/command", "/reference", "/state", "/estimate", "/truth", "/tf", "/tracking"):
        assert recording.topics[topic].count == ticks, topic
    link = [message for _, message in recording.decoded(bus_topic)]
    assert link[-1]["state"] == "active" and 0 < link[-1]["states_received"] <= report["hw"]["states_received"]  # the DDS link's
