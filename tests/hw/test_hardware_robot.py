"""Lifecycle and fault drills of the hardware robot against simulated hardware, byte for byte.

Each drill ends in damping on every joint with the fault named, and the commands the
motors receive never leave the joint map's limits.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager

import can
import numpy as np
import pytest

from hw import g1
from hw.emulation.faults import FaultPlan
from hw.emulation.imu_model import ImuModelConfig
from hw.emulation.rig import SimulatedHardware
from hw.errors import BusError, HardwareFault, LifecycleError, MotorNotFoundError
from hw.hardware_robot import HardwareRobot, Lifecycle
from hw.jointmap import BusConfig, HardwareConfig, load_hardware_config, load_motor_models
from hw.types import JointCommand
from sim.hardware_twin import MuJoCoPlant
from sim.robot import SimRobot

N = g1.NUM_JOINTS


class RecordingPlant(MuJoCoPlant):
    """Records every PD law the emulated motors apply (joint side)."""

    def __init__(self, robot: SimRobot) -> None:
        super().__init__(robot)
        self.applied: list[tuple[str, float, float, float]] = []

    def set_joint_command(self, joint: str, q: float, dq: float, kp: float, kd: float, tau: float) -> None:
        self.applied.append((joint, q, kp, kd))
        super().set_joint_command(joint, q, dq, kp, kd, tau)


def fast_config(name: str) -> HardwareConfig:
    cfg = load_hardware_config(name)
    return dataclasses.replace(cfg, safety=dataclasses.replace(cfg.safety, soft_start_time=0.02, cycle_timeout=0.02))


@contextmanager
def rig(g1_model, name: str = "sim-can", host_cfg=None) -> Iterator[tuple[HardwareRobot, SimulatedHardware, RecordingPlant]]:
    plant = RecordingPlant(SimRobot(g1_model))
    cfg = fast_config(name)
    with SimulatedHardware(cfg, plant) as twin:
        host = HardwareRobot(host_cfg(twin.host_config) if host_cfg else twin.host_config, stamp_clock=plant.time)
        try:
            yield host, twin, plant
        finally:
            host.close()
            plant.robot.close()


def run_cycles(host: HardwareRobot, twin: SimulatedHardware, n: int) -> None:
    for _ in range(n):
        host.cycle()
        twin.step()


def activate(host: HardwareRobot, twin: SimulatedHardware) -> None:
    host.configure()
    twin.step()
    host.activate()
    while host.state is Lifecycle.ACTIVATING:
        run_cycles(host, twin, 1)
    assert host.state is Lifecycle.ACTIVE


def assert_damped(plant: RecordingPlant, host: HardwareRobot, limp: tuple[str, ...] = ()) -> None:
    """Every joint damped, except motors whose own firmware went limp on a latched error."""
    last = {joint: (kp, kd) for joint, _, kp, kd in plant.applied}
    assert len(last) == N
    for joint in limp:
        assert last.pop(joint) == (0.0, 0.0)
    for joint, (kp, kd) in last.items():
        assert kp == pytest.approx(0.0, abs=1e-9), joint
        assert kd == pytest.approx(host.cfg.safety.damping_kd, rel=0.02), joint


def assert_within_limits(plant: RecordingPlant, host: HardwareRobot) -> None:
    for joint, q, kp, _ in plant.applied:
        if kp > 0:
            lo, hi = host.cfg.joints[joint].position_limits
            assert lo - 1e-3 <= q <= hi + 1e-3, (joint, q)


@pytest.mark.parametrize("name", ["sim-can", "sim-mixed"])
def test_lifecycle_soft_start_reaches_default_pose(g1_model, name: str) -> None:
    with rig(g1_model, name) as (host, twin, plant):
        with pytest.raises(LifecycleError):
            host.activate()
        activate(host, twin)
        run_cycles(host, twin, 5)
        assert np.abs(host.read().joint_pos - host.default_pose).max() < 0.1
        counters = host.counters()
        assert counters.frames_received > 0 and counters.crc_errors == 0
        host.deactivate()
        assert host.state is Lifecycle.INACTIVE
        assert_within_limits(plant, host)


def test_reply_drop_drill(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        twin.faults["can0"].drop_reply_prob = 1.0
        run_cycles(host, twin, 30)
        assert host.state is Lifecycle.ERROR
        assert any("left_hip_pitch_joint" in f and ("missed" in f or "watchdog" in f) for f in host.faults)
        assert host.counters().dropped >= 5
        twin.faults["can0"].drop_reply_prob = 0.0
        run_cycles(host, twin, 3)
        assert_damped(plant, host)


def test_bus_off_drill(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        twin.faults["can1"].bus_off = True
        run_cycles(host, twin, 5)
        assert host.state is Lifecycle.ERROR
        assert any("can1" in f and "bus-off" in f for f in host.faults)
        assert host.counters().error_frames >= 1
        twin.faults["can1"].bus_off = False
        run_cycles(host, twin, 3)
        assert_damped(plant, host)


def test_over_temperature_drill(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        knee_id = host.cfg.joints["left_knee_joint"].id
        twin.faults["can0"].over_temperature = {knee_id}
        run_cycles(host, twin, 3)
        assert host.state is Lifecycle.ERROR
        assert any("left_knee_joint" in f and "temperature" in f for f in host.faults)
        twin.faults["can0"].over_temperature = set()
        run_cycles(host, twin, 3)
        assert_damped(plant, host, limp=("left_knee_joint",))
        with pytest.raises(HardwareFault, match="left_knee_joint"):
            host.rearm()  # the motor still reports hot: no re-arm


def test_stale_imu_drill(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        twin.faults["imu"].silent = True
        run_cycles(host, twin, 40)
        assert host.state is Lifecycle.ERROR
        assert any("IMU stale" in f for f in host.faults)
        run_cycles(host, twin, 2)
        assert_damped(plant, host)
        twin.faults["imu"].silent = False
        run_cycles(host, twin, 2)
        host.rearm()
        assert host.state is Lifecycle.INACTIVE


def test_nan_target_drill(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        bad = JointCommand(q=np.full(N, np.nan), dq=np.zeros(N), kp=np.full(N, 40.0), kd=np.ones(N), tau_ff=np.zeros(N))
        host.write(bad)
        run_cycles(host, twin, 2)
        assert host.state is Lifecycle.ERROR and "non-finite" in host.faults[0]
        assert_damped(plant, host)
        assert all(np.isfinite(q) for _, q, _, _ in plant.applied)


def test_out_of_limit_commands_are_clamped_and_step_limited(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        start = len(plant.applied)
        wild = JointCommand(q=np.full(N, 10.0), dq=np.full(N, 1e3), kp=np.full(N, 40.0), kd=np.ones(N), tau_ff=np.full(N, 1e4))
        host.write(wild)
        run_cycles(host, twin, 1)
        knee = [q for joint, q, kp, _ in plant.applied[start:] if joint == "left_knee_joint" and kp > 0]
        assert knee and knee[-1] <= g1.DEFAULT_JOINT_POS["left_knee_joint"] + host.cfg.safety.max_position_step + 1e-3
        run_cycles(host, twin, 30)
        assert_within_limits(plant, host)
        assert host.clamped_values > 0


def test_rs485_crc_errors_are_counted_then_fault(g1_model) -> None:
    with rig(g1_model, "sim-mixed") as (host, twin, plant):
        activate(host, twin)
        twin.faults["rs485_left"].corrupt_prob = 1.0
        run_cycles(host, twin, 10)
        assert host.counters().crc_errors >= 6
        assert host.state is Lifecycle.ERROR
        assert any("left_" in f for f in host.faults)
        twin.faults["rs485_left"].corrupt_prob = 0.0
        run_cycles(host, twin, 2)
        assert_damped(plant, host)


def test_motor_error_code_is_decoded_and_named(g1_model) -> None:
    with rig(g1_model, "sim-mixed") as (host, twin, _plant):
        activate(host, twin)
        twin.faults["rs485_right"].error_codes = {host.cfg.joints["right_knee_joint"].id: 4}
        run_cycles(host, twin, 2)
        assert host.state is Lifecycle.ERROR
        assert any("right_knee_joint" in f and "encoder fault" in f for f in host.faults)


def test_missing_motor_is_named_at_configure(g1_model) -> None:
    def wrong_id(cfg: HardwareConfig) -> HardwareConfig:
        joints = dict(cfg.joints)
        joints["left_knee_joint"] = dataclasses.replace(joints["left_knee_joint"], id=44)
        return dataclasses.replace(cfg, joints=joints)

    with rig(g1_model, host_cfg=wrong_id) as (host, _twin, _plant):
        with pytest.raises(MotorNotFoundError, match=r"left_knee_joint \(bus can0, id 44\)"):
            host.configure()
        assert host.state is Lifecycle.UNCONFIGURED


def test_unknown_id_and_wrong_length_frames_are_counted(g1_model) -> None:
    with rig(g1_model) as (host, twin, _plant):
        activate(host, twin)
        intruder = can.Bus(interface="virtual", channel=twin.host_config.buses["can3"].channel)
        intruder.send(can.Message(arbitration_id=0x63, data=bytes([0x63, 0, 0, 0, 0, 0, 0, 0]), is_extended_id=False))
        intruder.send(can.Message(arbitration_id=0x01, data=bytes(3), is_extended_id=False))
        run_cycles(host, twin, 1)
        intruder.shutdown()
        counters = host.counters()
        assert counters.unknown_ids == 1 and counters.bad_frames == 1
        assert host.state is Lifecycle.ACTIVE  # counted, the loop goes on


def test_bus_that_does_not_open_is_named() -> None:
    cfg = load_hardware_config("sim-mixed")
    buses = dict(cfg.buses)
    buses["rs485_left"] = BusConfig(kind="serial", port="/dev/ttyG1-missing")
    host = HardwareRobot(dataclasses.replace(cfg, buses=buses))
    with pytest.raises(BusError, match=r"serial port 'rs485_left' \(/dev/ttyG1-missing\)"):
        host.configure()
    host.close()
    host.close()


def test_unknown_can_interface_is_named() -> None:
    cfg = load_hardware_config("sim-can")
    buses = dict(cfg.buses)
    buses["can0"] = BusConfig(kind="can", interface="nosuchcan", channel="x")
    host = HardwareRobot(dataclasses.replace(cfg, buses=buses))
    with pytest.raises(BusError, match=r"CAN bus 'can0' \(nosuchcan:x\)"):
        host.configure()
    host.close()


def test_faults_from_a_fault_plan_are_seeded() -> None:
    a, b = FaultPlan(drop_reply_prob=0.5, seed=3), FaultPlan(drop_reply_prob=0.5, seed=3)
    assert [a.drop() for _ in range(20)] == [b.drop() for _ in range(20)]


def test_stuck_motor_aborts_a_sweep_on_unexpected_torque(g1_model) -> None:
    from hw.bus_bench import BusBenchRobot

    with rig(g1_model) as (host, twin, _plant):
        host.configure()
        twin.step()
        elbow = host.cfg.joints["left_elbow_joint"]
        twin.faults["can2"].stuck = {elbow.id}

        def pump() -> None:
            host.cycle()
            twin.step()

        result = BusBenchRobot(host, pump, "sim-can").sweep("left_elbow_joint", fraction=0.3, speed=1.0)
        assert not result.completed and ("not following" in result.reason or "unexpected torque" in result.reason)
        assert host.state is Lifecycle.INACTIVE  # the sweep ends deactivated: damped, then disabled


def test_a_robot_activated_again_after_deactivate_enables_its_motors(g1_model) -> None:
    """deactivate takes the MIT motors out of motor mode: activating again enables them first, or they would stay limp
    under every command (a bench script sweeps joint after joint, a stopped sweep deactivates)."""
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        host.deactivate()
        twin.step()
        host.activate()
        while host.state is Lifecycle.ACTIVATING:
            run_cycles(host, twin, 1)
        start = len(plant.applied)
        run_cycles(host, twin, 5)
        holding = {joint: kp for joint, _, kp, _ in plant.applied[start:]}
        assert len(holding) == N and min(holding.values()) > 0, holding


def test_rewritten_command_after_rearm_is_step_limited_again(g1_model) -> None:
    with rig(g1_model) as (host, twin, plant):
        activate(host, twin)
        far = host.default_pose.copy()
        knee = g1.JOINT_NAMES.index("left_knee_joint")
        far[knee] += 1.0
        cmd = JointCommand(q=far, dq=np.zeros(N), kp=np.full(N, 40.0), kd=np.ones(N), tau_ff=np.zeros(N))
        host.write(cmd)
        run_cycles(host, twin, 10)  # reaches the target in 0.3 rad steps, then the command is reused as is
        host.enter_damping("drill")
        run_cycles(host, twin, 50)
        host.rearm()
        host.activate()
        while host.state is Lifecycle.ACTIVATING:
            run_cycles(host, twin, 1)
        start = len(plant.applied)
        host.write(cmd)  # the very same object as before the fault
        run_cycles(host, twin, 1)
        sent = [q for joint, q, kp, _ in plant.applied[start:] if joint == "left_knee_joint" and kp > 0]
        assert sent and abs(sent[-1] - host.default_pose[knee]) <= host.cfg.safety.max_position_step + 0.02


def test_a_host_with_a_wrong_joint_map_is_caught_on_the_wire(g1_model) -> None:
    """The host believes the knee goes to 10 rad; the motors' joint map says 2.88: the audit sees the difference."""

    def loose_knee(cfg: HardwareConfig) -> HardwareConfig:
        joints = dict(cfg.joints)
        joints["left_knee_joint"] = dataclasses.replace(joints["left_knee_joint"], position_limits=(-0.1, 10.0))
        return dataclasses.replace(cfg, joints=joints)

    with rig(g1_model, host_cfg=loose_knee) as (host, twin, _plant):
        activate(host, twin)
        n, knee = g1.NUM_JOINTS, g1.JOINT_NAMES.index("left_knee_joint")
        q = host.default_pose.copy()
        q[knee] = 3.5
        host.write(JointCommand(q=q, dq=np.zeros(n), kp=np.full(n, 40.0), kd=np.ones(n), tau_ff=np.zeros(n)))
        run_cycles(host, twin, 10)  # 0.3 rad a cycle: the knee target passes 2.88 rad on the way
        report = twin.audit.report()
        assert report["outside_limits"] >= 1 and {v["joint"] for v in report["outside_examples"]} == {"left_knee_joint"}
        assert report["commands"] >= 29 * 10


def test_the_host_reads_every_joint_and_the_imu_as_the_plant_was_one_physics_step_before(g1_model) -> None:
    """What a real bus gives: an MIT motor answers a command with the state at the exchange, so the host's read after a
    cycle is the plant before that cycle's physics step, joints and IMU from the same instant; off only by the codec's
    rounding (half a code step; the IMU noise-free here). An estimator must take its input as that old (issue 21)."""
    cfg = fast_config("sim-can")
    cfg = dataclasses.replace(cfg, imu_model=ImuModelConfig(accel_noise=0.0, gyro_noise=0.0))
    models = load_motor_models()
    ranges = [models[cfg.joints[name].model] for name in g1.JOINT_NAMES]
    gear = np.array([cfg.joints[name].gear_ratio for name in g1.JOINT_NAMES])
    half_step = {  # joint side, per joint: position 16 bits, velocity and torque 12 bits over the model's range
        "joint_pos": np.array([r.p_max for r in ranges]) / 65535 / gear + 1e-9,
        "joint_vel": np.array([r.v_max for r in ranges]) / 4095 / gear + 1e-9,
        "joint_tau": np.array([r.t_max for r in ranges]) / 4095 * gear + 1e-9,
    }
    plant = MuJoCoPlant(SimRobot(g1_model))
    with SimulatedHardware(cfg, plant) as twin:
        host = HardwareRobot(twin.host_config, stamp_clock=plant.time, await_replies=twin.await_replies)
        try:
            activate(host, twin)
            n, legs = g1.NUM_JOINTS, slice(0, 12)
            moved = 0.0
            for k in range(40):  # the legs swing at 4 Hz: joints accelerating, so one step of age shows
                q = host.default_pose.copy()
                q[legs] += 0.3 * np.sin(2 * np.pi * 4.0 * 0.002 * k)
                host.write(JointCommand(q=q, dq=np.zeros(n), kp=np.full(n, 100.0), kd=np.full(n, 2.0), tau_ff=np.zeros(n)))
                before = plant.robot.read()  # the plant as the motors sample it for this cycle's replies
                host.cycle()
                twin.step()
                read, now = host.read(), plant.robot.read()
                for field, tolerance in half_step.items():
                    assert (np.abs(getattr(read, field) - getattr(before, field)) <= tolerance).all(), (k, field)
                np.testing.assert_allclose(read.base_quat, before.base_quat, atol=1e-6)
                np.testing.assert_allclose(read.base_ang_vel, before.base_ang_vel, atol=1e-5)
                np.testing.assert_allclose(read.imu_accel, before.imu_accel, rtol=1e-6, atol=1e-5)
                moved = max(moved, float(np.abs(now.joint_vel - before.joint_vel).max()))
            assert moved > 20 * half_step["joint_vel"].max()  # the plant moved on meanwhile: the read is not the plant now
        finally:
            host.close()
            plant.robot.close()
