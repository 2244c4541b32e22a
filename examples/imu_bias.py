"""Log the IMU while the robot stands still and print its bias: the mean gyro, and the mean accelerometer less gravity.

    python examples/imu_bias.py --hardware sim-can --seconds 10 --csv imu.csv

Listens only: nothing is commanded. Gravity is taken out in each sample's own orientation, so the
robot may stand tilted, but it must stand still. Exit status 0 with a bias printed, 1 when the IMU
sent nothing, 2 when the robot could not be opened.
"""

from __future__ import annotations

import argparse
import csv
import sys

import numpy as np

from controller.runtime.bench_robot import open_robot
from hw.errors import G1Error, HardwareFault


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hardware", required=True, help="hardware config: a shipped name (sim-can, g1-dds, ...) or a path")
    parser.add_argument("--seconds", type=float, default=10.0, help="how long to log")
    parser.add_argument("--csv", default=None, help="write every sample here (time, quaternion w x y z, gyro, accel)")
    args = parser.parse_args()
    try:
        with open_robot(args.hardware) as robot:
            samples = robot.imu_samples(args.seconds)
    except HardwareFault as exc:  # the IMU (or the robot) sent nothing
        print(f"imu_bias: {exc}", file=sys.stderr)
        return 1
    except G1Error as exc:
        print(f"imu_bias: {exc}", file=sys.stderr)
        return 2
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["time", "qw", "qx", "qy", "qz", "gx", "gy", "gz", "ax", "ay", "az"])
            writer.writerows([s.time, *s.quaternion_wxyz, *s.gyro, *s.accel] for s in samples)
    gyro_bias = np.mean([s.gyro for s in samples], axis=0)
    accel_bias = np.mean([np.subtract(s.accel, s.gravity()) for s in samples], axis=0)
    span = samples[-1].time - samples[0].time
    print(f"{len(samples)} samples over {span:.2f} s ({len(samples) / max(span, 1e-9):.0f} Hz)")
    print("gyro bias  (rad/s): " + " ".join(f"{v:+.5f}" for v in gyro_bias))
    print("accel bias (m/s^2): " + " ".join(f"{v:+.4f}" for v in accel_bias))
    return 0


if __name__ == "__main__":
    sys.exit(main())
