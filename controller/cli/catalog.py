"""`g1ctl assets fetch|path` and `g1ctl scenarios`: the assets, and what ships by name."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    assets = sub.add_parser("assets", help="manage the G1 model and policy files")
    assets_sub = assets.add_subparsers(dest="assets_command", required=True)
    assets_sub.add_parser("fetch", help="download and verify the assets (no work when already there)")
    assets_sub.add_parser("path", help="print where the assets are")
    sub.add_parser(
        "scenarios",
        help="list shipped scenarios, policy presets, trackers, inputs, hardware configs, perturbation sets, fault plans and suites",
    )


def run(args: argparse.Namespace) -> int:
    if args.command == "assets":
        from controller.assets import ensure_assets  # noqa: PLC0415

        print(ensure_assets(args.assets_dir).root)
        return 0
    from controller.eval.suite import available_suites  # noqa: PLC0415
    from controller.inputs.registry import INPUTS  # noqa: PLC0415
    from controller.inputs.scripted import available_scenarios  # noqa: PLC0415
    from controller.tracking.presets import available_policies  # noqa: PLC0415
    from controller.tracking.registry import available_trackers  # noqa: PLC0415
    from hw.emulation.faults import available_fault_plans  # noqa: PLC0415
    from hw.jointmap import available_hardware  # noqa: PLC0415
    from hw.shipped import config_dir  # noqa: PLC0415
    from hw.yamlconfig import preset_names  # noqa: PLC0415

    print("scenarios:    ", ", ".join(available_scenarios()))
    print("policies:     ", ", ".join(available_policies()))
    print("trackers:     ", ", ".join(available_trackers()))
    print("inputs:       ", ", ".join(INPUTS))
    print("hardware:     ", ", ".join(available_hardware()))
    print("perturbations:", ", ".join(preset_names(config_dir("perturbations"))))
    print("fault plans:  ", ", ".join(available_fault_plans()))
    print("suites:       ", ", ".join(available_suites()))
    return 0
