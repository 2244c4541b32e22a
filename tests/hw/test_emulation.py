"""Simulated hardware never fails silently (an emulator whose thread dies stops the run, naming why), and it answers
on the simulated clock: its host waits for the emulators, not for the wall clock."""

from __future__ import annotations

import dataclasses
import logging
import threading

import can
import pytest

from hw import g1
from hw.emulation.plant import StaticPlant
from hw.emulation.rig import SimulatedHardware
from hw.errors import EmulatorError
from hw.hardware_robot import HardwareRobot
from hw.jointmap import HardwareConfig, load_hardware_config
from hw.protocols import mit
from tests.conftest import wait_for


class ThreadFailingPlant(StaticPlant):
    """Fails where an emulator's receive thread reads it, as a bug in that thread would;
    the control step, run from the caller's thread, still works."""

    def joint_state(self, joint: str) -> tuple[float, float, float]:
        if threading.current_thread() is not threading.main_thread():
            raise RuntimeError("encoder read failed")
        return super().joint_state(joint)


def test_an_emulator_thread_that_dies_makes_the_next_step_raise_naming_the_cause(caplog: pytest.LogCaptureFixture) -> None:
    plant = ThreadFailingPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0))
    with SimulatedHardware(load_hardware_config("sim-can"), plant) as twin:
        twin.step()
        emulator = next(e for e in twin.emulators if e.name == "can0")
        host = can.Bus(interface="virtual", channel=twin.host_config.buses["can0"].channel)
        try:
            with caplog.at_level(logging.ERROR, logger="hw.emulation.firmware"):
                # Entering motor mode makes the receive thread sample the motor: the plant raises there.
                host.send(can.Message(arbitration_id=1, data=mit.ENTER_MOTOR_MODE, is_extended_id=False))
                assert wait_for(lambda: emulator.error is not None)
        finally:
            host.shutdown()
        assert isinstance(emulator.error, RuntimeError)
        assert "firmware emulator 'can0' died: RuntimeError: encoder read failed" in caplog.text
        with pytest.raises(EmulatorError, match=r"emulator of bus 'can0' died: RuntimeError: encoder read failed") as caught:
            twin.step()
        assert caught.value.__cause__ is emulator.error
        with pytest.raises(EmulatorError):
            twin.step()  # and every step after it: the bus stays dead


def _no_time_to_answer() -> HardwareConfig:
    """sim-can with a cycle timeout no emulator thread can meet on the wall clock (a microsecond)."""
    cfg = load_hardware_config("sim-can")
    return dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, cycle_timeout=1e-6))


def test_the_host_of_simulated_hardware_waits_for_the_emulators_not_the_wall_clock() -> None:
    plant = StaticPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0))
    with SimulatedHardware(_no_time_to_answer(), plant) as twin, HardwareRobot(twin.host_config, await_replies=twin.await_replies) as host:
        host.configure()
        for _ in range(50):
            host.cycle()
            twin.step()
        counters = host.counters()
        assert counters.frames_received >= 51 * g1.NUM_JOINTS and counters.dropped == 0 and counters.late_replies == 0


def test_replies_delayed_by_a_fault_are_not_waited_for_on_the_simulated_clock() -> None:
    plant = StaticPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0))
    cfg = _no_time_to_answer()
    with SimulatedHardware(cfg, plant) as twin, HardwareRobot(twin.host_config, await_replies=twin.await_replies) as host:
        host.configure()
        twin.faults["can0"].delay_reply_s = 0.5  # far longer than the other buses take to answer
        host.cycle()
        twin.faults["can0"].delay_reply_s = 0.0
        missed = {name: host.feedback(name).missed for name in g1.JOINT_NAMES}
        assert missed == {name: int(joint.bus == "can0") for name, joint in cfg.joints.items()}  # can0's late, the rest on time
