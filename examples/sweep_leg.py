"""Sweep every joint of one leg in turn and check that each reached both ends of its range.

    python examples/sweep_leg.py --hardware sim-can --leg left

The robot must hang free (a gantry: a simulated robot hangs in one). Each joint moves slowly, with
half its stiffness, through a share of its range around where it is and back; every other joint
holds. Exit status 0 when every joint reached its range, 1 otherwise, 2 when the robot could not
be opened or refused the sweep. On any exit the robot ends damped.
"""

from __future__ import annotations

import argparse
import sys

from controller.runtime.bench_robot import open_robot
from hw.errors import G1Error
from hw.g1 import LEFT_LEG_JOINTS, RIGHT_LEG_JOINTS


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hardware", required=True, help="hardware config: a shipped name (sim-can, g1-dds, ...) or a path")
    parser.add_argument("--leg", choices=("left", "right"), default="left")
    parser.add_argument("--fraction", type=float, default=0.1, help="share of each joint's range to sweep")
    parser.add_argument("--speed", type=float, default=0.5, help="rad/s, at most")
    parser.add_argument("--tolerance", type=float, default=0.05, help="rad: how close each end must be reached")
    args = parser.parse_args()
    joints = LEFT_LEG_JOINTS if args.leg == "left" else RIGHT_LEG_JOINTS
    passed = []
    try:
        with open_robot(args.hardware) as robot:
            for joint in joints:
                sweep = robot.sweep(joint, fraction=args.fraction, speed=args.speed)
                ok = sweep.reached_range(args.tolerance)
                ends = ", ".join("-" if end is None else f"{end:+.3f}" for end in (sweep.reached_low, sweep.reached_high))
                print(
                    f"{'ok  ' if ok else 'FAIL'} {joint:24s} range [{sweep.low:+.3f}, {sweep.high:+.3f}] rad, reached [{ends}], "
                    f"max torque {sweep.max_abs_torque:.1f} N m" + ("" if sweep.completed else f"; stopped: {sweep.reason}")
                )
                if ok:
                    passed.append(joint)
                if not sweep.completed:  # a fault, a torque, a stuck joint: the robot is damped; look before going on
                    break
    except G1Error as exc:
        print(f"sweep_leg: {exc}", file=sys.stderr)
        return 2
    print(f"{len(passed)}/{len(joints)} joints of the {args.leg} leg reached their range (tolerance {args.tolerance} rad)")
    return 0 if len(passed) == len(joints) else 1


if __name__ == "__main__":
    sys.exit(main())
