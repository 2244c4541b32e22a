from __future__ import annotations

from controller.commands.velocity import VelocityCommand
from controller.inputs.base import Buttons, CommandSample
from controller.runtime.supervisor import Mode, Supervisor

WALK = VelocityCommand(vx=0.5)


def test_run_tracks_input_and_stop_holds_zero() -> None:
    sup = Supervisor()
    assert sup.update(CommandSample(WALK), None) == WALK
    assert sup.update(CommandSample(WALK, Buttons(stop=True)), None).is_zero()
    assert sup.mode is Mode.STAND
    assert sup.update(CommandSample(WALK), None).is_zero()
    assert sup.update(CommandSample(WALK, Buttons(start=True)), None) == WALK


def test_estop_and_dead_input_latch_damping_until_start() -> None:
    sup = Supervisor()
    assert sup.update(CommandSample(WALK, Buttons(estop=True)), None).is_zero()
    assert sup.mode is Mode.DAMP and sup.estops == 1
    assert sup.update(CommandSample(WALK), None).is_zero() and sup.mode is Mode.DAMP
    sup.update(CommandSample(WALK, Buttons(start=True)), None)
    assert sup.mode is Mode.RUN
    sup.update(CommandSample(alive=False), None)
    assert sup.mode is Mode.DAMP and sup.input_losses == 1 and "input lost" in sup.damp_reason
    sup.update(CommandSample(alive=False, buttons=Buttons(start=True)), None)
    assert sup.mode is Mode.DAMP  # cannot re-arm on a dead input


def test_policy_fault_damps_and_cannot_be_rearmed_while_present() -> None:
    sup = Supervisor()
    sup.update(CommandSample(WALK, Buttons(start=True)), "non-finite actions")
    assert sup.mode is Mode.DAMP and sup.damp_reason.startswith("fault")


def test_hold_stands_for_good_and_keeps_its_first_cause() -> None:
    sup = Supervisor()
    sup.hold("state estimate lost (feet slipping)")
    assert sup.mode is Mode.STAND
    assert sup.update(CommandSample(WALK, Buttons(start=True)), None).is_zero()  # start does not resume a held run
    assert sup.mode is Mode.STAND
    sup.hold("another cause")
    assert sup.hold_reason == "state estimate lost (feet slipping)"
    sup.update(CommandSample(WALK, Buttons(estop=True)), None)
    assert sup.mode is Mode.DAMP  # the e-stop still wins
    sup.hold("later")
    assert sup.mode is Mode.DAMP  # holding never lifts damping
