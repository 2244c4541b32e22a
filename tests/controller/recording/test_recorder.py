"""The flight recorder in process: a real session on the G1 model recorded into real MCAP files, read back.

What each tick recorded is checked against what the session did; a fault becomes a line on /log;
a writer behind a slow disk drops and counts instead of holding up the loop; a file cut off is
read up to the cut, and a file that is no MCAP is refused.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from controller.inputs.scripted import ScenarioStep, ScriptedSource
from controller.recording import topics
from controller.recording.info import describe, log_lines
from controller.recording.reader import read_recording
from controller.recording.sink import McapSink, Topic, check_record_path
from controller.runtime.session import Session
from controller.runtime.sim_backends import DirectSimBackend
from controller.tracking.presets import load_policy
from hw import g1
from hw.errors import ConfigError
from hw.shipped import config_dir
from sim.robot import SimRobot
from tests.conftest import wait_for

EVERY_TICK = ("/state", "/command", "/reference", "/input", "/supervisor", "/tracking", "/joints", "/tf")


def policy_yaml(tmp_path: Path, linear_onnx: Callable[..., Path], nan_output: bool = False) -> Path:
    """The fastsac preset with a zero (or NaN) linear graph of the same shape as its policy."""
    onnx = linear_onnx(np.zeros((100, 29)), name="tiny.onnx", nan_output=nan_output)
    path = tmp_path / "tiny.yaml"
    path.write_text((config_dir("policies") / "fastsac.yaml").read_text().replace("fastsac_g1_29dof.onnx", str(onnx)))
    return path


def recorded_session(g1_model: Any, assets: Any, policy: Path, record: Path, ticks: int) -> tuple[Session, list[dict[str, Any]]]:
    """`ticks` ticks of a standing G1 recorded into `record`; what the session wrote each tick, as it wrote it."""
    robot = SimRobot(g1_model)
    tracker = load_policy(str(policy), assets, robot.joint_names)
    backend = DirectSimBackend(robot)
    sent: list[dict[str, Any]] = []
    with backend, ScriptedSource((ScenarioStep(t=0.0, label="stand"),)) as source:
        session = Session(backend, tracker, source, record=record)
        try:
            session.start()
            for k in range(ticks):
                backend.advance_to(session.start_time + k / tracker.rate_hz)
                session.tick()
                sent.append({"time": robot.read().time, "q": robot.read().joint_pos.copy(), "mode": session.supervisor.mode.value})
        finally:
            session.close()
    return session, sent


def test_every_tick_is_recorded_as_the_session_saw_it(g1_model, assets, tmp_path: Path, linear_onnx) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "stand.mcap"
    session, _ = recorded_session(g1_model, assets, policy_yaml(tmp_path, linear_onnx), path, ticks=30)
    report = session.recorder_report()["recorder"]
    assert report["path"] == str(path) and report["ticks"] == 30 and report["drops"] == 0
    recording = read_recording(path, keep={"/joints", "/command", "/tf", "/supervisor", "/log"})
    assert recording.complete and recording.problem is None and recording.warning() is None
    assert report["messages"] == recording.messages and report["bytes"] == path.stat().st_size
    for topic in EVERY_TICK:
        assert recording.topics[topic].count == 30, topic
    assert "/estimate" not in recording.topics and "/truth" not in recording.topics  # the simulator read directly: its own truth
    assert recording.topics["/joints"].schema == "foxglove.JointStates" and recording.topics["/command"].schema == "g1ctl.JointCommand"
    assert not {"/counters/bus", "/counters/estimator"} & set(recording.topics)  # no bus, no estimator here
    run = recording.run
    assert run["format"] == "g1ctl-recording-1" and json.loads(run["joint_names"]) == list(g1.JOINT_NAMES)
    assert run["tracker"] == "velocity" and run["backend"] == "DirectSimBackend"
    assert recording.metadata["recorder"] == {"offered": "30", "drops": "0"}
    span = recording.span_s
    assert span is not None and span[1] - span[0] == pytest.approx(29 / 50, abs=1e-6)
    joints = recording.decoded(topics.JOINTS)
    assert [joint.name for joint in joints[0][1].joints] == list(g1.JOINT_NAMES)
    commands = recording.decoded(topics.PAYLOAD_TOPICS["command"])
    assert len(commands[0][1].q) == 29 and all(kp > 0 for kp in commands[-1][1].kp)  # the policy's gains, running
    assert [m.mode for _, m in recording.decoded(topics.PAYLOAD_TOPICS["supervisor"])] == ["run"] * 30
    assert [text for _, _, _, text in log_lines(recording)] == ["mode run"]
    pelvis = [t for _, m in recording.decoded(topics.TF) for t in m.transforms]
    assert {t.child_frame_id for t in pelvis} == {"pelvis"} and pelvis[0].translation.z == pytest.approx(
        g1.STANDING_PELVIS_HEIGHT, abs=0.05
    )


def test_a_fault_is_a_log_line_and_the_file_is_finished(g1_model, assets, tmp_path: Path, linear_onnx) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "nan.mcap"
    session, sent = recorded_session(g1_model, assets, policy_yaml(tmp_path, linear_onnx, nan_output=True), path, ticks=8)
    assert session.ended_in_fault
    recording = read_recording(path, keep={"/log", "/supervisor", "/command"})
    assert recording.complete
    lines = log_lines(recording)
    damped = [line for line in lines if line[2] == "supervisor" and "damp" in line[3]]
    assert len(damped) == 1 and damped[0][1] == "WARNING" and "non-finite" in damped[0][3]
    assert damped[0][0] == pytest.approx(sent[3]["time"])  # the tick the supervisor damped at: the fourth (after three NaNs)
    faults = [(t, text) for t, level, source, text in lines if level == "ERROR"]
    assert len(faults) == 1 and faults[0][0] == damped[0][0] and "non-finite" in faults[0][1]  # the fault itself, once
    modes = [m.mode for _, m in recording.decoded(topics.PAYLOAD_TOPICS["supervisor"])]
    assert modes == [s["mode"] for s in sent] and modes[-1] == "damp"
    last = recording.decoded(topics.PAYLOAD_TOPICS["command"])[-1][1]
    assert all(kp == 0.0 for kp in last.kp) and all(kd == pytest.approx(g1.DAMPING_KD) for kd in last.kd)  # damping, as sent
    text = "\n".join(describe(recording))
    assert "faults: " in text and "faults: none" not in text and "run -> damp" in text


SLOW_S = 0.02  # what the slow writer takes per item
NUMBER = Topic("/n", "test.Number", json_schema={"type": "object", "properties": {"n": {"type": "integer"}}})


def number(n: int) -> list[tuple[Topic, int, bytes]]:
    return [(NUMBER, n * 1_000_000, json.dumps({"n": n}).encode())]


def test_a_slow_writer_drops_and_counts_and_never_blocks_the_loop(tmp_path: Path) -> None:
    path = tmp_path / "slow.mcap"

    def slow(n: int) -> list[tuple[Topic, int, bytes]]:
        time.sleep(SLOW_S)  # a writer that cannot keep up (a slow disk, a starved thread)
        return number(n)

    sink = McapSink(path, slow, {"test": "slow writer"}, queue_items=4)
    offers = []
    for n in range(100):
        start = time.perf_counter()
        sink.offer(n)
        offers.append(time.perf_counter() - start)
    assert sum(offers) < 25 * SLOW_S  # writing the 100 items takes 100 * SLOW_S: the loop did not wait for it
    sink.close()
    assert sink.drops > 50 and sink.messages + sink.drops == 100
    recording = read_recording(path, keep={"/n"})
    assert recording.complete and recording.topics["/n"].count == sink.messages
    written = [json.loads(data)["n"] for _, data in recording.kept["/n"]]
    assert written == sorted(written) and written[0] == 0  # in order; the first went through, most later ones were dropped
    assert recording.metadata["recorder"] == {"offered": "100", "drops": str(sink.drops)}
    assert sink.report() == {"path": str(path), "messages": sink.messages, "drops": sink.drops, "bytes": path.stat().st_size}


def test_a_writer_that_fails_stops_recording_not_the_run(tmp_path: Path) -> None:
    path = tmp_path / "broken.mcap"

    def failing(n: int) -> list[tuple[Topic, int, bytes]]:
        if n == 3:
            raise OSError(28, "No space left on device")
        return number(n)

    sink = McapSink(path, failing, {})
    for n in range(10):
        sink.offer(n)
    sink.close()
    assert sink.error == "OSError: [Errno 28] No space left on device" and sink.messages == 3 and sink.drops == 7
    recording = read_recording(path, keep={"/n"})
    assert recording.complete and recording.topics["/n"].count == 3
    assert recording.metadata["recorder"]["error"] == sink.error


def test_a_file_cut_off_is_read_up_to_the_cut(tmp_path: Path) -> None:
    path = tmp_path / "whole.mcap"
    sink = McapSink(path, number, {}, chunk_seconds=0.0)  # a chunk per item: what a slow real-time run does once a second
    for n in range(200):
        assert sink.offer(n) or wait_for(lambda n=n: sink.offer(n))
    sink.close()
    whole = path.read_bytes()
    for size, messages in ((len(whole) // 2, range(1, 200)), (len(whole) - 20, range(200, 201))):  # in the data; in the summary
        cut = tmp_path / f"cut-{size}.mcap"
        cut.write_bytes(whole[:size])
        recording = read_recording(cut, keep={"/n"})
        assert not recording.complete and "ends before its footer" in (recording.warning() or "")
        read = [json.loads(data)["n"] for _, data in recording.kept["/n"]]
        assert len(read) in messages and read == list(range(len(read)))  # every message up to the cut, none after it
    assert read_recording(path).complete


def test_a_file_that_is_no_mcap_is_refused_in_one_line(tmp_path: Path) -> None:
    text = tmp_path / "notes.mcap"
    text.write_text("these are no MCAP records\n")
    with pytest.raises(ConfigError, match=r"notes.mcap is not an MCAP file \(it does not begin with MCAP's magic bytes\)"):
        read_recording(text)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(ConfigError, match="is not an MCAP file"):
        read_recording(empty)
    with pytest.raises(ConfigError, match="no such file"):
        read_recording(tmp_path / "missing.mcap")


def test_a_recording_path_that_cannot_be_written_is_refused(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    (tmp_path / "folder.mcap").mkdir()
    cases = {
        blocker / "run.mcap": "cannot write it",  # a file where a folder should be
        tmp_path / "folder.mcap": "that is a folder",
        tmp_path / "run.json": "a recording is an MCAP file, name it",
        Path("/proc/run.mcap"): "cannot write it",  # not even root may create files there
    }
    for path, message in cases.items():
        with pytest.raises(ConfigError, match=message):
            check_record_path(path)
    fine = tmp_path / "new" / "folder" / "run.mcap"
    check_record_path(fine)
    assert fine.parent.is_dir() and not fine.exists()  # the probe leaves no file behind
