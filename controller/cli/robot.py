"""`g1ctl robot --dds [--domain 1] [--interface lo] [--duration S] [--mode-machine 5] [--motion-mode ai]
[--truth] [--lockstep] [--gantry] [--fault KIND@SECONDS ...] [--remote SCENARIO|keyboard|gamepad] [--joint-map CONFIG]
[--seed N]`: a simulated G1 in its own process on the robot's DDS topics.

`g1ctl robot --buses sim-can-process|sim-mixed-process|PATH [--faults PLAN] [--truth-socket PATH] [--host-config PATH]
[--gantry] [--duration S] [--seed N]`: the G1 in MuJoCo behind the firmware emulators of a bus config, in its own process
on the wall clock; its serial ports and slcan CAN adapters are pseudo-terminals, printed as one JSON line
(`{"ready": true, "buses": {...}}`) for a host to open (`g1ctl sim --hardware` with the same config starts one itself;
`--host-config` writes a real robot's config on its ports, for `g1ctl run --hardware`)"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from hw.emulation.g1_faults import KINDS, RobotFault
from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    robot = sub.add_parser("robot", help="a simulated G1 in its own process, on the robot's DDS topics or behind CAN and serial buses")
    robot.add_argument("--dds", action="store_true", help="speak the G1's low-level DDS protocol (rt/lowcmd, rt/lowstate)")
    robot.add_argument(
        "--buses", default=None, metavar="CONFIG",
        help="a bus robot's hardware config (sim-can-process, sim-mixed-process): its buses as pseudo-terminals, CAN over slcan",
    )  # fmt: skip
    robot.add_argument("--faults", default=None, metavar="PLAN", help="with --buses: a fault plan for its buses (configs/faults/)")
    robot.add_argument("--truth-socket", default=None, metavar="PATH", help="with --buses: send the ground truth to this UNIX socket")
    robot.add_argument(
        "--host-config", type=Path, default=None, metavar="PATH",
        help="with --buses: write a real robot's config on this robot's ports (g1ctl run --hardware PATH drives it as real buses)",
    )  # fmt: skip
    robot.add_argument("--domain", type=int, default=1, help="DDS domain (the real robot uses 0)")
    robot.add_argument("--interface", default="lo", help="network interface")
    robot.add_argument("--duration", type=float, default=None, help="seconds to run (default: until stopped)")
    robot.add_argument("--mode-machine", type=int, default=5, help="the robot type code it reports in LowState_")
    robot.add_argument("--motion-mode", default="ai", help="high-level mode at boot: LowCmd_ refused until a host releases it ('': none)")
    robot.add_argument("--truth", action="store_true", help="also publish the simulator's state on sim/truth (for a run's metrics)")
    robot.add_argument("--lockstep", action="store_true", help="answer every LowCmd_ at once with a LowState_ (benchmarks)")
    robot.add_argument("--gantry", action="store_true", help="hang the pelvis in a virtual gantry (bring-up: g1ctl hw)")
    robot.add_argument(
        "--fault", action="append", default=[], metavar="KIND@SECONDS",
        help=f"develop a fault this long after the first command ({', '.join(KINDS)}); repeatable",
    )  # fmt: skip
    robot.add_argument(
        "--joint-map", default=None, metavar="CONFIG",
        help="a DDS hardware config whose joint limits judge every command taken (its report's 'wire' section) "
        "and whose imu_model the IMU measures with (default: the model's defaults)",
    )  # fmt: skip
    robot.add_argument("--seed", type=int, default=0, help="seed of the IMU's noise (a run passes its own)")
    robot.add_argument(
        "--remote", default=None, metavar="SCENARIO",
        help="feed LowState_.wireless_remote from a scenario (name or .yaml; its time starts with the first command taken), "
        "or from 'keyboard' or 'gamepad' (default: a remote at rest)",
    )  # fmt: skip


def run(args: argparse.Namespace) -> int:
    if args.dds == (args.buses is not None):
        raise ConfigError("g1ctl robot needs one protocol: --dds (the G1's low-level DDS topics) or --buses CONFIG (CAN and serial)")
    if args.buses is not None:
        return _bus_robot(args)
    if args.faults is not None or args.truth_socket is not None or args.host_config is not None:
        raise ConfigError("--faults, --truth-socket and --host-config are for --buses; over DDS: --fault KIND@SECONDS and --truth")
    from controller.assets import ensure_assets  # noqa: PLC0415
    from hw.dds.session import DdsConfig  # noqa: PLC0415
    from hw.emulation.g1_lowlevel import LowLevelConfig  # noqa: PLC0415
    from sim.dds_robot import DdsRobotConfig, run_dds_robot  # noqa: PLC0415

    cfg = DdsRobotConfig(
        mjcf=ensure_assets(args.assets_dir, quiet=True).g1_mjcf, dds=DdsConfig(domain=args.domain, interface=args.interface),
        lowlevel=LowLevelConfig(mode_machine=args.mode_machine), duration_s=args.duration, motion_mode=args.motion_mode,
        truth=args.truth, lockstep=args.lockstep, gantry=args.gantry, faults=tuple(RobotFault.parse(f) for f in args.fault),
        joint_map=args.joint_map, seed=args.seed,
    )  # fmt: skip
    with ExitStack() as stack:
        cfg = dataclasses.replace(cfg, remote=_remote(args.remote, stack))
        print(json.dumps(run_dds_robot(cfg)))
    return 0


def _remote(name: str | None, stack: ExitStack) -> Callable[[float], bytes] | None:
    """`--remote`: the remote's bytes by time, as a host reading them with `--input unitree-remote` gets the command back."""
    if name is None:
        return None
    from controller.commands.velocity import CommandLimits  # noqa: PLC0415
    from controller.inputs.unitree_remote import remote_bytes, remote_feed  # noqa: PLC0415

    limits = CommandLimits()  # the sticks carry fractions of these; a host scales them by its policy's ranges (the shipped ones: these)
    if name in ("keyboard", "gamepad"):
        from controller.inputs.registry import open_input  # noqa: PLC0415

        return remote_feed(stack.enter_context(open_input(name, limits, None, 0.0, 0)), limits)
    from controller.inputs.scripted import ScriptedSource, load_scenario, timeline  # noqa: PLC0415

    scenario = load_scenario(name)
    source = ScriptedSource(timeline(scenario, scenario.duration, limits, seed=0), limits)
    for step in source.steps:  # a gesture with no button on the remote: refused before the robot starts
        try:
            remote_bytes(source.poll(step.t), limits)
        except ConfigError as exc:
            raise ConfigError(f"--remote {name}: at {step.t:g} s, {exc}") from exc
    return remote_feed(source, limits)


def _bus_robot(args: argparse.Namespace) -> int:
    """The bus robot: its ports on stdout as soon as they are open, its counters when it stops."""
    import yaml  # noqa: PLC0415

    from controller.assets import ensure_assets  # noqa: PLC0415
    from sim.bus_robot import BusRobotConfig, load_bus_robot, real_robot_yaml, run_bus_robot  # noqa: PLC0415 - MuJoCo

    refused = [flag for flag, given in (("--fault", args.fault), ("--remote", args.remote), ("--lockstep", args.lockstep)) if given]
    if refused:
        raise ConfigError(f"{', '.join(refused)}: for a robot over DDS (--dds); a bus robot's faults are a plan: --faults PLAN")
    load_bus_robot(args.buses)  # a config that is no bus robot's: one line before MuJoCo loads
    cfg = BusRobotConfig(
        mjcf=ensure_assets(args.assets_dir, quiet=True).g1_mjcf, hardware=args.buses, faults=args.faults, seed=args.seed,
        duration_s=args.duration, truth=args.truth_socket, gantry=args.gantry,
    )  # fmt: skip

    def announce(ready: dict[str, Any]) -> None:
        if args.host_config is not None:  # written before the announcement: a host that reads it finds the file
            args.host_config.parent.mkdir(parents=True, exist_ok=True)
            args.host_config.write_text(yaml.safe_dump(real_robot_yaml(args.buses, ready["buses"]), sort_keys=False, width=200))
            ready = {**ready, "host_config": str(args.host_config)}
        print(json.dumps(ready), flush=True)

    print(json.dumps(run_bus_robot(cfg, announce)))
    return 0
