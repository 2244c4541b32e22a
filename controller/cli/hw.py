"""`g1ctl hw ...`: bench bring-up against real or simulated hardware from a hardware config (the jobs are
`controller.runtime.bringup`'s, on the bench interface a script uses: `controller.runtime.bench_robot.open_robot`).

g1ctl hw scan    --hardware sim-can      (or a G1 over DDS: g1-dds, sim-dds; these have no zero)
g1ctl hw monitor --hardware sim-can [--seconds 5] [--refresh 0.2]
g1ctl hw zero    --hardware my-robot --joint left_knee_joint [--yes]
g1ctl hw sweep   --hardware my-robot --joint left_knee_joint [--fraction 0.3] [--speed 0.3] [--yes]
g1ctl hw damp    --hardware my-robot [--seconds 2]
g1ctl hw imu     --hardware my-robot [--seconds 1]
g1ctl hw frame encode --protocol mit --model AK80-9 --position 1.0 --kp 50 --kd 1
g1ctl hw frame decode --protocol unitree-rs485 fdee12...
g1ctl hw frame encode --protocol unitree-hg --id 0 --mode 1 --position 0.2 --kp 60 --kd 1 [--mode-machine 5]   # a whole LowCmd_
"""

from __future__ import annotations

import argparse
import json

from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    hw = sub.add_parser("hw", help="bench bring-up on real or simulated hardware")
    hw_sub = hw.add_subparsers(dest="hw_command", required=True)

    def with_hardware(name: str, help_text: str) -> argparse.ArgumentParser:
        p = hw_sub.add_parser(name, help=help_text)
        p.add_argument("--hardware", required=True, help="hardware config name (configs/hardware) or path")
        p.add_argument("--rt-priority", type=int, default=0, help="run the bus cycle under SCHED_FIFO at this priority (1-99)")
        p.add_argument("--cpu", type=int, default=None, help="pin the bus cycle to this CPU (ideally one kept free, e.g. by isolcpus)")
        return p

    with_hardware("scan", help_text="list the motors answering on each bus")
    monitor = with_hardware("monitor", help_text="live table of every joint")
    monitor.add_argument("--seconds", type=float, default=10.0)
    monitor.add_argument("--refresh", type=float, default=0.25)
    zero = with_hardware("zero", help_text="set a joint's encoder zero at its current position")
    zero.add_argument("--joint", default=None, help="required (a G1 over DDS has no zero: refused)")
    zero.add_argument("--yes", action="store_true", help="do not ask for confirmation")
    sweep = with_hardware("sweep", help_text="slow, low-gain move of one joint through part of its range and back")
    sweep.add_argument("--joint", required=True)
    sweep.add_argument("--fraction", type=float, default=0.3, help="share of the joint's range to sweep")
    sweep.add_argument("--speed", type=float, default=0.3, help="rad/s")
    sweep.add_argument("--yes", action="store_true", help="do not ask for confirmation")
    damp = with_hardware("damp", help_text="damp every joint")
    damp.add_argument("--seconds", type=float, default=2.0)
    imu = with_hardware("imu", help_text="read the IMU")
    imu.add_argument("--seconds", type=float, default=1.0)

    frame = hw_sub.add_parser("frame", help="encode or decode one motor frame")
    frame_sub = frame.add_subparsers(dest="frame_command", required=True)
    enc = frame_sub.add_parser("encode", help="command values (motor side) -> data bytes as hex")
    dec = frame_sub.add_parser("decode", help="data bytes as hex -> fields as JSON")
    for p in (enc, dec):
        p.add_argument("--protocol", required=True, choices=("mit", "unitree-rs485", "unitree-hg"))
        p.add_argument("--model", default=None, help="MIT motor model (configs/motors.yaml)")
    enc.add_argument("--id", type=int, default=1, help="motor id (unitree-hg: the motor slot, 0-34; joints are 0-28)")
    enc.add_argument("--mode", type=int, default=1, help="RS-485: 0 brake, 1 FOC, 2 calibrate; unitree-hg: 1 enables the motor")
    enc.add_argument("--mode-machine", type=int, default=0, help="unitree-hg: copied from the robot's LowState_")
    for field in ("position", "velocity", "torque", "kp", "kd"):
        enc.add_argument(f"--{field}", type=float, default=0.0)
    dec.add_argument("hex", help="the frame's data bytes")
    dec.add_argument("--reply", default=None, choices=("basic", "cubemars", "damiao"), help="MIT: decode as this reply variant")


def run(args: argparse.Namespace) -> int:
    if args.hw_command == "frame":
        return _frame(args)
    from controller.runtime.bringup import BringupConfig  # noqa: PLC0415
    from controller.runtime.bringup import run as run_bringup  # noqa: PLC0415

    cfg = BringupConfig(
        operation=args.hw_command, hardware=args.hardware, joint=getattr(args, "joint", None), seconds=getattr(args, "seconds", 1.0),
        refresh=getattr(args, "refresh", 0.25), fraction=getattr(args, "fraction", 0.3), speed=getattr(args, "speed", 0.3),
        yes=getattr(args, "yes", False), rt_priority=args.rt_priority, cpu=args.cpu, assets_dir=args.assets_dir,
    )  # fmt: skip
    return run_bringup(cfg)


def _frame(args: argparse.Namespace) -> int:
    from hw.frames_cli import decode_frame, encode_frame  # noqa: PLC0415
    from hw.jointmap import load_motor_models  # noqa: PLC0415

    ranges = None
    if args.model is not None:
        models = load_motor_models()
        if args.model not in models:
            raise ConfigError(f"unknown motor model '{args.model}' (known: {', '.join(models)})")
        ranges = models[args.model]
    if args.frame_command == "encode":
        values = {k: getattr(args, k) for k in ("position", "velocity", "torque", "kp", "kd")}
        print(encode_frame(args.protocol, ranges, args.id, args.mode, values, args.mode_machine).hex())
    else:
        print(json.dumps(decode_frame(args.protocol, args.hex, ranges, args.reply)))
    return 0
