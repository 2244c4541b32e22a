"""Every motor answers, and reports its temperature and error state: a bench check before anything moves.

    python examples/check_motors.py --hardware sim-can

Listens only: nothing is commanded (a G1 keeps its own controller). Exit status 0 when every motor
answered healthy with a temperature, 1 otherwise, 2 when the robot could not be opened.
"""

from __future__ import annotations

import argparse
import sys

from controller.runtime.bench_robot import open_robot
from hw.bench import format_table
from hw.errors import G1Error


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hardware", required=True, help="hardware config: a shipped name (sim-can, g1-dds, ...) or a path")
    args = parser.parse_args()
    try:
        with open_robot(args.hardware) as robot:
            motors = robot.scan()
            print(format_table(motors, ("joint", "bus", "id", "answered", "temperature", "error")))
            for note in robot.notes():
                print(note)
    except G1Error as exc:
        print(f"check_motors: {exc}", file=sys.stderr)
        return 2
    problems = [
        f"{m.joint}: " + ("no reply" if not m.answered else "no temperature reported" if m.temperature is None else f"error {m.error}")
        for m in motors
        if not (m.answered and m.healthy and m.temperature is not None)
    ]
    hottest = max(motors, key=lambda m: m.temperature or -273.0)
    print(f"{len(motors) - len(problems)}/{len(motors)} motors answered healthy; hottest {hottest.joint} at {hottest.temperature} C")
    for problem in problems:
        print(f"FAIL {problem}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
