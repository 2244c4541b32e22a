"""`g1ctl run` taking instructions while it runs, end to end: through its socket with `g1ctl tell`, from standard input on
simulated buses, and what it refuses in one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

from controller.recording import topics
from controller.recording.reader import read_recording
from tests.conftest import G1CTL, g1ctl, one_line_error, wait_for


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (("run", "--no-planner", "--instructions", "-", "--input", "scripted"), "drop --no-planner"),
        (("run", "--instructions", "-", "--input", "keyboard"), "the keyboard reads too"),
        (("run", "--input", "scripted", "--instructions", "{shared}/g1.sock"), "can be written by others"),
        (("tell", "wave", "--to", "{tmp}/none.sock"), "no run listens on"),
    ],
)
def test_what_a_run_cannot_take_is_refused_in_one_line(args: tuple[str, ...], says: str, tmp_path: Path) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    error = one_line_error(g1ctl(*(a.format(shared=shared, tmp=tmp_path) for a in args)))
    assert says in error
    assert not (shared / "g1.sock").exists()


def tell(path: Path, text: str, timeout: float = 10.0) -> tuple[int, str]:
    result = g1ctl("tell", text, "--to", str(path), "--timeout", str(timeout))
    assert result.stderr == "", result.stderr
    return result.returncode, result.stdout.strip()


@pytest.mark.slow
def test_instructions_through_the_socket_switch_refuse_and_stop(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir(mode=0o700)
    path, report_path, recording = folder / "g1.sock", tmp_path / "run.json", tmp_path / "run.mcap"
    command = [*G1CTL, "run", "--instructions", str(path), "--duration", "120", "--report", str(report_path), "--record", str(recording)]
    with tempfile.TemporaryDirectory(prefix="g1ctl-cwd-") as cwd:
        run = subprocess.Popen(command, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert wait_for(path.exists, timeout=60.0)
            assert tell(path, "walk forward 1 m", timeout=120.0) == (0, "accepted: 1 clause: walk forward 1 m")
            time.sleep(1.5)
            code, line = tell(path, "do a backflip")
            assert code == 1 and line.startswith('refused: cannot plan "do a backflip"')
            assert tell(path, "turn left 90 degrees") == (0, "accepted: 1 clause: turn left 90 degrees")
            time.sleep(1.0)
            assert tell(path, "stop") == (0, "accepted: stop: the robot stands")
            code, line = tell(path, "   ")
            assert code == 1 and line.startswith("refused: empty instruction")
        finally:
            run.send_signal(signal.SIGINT)  # Ctrl-C ends the run; its report is written
            stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == 0, stderr
    assert not path.exists()  # removed at the end
    summary = json.loads(next(line for line in stdout.splitlines() if line.startswith('{"instructions"')))["instructions"]
    assert (summary["received"], summary["accepted"], summary["refused"], summary["stops"]) == (5, 2, 2, 1)
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["interrupted"]
    log = report["instructions"]["log"]
    assert [entry["status"] for entry in log] == ["interrupted", "refused", "stopped", "stop", "refused"]
    walk, _, turn = log[:3]
    assert walk["clauses_run"][0]["interrupted"] and walk["clauses_run"][0]["displacement"][0] > 0.2
    assert turn["clauses_run"][0]["start_s"] == walk["clauses_run"][0]["end_s"] and turn["clauses_run"][0]["heading_change_deg"] > 20
    latency = report["instructions"]["first_plan_latency_s"]
    assert latency["n"] == 2 and 0 < latency["max"] < 1.0  # the target (0.3 s at p95) is judged by `g1ctl bench typed`
    said = [message.message for _, message in read_recording(recording, keep=[topics.LOG.name]).decoded(topics.LOG)]
    assert "accepted: 1 clause: walk forward 1 m" in said and "accepted: stop: the robot stands" in said


@pytest.mark.slow
def test_instructions_from_standard_input_on_simulated_buses(tmp_path: Path) -> None:
    report_path = tmp_path / "run.json"
    with tempfile.TemporaryDirectory(prefix="g1ctl-cwd-") as cwd:
        result = subprocess.run(
            [*G1CTL, "run", "--hardware", "sim-can", "--instructions", "-", "--report", str(report_path), "--duration", "60"],
            input="wave with your right hand\ndance like a chicken\n", cwd=cwd, capture_output=True, text=True, timeout=300,
            env={**os.environ},
        )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "g1ctl run: accepted: 1 clause: wave with your right hand" in result.stderr
    assert 'g1ctl run: refused: cannot plan "dance like a chicken"' in result.stderr
    report = json.loads(report_path.read_text())
    assert report["falls"] == 0 and report["hw"]["faults"] == 0 and report["run_seconds"] < 30  # it ended once the wave was over
    (wave, refused) = report["instructions"]["log"]
    assert wave["status"] == "done" and wave["origin"] == "stdin" and refused["status"] == "refused"
    assert wave["clauses_run"][0]["end_s"] - wave["clauses_run"][0]["start_s"] >= 2.0
