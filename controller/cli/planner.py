"""`g1ctl train planner` and `g1ctl viz plan`.

g1ctl train planner --data DATASET [--data DATASET ...] --out DIR [--steps N] [--data-weights 1,1,2]
                    [--no-mirror] [--text-dropout 0.3] [--text-variants 12] [--free-share 0] [--hold-out bonus]
                    [--velocity-share 0.3] [--speed-factors 0.8,1.25] [--residual-gain 1] [--velocity-residual-gain G]
g1ctl viz plan --out plan.png [--model DIR] [--data DATASET] [--seeds 4] [--length 44]
g1ctl viz plan --out plan.mp4 --target 1.2,0.4,0.8
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from controller.motion_data.styles import parse_patterns
from controller.planner.request import Keyframe
from hw.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    train = sub.add_parser("train", help="train models (needs the [train] extra: torch)")
    train_sub = train.add_subparsers(dest="train_command", required=True)
    planner = train_sub.add_parser("planner", help="train the in-betweening planner and export it to ONNX")
    planner.add_argument("--data", type=Path, action="append", required=True, help="dataset folder (repeat for several)")
    planner.add_argument("--out", type=Path, required=True, help="model folder: checkpoint, planner.onnx, planner.json")
    planner.add_argument("--steps", type=int, default=None, help="training steps (default: the shipped model's)")
    planner.add_argument("--seed", type=int, default=0)
    planner.add_argument("--threads", type=int, default=2)
    planner.add_argument("--data-weights", default=None, help="share of training windows per --data folder, e.g. 1,1,2 (default: equal)")
    planner.add_argument("--no-mirror", action="store_true", help="do not add left-right mirrored copies of imported clips")
    planner.add_argument("--text-dropout", type=float, default=None, help="share of windows without text (1: no text at all)")
    planner.add_argument("--text-variants", type=int, default=None, help="paraphrases per caption, the caption included")
    planner.add_argument("--free-share", type=float, default=None, help="share of windows with no constraint at all (default 0)")
    planner.add_argument(
        "--hold-out", default=None, help="leave these styles out of every split: clip name patterns, e.g. bonus or 'dance-B_*'"
    )
    planner.add_argument("--velocity-share", type=float, default=None, help="share of windows whose keyframes carry their velocity (0.3)")
    planner.add_argument("--speed-factors", default=None, help="imported clips also played this many times faster, e.g. 0.8,1.25")
    planner.add_argument("--residual-gain", type=float, default=None, help="share of the learned residual added to the anchor (1)")
    planner.add_argument(
        "--velocity-residual-gain", type=float, default=None, help="the same where a keyframe carries its velocity (--residual-gain)"
    )
    planner.add_argument("--no-progress", action="store_true")

    viz = sub.add_parser("viz", help="pictures and videos of plans")
    viz_sub = viz.add_subparsers(dest="viz_command", required=True)
    plan = viz_sub.add_parser("plan", help="context, target keyframe and generated seeds as a filmstrip PNG or a video")
    plan.add_argument("--out", type=Path, required=True, help=".png filmstrip, or .mp4/.gif video")
    plan.add_argument("--model", type=Path, default=None, help="planner model folder (default: the shipped one)")
    plan.add_argument("--data", type=Path, default=None, help="take context and target from this dataset's test split")
    plan.add_argument("--target", default="1.2,0.4,0.8", help="without --data: target root x,y (m) and heading (rad)")
    plan.add_argument("--length", type=int, default=44, help="plan length in frames (multiple of 4, 24-64)")
    plan.add_argument("--seeds", type=int, default=4)
    plan.add_argument("--seed", type=int, default=0, help="which window of the data")
    plan.add_argument("--temperature", type=float, default=None, help="sampling noise scale (default: the model's; higher varies more)")


def run(args: argparse.Namespace) -> int:
    return run_train(args) if args.command == "train" else run_viz(args)


def run_train(args: argparse.Namespace) -> int:
    try:
        from controller.training.planner import TrainConfig, train_planner  # noqa: PLC0415 - needs torch
    except ModuleNotFoundError as exc:
        if exc.name != "torch":
            raise
        raise ConfigError("training needs torch: pip install -e '.[train]' (torch==2.13.0)") from exc
    cfg = TrainConfig(seed=args.seed, threads=args.threads, mirror_imports=not args.no_mirror)
    if args.data_weights is not None:
        cfg = replace(cfg, data_weights=_weights(args.data_weights, len(args.data)))
    if args.text_dropout is not None:
        cfg = replace(cfg, text_dropout=args.text_dropout)
    if args.text_variants is not None:
        cfg = replace(cfg, text_variants=args.text_variants)
    if args.free_share is not None:
        cfg = replace(cfg, free_share=args.free_share)
    if args.hold_out is not None:
        cfg = replace(cfg, hold_out=parse_patterns(args.hold_out, "--hold-out"))
    if args.velocity_share is not None:
        cfg = replace(cfg, velocity_share=args.velocity_share)
    if args.speed_factors is not None:
        cfg = replace(cfg, speed_factors=_numbers(args.speed_factors, "--speed-factors", "0.8,1.25"))
    if args.residual_gain is not None:
        cfg = replace(cfg, residual_gain=args.residual_gain)
    if args.velocity_residual_gain is not None:
        cfg = replace(cfg, velocity_residual_gain=args.velocity_residual_gain)
    if args.steps is not None:
        if args.steps < 1:
            raise ConfigError(f"--steps must be at least 1, got {args.steps}")
        cfg = replace(cfg, steps=args.steps)
    summary = train_planner(args.data, args.out, cfg, progress=not args.no_progress)
    print(json.dumps(summary))
    print(f"model: {args.out}")
    return 0


def _numbers(text: str, option: str, example: str) -> tuple[float, ...]:
    try:
        return tuple(float(w) for w in text.split(","))
    except ValueError as exc:
        raise ConfigError(f"{option} must be comma-separated numbers like {example}, got '{text}'") from exc


def _weights(text: str, folders: int) -> tuple[float, ...]:
    weights = _numbers(text, "--data-weights", "1,1,2")
    if len(weights) != folders or min(weights) <= 0:
        raise ConfigError(f"--data-weights needs {folders} positive numbers, one per --data folder, got '{text}'")
    return weights


@dataclass(frozen=True)
class _Scene:
    context: np.ndarray
    truth: np.ndarray | None
    request_keyframes: tuple[Keyframe, ...]


def run_viz(args: argparse.Namespace) -> int:
    from controller.assets import ensure_assets  # noqa: PLC0415
    from controller.planner.request import PlanRequest  # noqa: PLC0415
    from controller.planner.runtime import Planner  # noqa: PLC0415
    from sim import use_headless_gl  # noqa: PLC0415

    use_headless_gl()  # before MuJoCo is imported: it reads MUJOCO_GL then
    from sim import plan_views  # noqa: PLC0415 - imports MuJoCo
    from sim.world import build_model  # noqa: PLC0415

    if args.out.suffix.lower() not in (".png", ".mp4", ".gif"):
        raise ConfigError(f"--out must end in .png, .mp4 or .gif, got {args.out.name}")
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be at least 1, got {args.seeds}")
    scene = _scene_from_data(args) if args.data is not None else _scene_from_target(args)
    planner = Planner.load(args.model, temperature=args.temperature)
    request = PlanRequest(scene.context, scene.request_keyframes, (args.length,)).validated()
    unreachable = request.unreachable()
    if unreachable is not None:
        print(f"warning: {unreachable}", file=sys.stderr)
    plans, _ = planner.sample(request, list(range(args.seeds)))
    rows = {f"seed {s}": p for s, p in enumerate(plans)}
    if scene.truth is not None:
        rows = {"data": scene.truth[: plans.shape[1]]} | rows
    model = build_model(ensure_assets(args.assets_dir).g1_mjcf)
    lookat = np.array([*np.mean(plans[:, :, :2], axis=(0, 1)), 0.6])
    if args.out.suffix.lower() == ".png":
        plan_views.filmstrip(model, scene.context, rows, lookat, args.out)
    else:
        plan_views.video(model, scene.context, rows, lookat, args.out)
        print(f"columns: {', '.join(rows)}", file=sys.stderr)
    print(f"plan: {args.out}")
    return 0


def _scene_from_target(args: argparse.Namespace) -> _Scene:
    from controller.planner.request import target_root  # noqa: PLC0415
    from hw import g1  # noqa: PLC0415

    try:
        x, y, heading = (float(v) for v in args.target.split(","))
    except ValueError as exc:
        raise ConfigError(f"--target must be x,y,heading (three numbers), got '{args.target}'") from exc
    return _Scene(np.tile(g1.standing_qpos(), (4, 1)), None, (target_root(args.length - 1, x, y, heading),))


def _scene_from_data(args: argparse.Namespace) -> _Scene:
    from controller.motion_data.dataset import load_dataset  # noqa: PLC0415

    clips = [c for c in load_dataset(args.data, split="test") if len(c.qpos) >= 4 + args.length]
    if not clips:
        raise ConfigError(f"no test clip in {args.data} is long enough for a {args.length}-frame plan")
    rng = np.random.default_rng(args.seed)
    clip = clips[int(rng.integers(len(clips)))]
    start = int(rng.integers(0, len(clip.qpos) - 4 - args.length + 1))
    window = clip.qpos[start : start + 4 + args.length]
    target = window[-1]
    return _Scene(window[:4], window[4:], (Keyframe(args.length - 1, target),))
