"""`g1ctl dataset ...`: the planner's motion dataset.

g1ctl dataset record --out DIR --minutes M --seed S [--policy fastsac] [--progress] [--workers N] [--address ADDR]
g1ctl dataset import --csv PATH [--fps 60] --out DIR      (a .csv file or a folder of them, recursively)
g1ctl dataset info DIR

Format and split rule: `controller/planner/dataset.py`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    dataset = sub.add_parser("dataset", help="record, import and inspect motion datasets for the planner")
    dataset_sub = dataset.add_subparsers(dest="dataset_command", required=True)

    record = dataset_sub.add_parser("record", help="record the simulated G1 under random commands and gestures")
    record.add_argument("--out", type=Path, required=True, help="dataset folder (shards and manifest.json)")
    record.add_argument("--minutes", type=float, required=True, help="minutes of motion to keep")
    record.add_argument("--seed", type=int, default=0, help="run seed; episode seeds and splits follow from it")
    record.add_argument("--policy", default="fastsac", help="policy preset name or path to a policy YAML")
    record.add_argument("--progress", action="store_true", help="show a progress bar on stderr")
    record.add_argument("--workers", type=int, default=1, help="episodes at a time, as Ray tasks (1: in this process)")
    record.add_argument("--address", default=None, help="record on this Ray cluster (e.g. auto, or HOST:6379)")

    imp = dataset_sub.add_parser("import", help="import G1 clips from 36-column CSV files")
    imp.add_argument("--csv", required=True, help="a .csv file or a folder searched recursively")
    imp.add_argument("--fps", type=float, default=60.0, help="frame rate of the CSV files (resampled to 30)")
    imp.add_argument("--out", type=Path, required=True, help="dataset folder (shards and manifest.json)")

    info = dataset_sub.add_parser("info", help="clips, minutes per split and gesture histogram as JSON")
    info.add_argument("path", type=Path, help="dataset folder or its manifest.json")


def run(args: argparse.Namespace) -> int:
    if args.dataset_command == "info":
        from controller.motion_data.dataset import dataset_summary  # noqa: PLC0415

        print(json.dumps(dataset_summary(args.path), indent=2))
        return 0
    from controller.eval import dataset_recorder as dataset_record  # noqa: PLC0415 - imports MuJoCo
    from controller.motion_data import csv_import  # noqa: PLC0415

    if args.dataset_command == "record":
        cfg = dataset_record.RecordConfig(
            out=args.out, minutes=args.minutes, seed=args.seed, policy=args.policy, progress=args.progress, assets_dir=args.assets_dir,
            workers=args.workers, address=args.address,
        )  # fmt: skip
        print(json.dumps(dataset_record.record(cfg)))
        return 0
    if args.dataset_command == "import":
        print(json.dumps(csv_import.import_csv(args.csv, args.out, args.fps, args.assets_dir)))
        return 0
    raise AssertionError(args.dataset_command)
