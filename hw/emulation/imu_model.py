"""What a simulated IMU measures: the plant's perfect reading with a real MEMS IMU's noise and bias.

One model for both emulated IMUs (the serial IMU of simulated buses, the simulated G1's
`LowState_.imu_state`):

- gyroscope = true rate + bias + white noise (rad/s, IMU frame);
- accelerometer = true specific force (gravity included) + bias + white noise (m/s^2, IMU frame);
- attitude: what the IMU's own attitude filter outputs. Roll and pitch stay gravity-referenced
  (the true ones): the filter levels itself on the accelerometer's gravity. Heading has no such
  reference (no magnetometer: the G1's `LowState_` carries none), so it is the gyro's integral
  and drifts by the integrated gyro error about the vertical: a z bias b turns the heading by b
  rad/s on a level IMU.

The default noise is the Bosch BMI088's, a 6-axis MEMS IMU of the class in legged robots and
their bench rigs (Unitree does not name the G1's part; BMI088 data sheet BST-BMI088-DS001: gyroscope noise density 0.014 deg/s/sqrt(Hz),
accelerometer 175 ug/sqrt(Hz)), times the square root of a 250 Hz noise bandwidth (the Nyquist
band of the 500 Hz stream the host reads): 0.0039 rad/s and 0.027 m/s^2 per sample. Biases default
to zero: a robot calibrates its IMU's turn-on bias out at start-up (at rest), and a heading target
in degrees per minute would otherwise judge an arbitrary pick of ours; a bias is a fault to drill
(`gyro_bias`/`accel_bias` in a fault plan, `imu-bias` on the simulated G1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

Vec3 = tuple[float, float, float]
Reading = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]  # quaternion (w, x, y, z), gyro, accel

NOISE_BANDWIDTH_HZ = 250.0
GYRO_NOISE_RADPS = math.radians(0.014) * math.sqrt(NOISE_BANDWIDTH_HZ)  # 0.0039 rad/s
ACCEL_NOISE_MPS2 = 175e-6 * 9.80665 * math.sqrt(NOISE_BANDWIDTH_HZ)  # 0.027 m/s^2
ZERO: Vec3 = (0.0, 0.0, 0.0)
NOISE_BLOCK = 1024


@dataclass(frozen=True)
class ImuModelConfig:
    """A simulated IMU's errors (hardware YAML `imu_model:`, only where `simulated: true`); all zero: a perfect IMU."""

    accel_noise: float = round(ACCEL_NOISE_MPS2, 4)  # m/s^2, standard deviation of each sample, per axis
    gyro_noise: float = round(GYRO_NOISE_RADPS, 5)  # rad/s, standard deviation of each sample, per axis
    accel_bias: Vec3 = ZERO  # m/s^2, IMU frame
    gyro_bias: Vec3 = ZERO  # rad/s, IMU frame
    seed: int = 0  # with the run's seed: the noise of one run, the same every time

    def __post_init__(self) -> None:
        values = (self.accel_noise, self.gyro_noise, *self.accel_bias, *self.gyro_bias)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"noise and biases must be finite numbers, got {values}")
        if self.accel_noise < 0 or self.gyro_noise < 0:
            raise ValueError(f"accel_noise and gyro_noise are standard deviations (>= 0), got {self.accel_noise} and {self.gyro_noise}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")


@dataclass(frozen=True)
class ImuBias:
    """Bias a fault adds on top of the configured one (IMU frame)."""

    gyro: Vec3 = ZERO  # rad/s
    accel: Vec3 = ZERO  # m/s^2


NO_FAULT = ImuBias()


class ImuModel:
    """One simulated IMU: `measure` turns each perfect reading into the measured one (call it once per sample, in time order)."""

    def __init__(self, cfg: ImuModelConfig, run_seed: int = 0) -> None:
        self.cfg = cfg
        self._rng = np.random.default_rng([cfg.seed, run_seed % 2**63])
        self._scale = np.repeat([cfg.gyro_noise, cfg.accel_noise], 3)
        self._noise: list[list[float]] = []  # drawn NOISE_BLOCK samples at a time: one draw per sample costs more than the rest
        self.heading_error = 0.0  # rad: the attitude filter's heading minus the true heading
        self._last_time: float | None = None

    def measure(self, reading: Reading, now: float, fault: ImuBias = NO_FAULT) -> Reading:
        """The sample the IMU reports at plant time `now` for the true `reading`; `fault`: bias added by a fault in force."""
        quaternion, gyro, accel = reading
        if not self._noise:
            self._noise = (self._rng.standard_normal((NOISE_BLOCK, 6)) * self._scale).tolist()[::-1]
        noise = self._noise.pop()
        cfg = self.cfg
        gyro_error = [cfg.gyro_bias[i] + fault.gyro[i] + noise[i] for i in range(3)]
        accel_error = [cfg.accel_bias[i] + fault.accel[i] + noise[3 + i] for i in range(3)]
        dt = 0.0 if self._last_time is None else max(now - self._last_time, 0.0)
        self._last_time = now
        self.heading_error += dt * vertical_component(quaternion, gyro_error)
        measured = turned_about_vertical(quaternion, self.heading_error)
        return (
            measured,
            tuple(g + e for g, e in zip(gyro, gyro_error, strict=True)),
            tuple(a + e for a, e in zip(accel, accel_error, strict=True)),
        )


def vertical_component(quaternion: tuple[float, ...], v: list[float]) -> float:
    """The world-z component of the IMU-frame vector `v` (the third row of the rotation matrix, times v)."""
    w, x, y, z = quaternion
    return 2 * (x * z - w * y) * v[0] + 2 * (y * z + w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2]


def turned_about_vertical(quaternion: tuple[float, ...], angle: float) -> tuple[float, float, float, float]:
    """The attitude `quaternion` (w, x, y, z) turned by `angle` (rad) about the world vertical: (cos a/2, 0, 0, sin a/2) * q."""
    w, x, y, z = quaternion
    c, s = math.cos(0.5 * angle), math.sin(0.5 * angle)
    return c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w
