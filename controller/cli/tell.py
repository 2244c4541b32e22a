"""`g1ctl tell "INSTRUCTION" --to PATH`: one instruction to a run that takes them (`g1ctl run --instructions PATH`).

g1ctl tell "walk forward 1 m, then wave" --to /run/user/1000/g1.sock [--timeout 10]

Prints the run's reply line: "accepted: ..." (exit status 0), or "refused: ...", "dropped: ...",
"cancelled: ..." (exit status 1). No run listening there, or no reply in time: one line, exit status 2.
"stop" ends what the robot does and stands it.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    tell = sub.add_parser("tell", help="send one instruction to a running g1ctl run --instructions PATH, print its reply")
    tell.add_argument("instruction", help='what the robot should do now, e.g. "wave" or "stop"')
    tell.add_argument("--to", type=Path, required=True, help="the run's instruction socket (its --instructions PATH)")
    tell.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the reply")


def run(args: argparse.Namespace) -> int:
    from controller.inputs.instruction_socket import send_instruction  # noqa: PLC0415

    reply = send_instruction(args.to, args.instruction, args.timeout)
    print(reply)
    return 0 if reply.startswith("accepted") else 1
