"""Instructions while the robot runs, on an ideal robot: switched to at once from where it is, refused without a change,
"stop" and the supervisor win, a resolver's process that dies is replaced. The real resolver process, planner and encoder."""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from controller.commands.velocity import ZERO, VelocityCommand
from controller.inputs.instructions import Instruction, InstructionInbox
from controller.planner.runtime import Planner
from controller.reference.planned import PlannedReference
from controller.text.live import NOT_RUNNING, LiveTextReference
from controller.text.resolver import ResolverProcess
from tests.conftest import HANG_S, IdealRobot


@pytest.fixture(scope="module")
def planner() -> Planner:
    planner = Planner.load()
    planner.warm_up()
    return planner


@dataclass
class Live:
    reference: LiveTextReference
    robot: IdealRobot
    inbox: InstructionInbox
    resolver: ResolverProcess

    def send(self, text: str, device: VelocityCommand = ZERO, hold: bool = False) -> Instruction:
        """Submit `text` and tick (with the device's command) until the control thread has decided it."""
        instruction = self.inbox.submit(text, "test")
        assert instruction is not None
        deadline = time.monotonic() + HANG_S
        while instruction.status == "queued" and time.monotonic() < deadline:
            self.robot.tick(device, hold=hold)
        return instruction


@pytest.fixture
def live(planner: Planner) -> Iterator[Live]:
    inbox = InstructionInbox()
    with ResolverProcess(inbox) as resolver:
        planned = PlannedReference(planner.plan)
        reference = LiveTextReference(planned, resolver)
        yield Live(reference, IdealRobot(reference, planned), inbox, resolver)
        reference.close()


@pytest.mark.slow
def test_instructions_switch_at_once_from_where_the_robot_is_and_refusals_change_nothing(live: Live) -> None:
    reference, robot = live.reference, live.robot
    robot.run(0.5)
    walk = live.send("walk forward 1 m")
    assert walk.status == "running" and reference.running is walk and walk.details["clauses"] == ["walk forward 1 m"]
    robot.run(1.5)
    refused = live.send("do a backflip")
    assert refused.status == "refused" and refused.reason.startswith('cannot plan "do a backflip"')
    assert reference.running is walk  # the walk goes on
    assert reference.caption.startswith("1/1: walk forward 1 m | refused: cannot plan")
    x = float(robot.state.base_pos[0])
    assert 0.2 < x < 0.9
    turn = live.send("turn left 90 degrees")
    assert walk.status == "interrupted" and reference.running is turn
    assert walk.details["clauses_run"][0]["interrupted"] and walk.details["first_plan_latency_s"] > 0
    assert robot.until(lambda: reference.running is None, 15.0)
    assert turn.status == "done" and turn.details["first_plan_latency_s"] > 0
    (clause,) = turn.details["clauses_run"]
    assert not clause["interrupted"] and clause["heading_change_deg"] == pytest.approx(90.0, abs=12.0)
    assert float(robot.state.base_pos[0]) == pytest.approx(x, abs=0.15)  # turned where it was, not at the walk's end
    report = reference.report()["instructions"]
    assert (report["received"], report["accepted"], report["refused"]) == (3, 2, 1)
    assert [e["status"] for e in report["log"]] == ["interrupted", "refused", "done"] and report["first_plan_latency_s"]["n"] == 2
    lines = live.inbox.take_lines()
    assert [line.split(":")[0] for line in lines] == ["accepted", "refused", "accepted"]


@pytest.mark.slow
def test_stop_wins_and_the_robot_stands_until_its_device_asks_anew(live: Live) -> None:
    reference, robot, inbox = live.reference, live.robot, live.inbox
    keyboard = VelocityCommand(0.3, 0.0, 0.0)
    robot.run(0.5, keyboard)
    assert robot.velocity.vx == pytest.approx(0.3)  # no instruction: the device drives, as in any run
    wave = live.send("wave", keyboard)
    assert wave.status == "running" and robot.velocity.is_zero()
    walk = inbox.submit("walk forward 1 m", "test")
    stop = inbox.submit("stop", "test")
    robot.tick(keyboard)
    assert wave.status == "stopped" and reference.running is None and stop is not None and stop.status == "stop"
    assert walk is not None
    deadline = time.monotonic() + HANG_S
    while walk.status == "queued" and time.monotonic() < deadline:
        robot.tick(keyboard)
    assert walk.status == "cancelled" and walk.reason == "a stop came after it"  # sent before the stop: never runs
    robot.run(1.0, keyboard)
    assert robot.velocity.is_zero()  # the keyboard still says what it said before: the robot stands
    robot.tick(VelocityCommand(0.2, 0.0, 0.0))
    assert robot.velocity.vx == pytest.approx(0.2)  # the device asks anew: it drives again
    assert "accepted: stop: the robot stands" in inbox.take_lines()


@pytest.mark.slow
def test_the_supervisor_wins_and_a_resolver_that_died_is_replaced(live: Live) -> None:
    reference, robot = live.reference, live.robot
    walk = live.send("walk forward 1 m")
    robot.run(1.0)
    robot.tick(hold=True)  # an e-stop: the supervisor damps the robot
    assert walk.status == "interrupted" and "stopped running" in walk.reason and reference.running is None
    held = live.send("wave", hold=True)
    assert held.status == "refused" and held.reason == NOT_RUNNING
    pid = live.resolver.pid
    assert pid is not None
    os.kill(pid, signal.SIGKILL)
    lost = live.send("wave")
    assert lost.status == "refused" and "the resolver's process ended" in lost.reason and live.resolver.restarts == 1
    again = live.send("raise both arms")
    assert again.status == "running" and live.resolver.pid not in (None, pid)
    assert math.isfinite(again.details["resolve_ms"])
