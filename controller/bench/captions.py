"""`g1ctl bench caption`: does a caption change the plan, and in the way it says?

Usage:
    g1ctl bench caption [--data PATH] [--model DIR] [--seeds 8] [--windows 200] [--length 44] --report PATH

Protocol.
- Free plans: from a standing context (4 standing frames) and, with `--data`, from the
  contexts of `--windows` test-split windows, the planner is asked for a `--length`-frame
  plan with no keyframe and no root target, under each caption of `CAPTIONS` (and none),
  with seeds 0..`--seeds`-1. Per caption: the root's displacement at the last frame in the
  context's heading frame (forward, left; m), the heading change (deg), the arm motion (mean
  absolute change of the left and right arm joints from the context's last frame, rad), and
  how far the plan moves from the untexted plan of the same context and seed (mean body
  position distance by forward kinematics, m).
- Captioned test windows (with `--data`): windows of `--length` - 1 transition frames whose
  transition has one caption in force (`controller.training.captions.caption_in_force`). Each
  is planned with no text, with its true caption and with a wrong one (another window's
  caption, seeded), both free (context only) and as in-betweening (the true target frame as
  a keyframe); l2p (m) against the truth, seed 0..`--seeds`-1 averaged.
The text is embedded with the all-MiniLM-L6-v2 sentence encoder (`controller.text.encoder`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from controller.bench import motion_metrics as mt
from controller.bench.inbetween import draw_windows, load_test_clips
from controller.planner import features as ft
from controller.planner.request import ALLOWED_LENGTHS, CONTEXT_FRAMES, FloatArray, Keyframe, PlanRequest
from hw import g1
from hw.errors import ConfigError

CAPTIONS: tuple[str | None, ...] = (
    None, "walk forward", "walk backward", "turn left in place", "turn right in place", "step sideways to the left",
    "wave the right hand", "raise both arms",
)  # fmt: skip
_LEFT_ARM, _RIGHT_ARM = g1.joint_slice(g1.LEFT_ARM_JOINTS, qpos=True), g1.joint_slice(g1.RIGHT_ARM_JOINTS, qpos=True)


@dataclass(frozen=True)
class CaptionConfig:
    data: Path | None = None
    model_dir: Path | None = None
    seeds: int = 8
    windows: int = 200
    length: int = 44
    seed: int = 0
    assets_dir: str | None = None
    captions: tuple[str | None, ...] = CAPTIONS


class _Kinematics(Protocol):
    def forward(self, qpos: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]: ...


class _Planner(Protocol):
    text_conditioned: bool

    def sample(self, request: PlanRequest, seeds: list[int]) -> tuple[np.ndarray, np.ndarray]: ...


Embed = Callable[[list[str]], np.ndarray]


def validate(cfg: CaptionConfig) -> None:
    if cfg.length not in ALLOWED_LENGTHS:
        raise ConfigError(f"--length {cfg.length} is not a plan length: use a multiple of 4 from 24 to 64")
    if cfg.seeds < 1 or cfg.windows < 1:
        raise ConfigError(f"--seeds and --windows must be at least 1, got {cfg.seeds} and {cfg.windows}")
    if None not in cfg.captions:
        raise ConfigError("the caption set must include no text (None): changes are measured against it")


def plan_motion(plans: FloatArray, context_last: FloatArray) -> dict[str, FloatArray]:
    """Per plan [S, N, 36]: root displacement at the end in the context's heading frame, heading change, arm motion."""
    origin_xy, origin_yaw = ft.frame_origin(context_last)
    channels = ft.to_channels(plans, origin_xy, origin_yaw)  # [S, N, C], root at the context's last frame, facing +x
    last = context_last
    return {
        "forward_m": channels[:, -1, 0],
        "left_m": channels[:, -1, 1],
        "heading_deg": np.rad2deg(channels[:, -1, ft.HEADING]),
        "left_arm_rad": np.abs(plans[..., _LEFT_ARM] - last[_LEFT_ARM]).mean(axis=(-2, -1)),
        "right_arm_rad": np.abs(plans[..., _RIGHT_ARM] - last[_RIGHT_ARM]).mean(axis=(-2, -1)),
    }


def _body_distance(kin: _Kinematics, a: FloatArray, b: FloatArray) -> float:
    pa = kin.forward(a.reshape(-1, a.shape[-1]))[0]
    pb = kin.forward(b.reshape(-1, b.shape[-1]))[0]
    return mt.l2p(pa, pb)


def free_plans(
    planner: _Planner, contexts: Sequence[FloatArray], cfg: CaptionConfig, texts: dict[str, FloatArray], kin: _Kinematics
) -> dict[str, dict[str, float]]:
    """Per caption (None as "none"): mean motion figures of free plans and the distance from the untexted plans."""
    seeds = list(range(cfg.seeds))
    untexted: list[FloatArray] = []
    out: dict[str, dict[str, float]] = {}
    for caption in cfg.captions:
        figures: dict[str, list[float]] = {}
        distances = []
        for i, context in enumerate(contexts):
            text = None if caption is None else texts[caption]
            request = PlanRequest(context=context, lengths=(cfg.length,), text_embedding=text).validated()
            plans, _ = planner.sample(request, seeds)
            if caption is None:
                untexted.append(plans)
            else:
                distances.append(_body_distance(kin, plans, untexted[i]))
            for key, values in plan_motion(plans, context[-1]).items():
                figures.setdefault(key, []).extend(values.tolist())
        row = {key: round(float(np.mean(v)), 4) for key, v in figures.items()}
        row["change_vs_none_m"] = round(float(np.mean(distances)), 4) if distances else 0.0
        out["none" if caption is None else caption] = row
    return out


def captioned_windows(planner: _Planner, clips: Sequence[Any], cfg: CaptionConfig, embed: Embed, kin: _Kinematics) -> dict[str, Any]:
    """l2p of free and in-betweening plans on captioned test windows: no text, the true caption, a wrong caption."""
    from controller.training.captions import caption_in_force  # noqa: PLC0415 - pure numpy, beside the training code

    transition = cfg.length - 1
    by_name = {c.name: c for c in clips}
    picked = []
    rng = np.random.default_rng(cfg.seed)
    drawn = draw_windows(clips, transition, cfg.windows * 4, cfg.seed)  # in clip order: shuffled, so every clip takes part
    for i in rng.permutation(len(drawn)):
        window = drawn[int(i)]
        first = window.start + CONTEXT_FRAMES
        caption = caption_in_force(tuple(by_name[window.clip].captions), first, first + transition, majority=0.9)
        if caption is not None:
            picked.append((window, caption))
        if len(picked) == cfg.windows:
            break
    if not picked:
        raise ConfigError("no test window has one caption in force over its transition; pass a recorded dataset")
    captions = sorted({c for _, c in picked})
    wrong = [captions[int(rng.integers(len(captions)))] for _ in picked]
    for i, (_, caption) in enumerate(picked):
        while wrong[i] == caption and len(captions) > 1:
            wrong[i] = captions[int(rng.integers(len(captions)))]
    vectors = embed(captions)
    texts = {c: vectors[i] for i, c in enumerate(captions)}
    seeds = list(range(cfg.seeds))
    results: dict[str, dict[str, list[float]]] = {"free": {}, "target": {}}
    for (window, caption), other in zip(picked, wrong, strict=True):
        truth_pos = kin.forward(window.transition)[0]
        for setting in results:
            keys: tuple[Keyframe, ...] = (Keyframe(transition, window.target),) if setting == "target" else ()
            for name, text in (("none", None), ("true", texts[caption]), ("wrong", texts[other])):
                request = PlanRequest(context=window.context, keyframes=keys, lengths=(cfg.length,), text_embedding=text).validated()
                plans, _ = planner.sample(request, seeds)
                pos = kin.forward(plans[:, :transition].reshape(-1, plans.shape[-1]))[0].reshape(len(seeds), transition, -1, 3)
                results[setting].setdefault(name, []).append(mt.l2p(pos, np.broadcast_to(truth_pos, pos.shape)))
    return {
        "windows": len(picked),
        "distinct_captions": len(captions),
        "transition_frames": transition,
        "l2p_m": {s: {name: round(float(np.mean(v)), 4) for name, v in r.items()} for s, r in results.items()},
        "true_beats_none_share": {s: round(float(np.mean(np.array(r["true"]) < np.array(r["none"]))), 3) for s, r in results.items()},
    }


def run_on(planner: _Planner, embed: Embed, kin: _Kinematics, cfg: CaptionConfig, clips: Sequence[Any] | None) -> dict[str, Any]:
    """The report from a loaded planner, an embedding function, kinematics and optional test clips."""
    validate(cfg)
    started = time.perf_counter()
    named = [c for c in cfg.captions if c is not None]
    vectors = embed(named)
    texts = {c: vectors[i] for i, c in enumerate(named)}
    standing = [np.tile(g1.standing_qpos(), (CONTEXT_FRAMES, 1))]
    report: dict[str, Any] = {
        "benchmark": "caption",
        "text_conditioned": planner.text_conditioned,
        "length": cfg.length,
        "seeds": cfg.seeds,
        "captions": ["none" if c is None else c for c in cfg.captions],
        "standing": free_plans(planner, standing, cfg, texts, kin),
    }
    if clips is not None:
        windows = draw_windows(clips, cfg.length, cfg.windows, cfg.seed)
        report["test_contexts"] = free_plans(planner, [w.context for w in windows], cfg, texts, kin)
        report["test_contexts_count"] = len(windows)
        report["captioned_windows"] = captioned_windows(planner, clips, cfg, embed, kin)
    report["wall_seconds"] = round(time.perf_counter() - started, 2)
    return report


def run_caption_bench(cfg: CaptionConfig) -> dict[str, Any]:
    """Load the planner, the sentence encoder, the G1 kinematics and the test clips; return the JSON report."""
    validate(cfg)
    clips = load_test_clips(cfg.data) if cfg.data is not None else None
    from controller.assets import ensure_assets  # noqa: PLC0415 - MuJoCo only for this command
    from controller.planner.runtime import Planner  # noqa: PLC0415
    from controller.text.encoder import shared_encoder  # noqa: PLC0415
    from sim.kinematics import G1Kinematics  # noqa: PLC0415

    planner = Planner.load(cfg.model_dir, threads=1)
    if not planner.text_conditioned:
        raise ConfigError(
            f"the planner model in {cfg.model_dir or 'models/planner'} was trained without text (planner.json: text_conditioned "
            "false), so there is no caption to measure; pass --model with a text-conditioned model"
        )
    kin = G1Kinematics(ensure_assets(cfg.assets_dir, quiet=True).g1_mjcf)
    encoder = shared_encoder()
    report = run_on(planner, encoder.embed, kin, cfg, clips)
    return {"data": None if cfg.data is None else str(cfg.data), **report}


def format_table(report: dict[str, Any]) -> str:
    """Per context kind, one row per caption; then the captioned windows' l2p."""
    cols = ("forward_m", "left_m", "heading_deg", "left_arm_rad", "right_arm_rad", "change_vs_none_m")
    lines = [f"caption benchmark (text_conditioned: {report['text_conditioned']}, {report['length']} frames, {report['seeds']} seeds)"]
    for kind in ("standing", "test_contexts"):
        if kind not in report:
            continue
        lines += ["", kind, f"{'caption':<28}" + "".join(f"{c:>18}" for c in cols)]
        for caption, row in report[kind].items():
            lines.append(f"{caption:<28}" + "".join(f"{row[c]:>18.4f}" for c in cols))
    if "captioned_windows" in report:
        cw = report["captioned_windows"]
        lines += ["", f"captioned test windows: {cw['windows']} ({cw['distinct_captions']} captions), l2p m"]
        for setting, row in cw["l2p_m"].items():
            cells = ", ".join(f"{name} {value:.4f}" for name, value in row.items())
            lines.append(f"  {setting:<7} {cells}; true < none in {cw['true_beats_none_share'][setting]:.0%} of windows")
    return "\n".join(lines)
