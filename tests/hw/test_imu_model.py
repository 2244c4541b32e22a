"""The simulated IMUs measure as a real one: noise and bias as configured, a heading that drifts by the gyro's z bias,
the configs that state it checked line by line, and the bias fault of the serial IMU from its start time on."""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest

from hw import g1, quat
from hw.emulation.faults import FaultFile, FaultSpec, load_fault_file, load_faults
from hw.emulation.g1_faults import IMU_BIAS_DRILL, RobotFault, active, imu_fault
from hw.emulation.g1_lowlevel import G1LowLevel, roll_pitch_yaw
from hw.emulation.imu_model import ACCEL_NOISE_MPS2, GYRO_NOISE_RADPS, NO_FAULT, ImuBias, ImuModel, ImuModelConfig, Reading
from hw.emulation.plant import StaticPlant
from hw.emulation.rig import SimulatedHardware
from hw.errors import ConfigError
from hw.jointmap import load_hardware_config, load_robot_config
from hw.protocols import imu as imu_frame
from hw.protocols.unitree_rs485 import FrameSplitter
from hw.shipped import config_dir

DT = 0.002  # the 500 Hz the emulators sample at
TILTED = tuple(quat.normalize([0.95, 0.2, -0.1, 0.3]).tolist())  # rolled, pitched and turned
GRAVITY_UP = (0.0, 0.0, 9.81)


def still(quaternion: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0)) -> Reading:
    """What a perfect IMU at rest reads in this attitude: no rate, gravity's reaction in the IMU frame."""
    return quaternion, (0.0, 0.0, 0.0), tuple(quat.rotate(quat.conjugate(quaternion), GRAVITY_UP).tolist())


def samples(model: ImuModel, reading: Reading, n: int, fault: ImuBias = NO_FAULT) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    out = [model.measure(reading, i * DT, fault) for i in range(n)]
    return tuple(np.array([o[k] for o in out]) for k in range(3))  # type: ignore[return-value]


def test_the_defaults_are_the_bmi088s_noise_over_the_streams_band() -> None:
    cfg = ImuModelConfig()
    assert cfg.gyro_noise == pytest.approx(GYRO_NOISE_RADPS, rel=3e-3) == pytest.approx(0.00386, abs=1e-5)
    assert cfg.accel_noise == pytest.approx(ACCEL_NOISE_MPS2, rel=3e-3) == pytest.approx(0.0271, abs=1e-4)
    assert cfg.gyro_bias == cfg.accel_bias == (0.0, 0.0, 0.0)


def test_samples_carry_the_configured_bias_and_noise() -> None:
    cfg = ImuModelConfig(accel_noise=0.05, gyro_noise=0.004, accel_bias=(0.1, -0.2, 0.3), gyro_bias=(0.01, -0.02, 0.0), seed=3)
    n = 20_000
    reading = still(TILTED)
    _, gyro, accel = samples(ImuModel(cfg, run_seed=11), reading, n)
    for measured, truth, bias, sigma in (
        (gyro, reading[1], cfg.gyro_bias, cfg.gyro_noise),
        (accel, reading[2], cfg.accel_bias, cfg.accel_noise),
    ):
        np.testing.assert_allclose(measured.mean(axis=0), np.add(truth, bias), atol=5 * sigma / math.sqrt(n))
        np.testing.assert_allclose(measured.std(axis=0), sigma, rtol=0.03)
    assert abs(np.corrcoef(gyro[:, 0], gyro[:, 1])[0, 1]) < 0.03  # independent axes


def test_the_same_seeds_give_the_same_noise_and_the_run_seed_changes_it() -> None:
    cfg = ImuModelConfig()
    first, again, other = (samples(ImuModel(cfg, seed), still(), 50)[2] for seed in (1, 1, 2))
    assert np.array_equal(first, again) and not np.array_equal(first, other)
    assert np.array_equal(samples(ImuModel(ImuModelConfig(0, 0), 5), still(), 3)[2], np.tile(GRAVITY_UP, (3, 1)))  # all zero: perfect


def test_roll_and_pitch_stay_true_and_the_heading_drifts_by_the_gyro_z_bias() -> None:
    """An attitude filter without magnetometer: levelled by gravity, its heading the gyro's integral (noise on)."""
    cfg = ImuModelConfig(gyro_bias=(0.0, 0.0, 0.01))
    model = ImuModel(cfg)
    level = still()
    minute = round(60.0 / DT)
    quaternions, _, _ = samples(model, level, minute + 1)
    heading_deg_per_min = math.degrees(roll_pitch_yaw(tuple(quaternions[-1]))[2])
    assert heading_deg_per_min == pytest.approx(math.degrees(0.01 * 60.0), abs=0.1)  # 34.4 deg/min; the noise's walk: 0.01 deg
    tilted = ImuModel(dataclasses.replace(cfg, gyro_noise=0.0))
    measured = [tilted.measure(still(TILTED), i * DT)[0] for i in range(501)][-1]
    (roll, pitch, yaw), (true_roll, true_pitch, true_yaw) = roll_pitch_yaw(measured), roll_pitch_yaw(TILTED)
    assert (roll, pitch) == pytest.approx((true_roll, true_pitch), abs=1e-9)
    vertical = quat.rotate(TILTED, (0.0, 0.0, 0.01))[2]  # a tilted IMU's z axis turns the heading less
    assert yaw - true_yaw == pytest.approx(vertical * 1.0, rel=1e-9) and vertical < 0.01
    assert np.allclose(quat.rotate(quat.conjugate(measured), GRAVITY_UP), still(TILTED)[2])  # gravity where it truly is


def test_a_faults_bias_adds_to_the_configured_one() -> None:
    model = ImuModel(ImuModelConfig(accel_noise=0.0, gyro_noise=0.0, gyro_bias=(0.001, 0.0, 0.0)))
    _, gyro, accel = model.measure(still(), 0.0, IMU_BIAS_DRILL)
    assert gyro == pytest.approx(np.add(IMU_BIAS_DRILL.gyro, (0.001, 0.0, 0.0)))
    assert accel == pytest.approx(np.add(GRAVITY_UP, IMU_BIAS_DRILL.accel))
    assert imu_fault(active((RobotFault.parse("imu-bias@3"),), 2.9)) == ImuBias()
    assert imu_fault(active((RobotFault.parse("imu-bias@3"),), 3.0)) == IMU_BIAS_DRILL


def test_the_simulated_g1s_low_state_carries_the_model_and_the_bias_fault() -> None:
    plant = StaticPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0), clock=lambda: 0.0)
    lowlevel = G1LowLevel(plant, imu=ImuModel(load_robot_config("sim-dds").imu_model or ImuModelConfig()))
    accel = np.array([lowlevel.low_state()["imu_state"]["accelerometer"] for _ in range(2000)])
    assert accel.mean(axis=0) == pytest.approx(GRAVITY_UP, abs=0.005) and accel.std(axis=0) == pytest.approx(0.0271, rel=0.1)
    biased = np.array([lowlevel.low_state(imu_fault=IMU_BIAS_DRILL)["imu_state"]["gyroscope"] for _ in range(2000)])
    assert biased.mean(axis=0) == pytest.approx(IMU_BIAS_DRILL.gyro, abs=0.001)


YAML_MISTAKES = [
    ("imu_model: {accel_noise: -0.1}", "imu_model: accel_noise and gyro_noise are standard deviations (>= 0), got -0.1 and"),
    ("imu_model: {gyro_bias: [0.0, 0.01]}", "imu_model.gyro_bias: expected 3 values, got 2"),
    ("imu_model: {accel_bias: [0.0, .nan, 0.0]}", "imu_model: noise and biases must be finite numbers"),
    ("imu_model: {noise: 0.1}", "unknown key 'imu_model.noise' (valid keys: accel_bias, accel_noise, gyro_bias, gyro_noise, seed)"),
    ("imu_model: {gyro_noise: fast}", "imu_model.gyro_noise: expected a number, got 'fast'"),
    ("imu_model: {seed: -1}", "imu_model: seed must be >= 0, got -1"),
]


def _with_line(tmp_path: Path, name: str, line: str, drop: str = "imu_model:") -> Path:
    """A shipped config with its own imu_model line (if any) replaced by `line`."""
    kept = [row for row in config_dir("hardware", f"{name}.yaml").read_text().splitlines() if not row.startswith(drop)]
    path = tmp_path / f"{name}-variant.yaml"
    path.write_text("\n".join([*kept, line, ""]))
    return path


@pytest.mark.parametrize("name", ["sim-can", "sim-dds"])
@pytest.mark.parametrize(("line", "message"), YAML_MISTAKES)
def test_imu_model_mistakes_are_one_line_naming_the_key(tmp_path: Path, name: str, line: str, message: str) -> None:
    path = _with_line(tmp_path, name, line)
    with pytest.raises(ConfigError, match=re.escape(str(path)) + ": .*" + re.escape(message)) as caught:
        load_robot_config(str(path))
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("name", ["g1-dds", "sim-can"])
def test_a_real_robots_config_refuses_an_imu_model(tmp_path: Path, name: str) -> None:
    path = _with_line(tmp_path, name, "imu_model: {gyro_noise: 0.01}")
    if name == "sim-can":  # the same config made real
        path.write_text(path.read_text().replace("simulated: true", "simulated: false"))
    with pytest.raises(ConfigError, match=r"imu_model: only a simulated robot's IMU is modelled \('simulated: true'\)"):
        load_robot_config(str(path))


def test_a_config_without_an_imu_has_no_imu_to_model(tmp_path: Path) -> None:
    path = _with_line(tmp_path, "sim-can", "imu_model: {gyro_noise: 0.01}", drop="imu")
    path.write_text(path.read_text().replace("  imu: {kind: serial, port: 'sim://pty', baudrate: 921600}\n", ""))
    with pytest.raises(ConfigError, match="imu_model: this config has no IMU to model"):
        load_robot_config(str(path))


def test_an_imu_bias_belongs_on_the_imus_bus() -> None:
    plan = FaultFile(buses={"can0": FaultSpec(gyro_bias=(0.0, 0.0, 0.01))})
    with pytest.raises(ConfigError, match=r"p: buses\.can0: gyro_bias and accel_bias are faults of the IMU; the IMU is on bus 'imu'"):
        load_faults(plan, "p", ["can0", "imu"], "imu")
    with pytest.raises(ValueError, match="gyro_bias and accel_bias must be finite"):
        FaultSpec(accel_bias=(0.0, math.inf, 0.0))
    shipped = load_fault_file("imu-bias").buses["imu"]
    assert (shipped.gyro_bias, shipped.accel_bias) == (IMU_BIAS_DRILL.gyro, IMU_BIAS_DRILL.accel)  # the same drill on both transports


class _Frames:
    """The host's end of the simulated IMU's port, read after every step (a real UART's buffer would overflow otherwise)."""

    def __init__(self, port: str) -> None:
        self.fd = os.open(port, os.O_RDONLY | os.O_NONBLOCK)
        self.splitter = FrameSplitter(imu_frame.HEADER, imu_frame.SIZE)

    def read(self) -> list[imu_frame.ImuSample]:
        try:
            data = os.read(self.fd, 4096)
        except BlockingIOError:
            return []
        return [imu_frame.decode_imu(f) for f in self.splitter.feed(data)]

    def close(self) -> None:
        os.close(self.fd)


def _serial_imu_samples(bias_at_s: float, steps: int) -> tuple[list[float], list[imu_frame.ImuSample]]:
    """sim-can's serial IMU over a still robot, with the drill's bias from `bias_at_s` on: the times and the frames."""
    clock = [0.0]
    plant = StaticPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0), clock=lambda: clock[0])
    spec = load_fault_file("imu-bias").buses["imu"]
    faults = load_faults(FaultFile(buses={"imu": dataclasses.replace(spec, start_s=bias_at_s)}), "drill", ["imu"], "imu")
    times, frames = [], []
    with SimulatedHardware(load_hardware_config("sim-can"), plant, faults, seed=4) as twin:
        reader = _Frames(twin.host_config.buses["imu"].port)
        try:
            for _ in range(steps):
                twin.step()
                got = reader.read()
                times += [clock[0]] * len(got)
                frames += got
                clock[0] += DT
        finally:
            reader.close()
    return times, frames


def test_sim_cans_imu_frames_are_noisy_about_gravity_and_take_the_bias_from_its_start() -> None:
    times, frames = _serial_imu_samples(bias_at_s=1.0, steps=1000)
    assert len(frames) == 1000  # one frame per step, none lost
    t = np.array(times)
    accel = np.array([f.linear_acceleration for f in frames])
    gyro = np.array([f.angular_velocity for f in frames])
    before, after = t < 1.0, t >= 1.0
    assert accel[before].mean(axis=0) == pytest.approx(GRAVITY_UP, abs=0.006)  # +9.81 up, 500 samples
    assert accel[before].std(axis=0) == pytest.approx(0.0271, rel=0.15)  # sim-can's imu_model
    assert gyro[before].mean(axis=0) == pytest.approx((0.0, 0.0, 0.0), abs=0.001)
    assert accel[after].mean(axis=0) == pytest.approx(np.add(GRAVITY_UP, IMU_BIAS_DRILL.accel), abs=0.006)
    assert gyro[after].mean(axis=0) == pytest.approx(IMU_BIAS_DRILL.gyro, abs=0.001)
    heading = math.degrees(roll_pitch_yaw(frames[-1].quaternion)[2])
    assert heading == pytest.approx(math.degrees(0.01 * (times[-1] - 1.0)), abs=0.05)  # drifting since the bias struck
