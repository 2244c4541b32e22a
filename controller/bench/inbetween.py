"""`g1ctl bench inbetween`: motion in-betweening on held-out clips, the learned planner against baselines.

Usage:
    g1ctl bench inbetween --data PATH [--methods ours,interp,hermite,zerovel] [--lengths 15,30,45]
                          [--windows 200] [--seed 0] [--model DIR] [--temperature T] [--residual-gain G] [--split val] --report PATH
    g1ctl bench inbetween --data PATH --only bonus --split all ...   (a style the model was trained without)

Protocol. For each transition length L, up to `--windows` windows are drawn at random
(seeded) from the test split of the clips (`--split val`: the validation split, where
sampling settings are chosen; never tune on test; `--only STYLE --split all`: every clip of a
style held out of training, `controller.motion_data.styles`): 4 context frames, the L true transition frames,
the target frame, and the true frame after the target (only hermite reads it, for its
arrival velocity). Every method gets the same windows: the context and the full target
frame (pose and root), and returns the L transition frames plus the frame it puts at the
target. Forward kinematics of the G1 turns frames into body poses; the metrics
(`controller.bench.motion_metrics`) compare them with the truth in the world frame.

- Pose metrics (l2p, l2q, npss) cover the L transition frames.
- Motion metrics (foot_skate, joint_jitter, root_jitter) run over the motion as it would be
  executed: the context, the method's transition, then the target keyframe as given. Foot
  skate counts the L + 1 steps from the context's last frame to the target; jitter the
  L + 1 accelerations at the context's last frame and at each transition frame. A velocity
  break at the start or a jump onto the target counts; the truth's own figures for the
  same frames are in the report's `ground_truth`.
- Plausibility (wild_share, beyond_limits_share; `controller.planner.plausibility`): the share of
  the L transition frames beyond what the motion data ever shows (pelvis tilt, root-height change
  from the context's last frame and from frame to frame), and the share of their joint values
  outside the G1's limits, as the method made them (no method clamps). Foot skate is above.
- Target metrics (tgt_keyframe_err, tgt_root_err, reach_success) read the frame the method
  puts at the target (the baselines: the target itself; zerovel: the held frame).
- `ours_vel`: `ours` with the target keyframe's true velocity (`Keyframe.velocity`, from the
  frame after the target, as `hermite` gets it); for models trained with keyframe velocities.
- diversity: for stochastic methods, seeds 0..9 on the first 20 windows of each length.
- latency_ms: one 44-frame plan of `ours`, one intra-op thread, 200 timed calls after warm-up.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from controller.bench import baselines
from controller.bench import motion_metrics as mt
from controller.planner import plausibility
from controller.planner.request import (
    ALLOWED_LENGTHS,
    CONTEXT_FRAMES,
    FPS,
    KEYFRAME_LIMIT_TOLERANCE_RAD,
    MAX_LENGTH,
    FloatArray,
    Keyframe,
    PlanRequest,
)  # fmt: skip
from controller.reports import percentiles_ms
from hw import g1
from hw.errors import ConfigError

DEFAULT_METHODS = ("ours", "interp", "hermite", "zerovel")
DEFAULT_LENGTHS = (15, 30, 45)
LATENCY_PLAN_FRAMES = 44
TABLE_COLUMNS = (
    ("l2p", "l2p m"),
    ("l2q", "l2q rad"),
    ("npss", "npss"),
    ("foot_skate", "skate m/s"),
    ("joint_jitter", "jitter m/s2"),
    ("root_jitter", "root jit"),
    ("wild_share", "wild"),
    ("beyond_limits_share", "beyond lim"),
    ("tgt_keyframe_err", "tgt err m"),
    ("tgt_root_err", "root err m"),
    ("reach_success", "reach"),
    ("diversity", "div m"),
)


class Clip(Protocol):
    """What the benchmark reads of a motion clip (`controller.motion_data.dataset.MotionClip`)."""

    @property
    def name(self) -> str: ...

    @property
    def qpos(self) -> FloatArray: ...


@dataclass(frozen=True)
class InbetweenConfig:
    data: Path
    methods: tuple[str, ...] = DEFAULT_METHODS
    lengths: tuple[int, ...] = DEFAULT_LENGTHS
    windows: int = 200
    seed: int = 0
    assets_dir: str | None = None
    model_dir: Path | None = None
    temperature: float | None = None  # ours: sampling noise scale (default: the model's)
    residual_gain: float | None = None  # ours: share of the learned residual added to the anchor (default: the model's)
    split: str = "test"  # "all": every split, for a style the model was trained without (`only`)
    only: tuple[str, ...] = ()  # clip name patterns (controller.motion_data.styles): score on these clips alone
    diversity_windows: int = 20
    diversity_seeds: int = 10
    latency_repeats: int = 200
    latency_warmup: int = 20


@dataclass(frozen=True)
class Window:
    """A cut of a clip: context [4], transition [L], target, and the true frame after the target."""

    clip: str
    start: int
    length: int
    frames: FloatArray  # [4 + L + 2, 36]

    @property
    def context(self) -> FloatArray:
        return self.frames[:CONTEXT_FRAMES]

    @property
    def transition(self) -> FloatArray:
        return self.frames[CONTEXT_FRAMES : CONTEXT_FRAMES + self.length]

    @property
    def target(self) -> FloatArray:
        return self.frames[CONTEXT_FRAMES + self.length]

    @property
    def after_target(self) -> FloatArray:
        return self.frames[CONTEXT_FRAMES + self.length + 1]


Predict = Callable[[Window, int], FloatArray]  # (window, seed) -> [L + 1, 36]: transition and the frame at the target


@dataclass(frozen=True)
class Method:
    predict: Predict
    stochastic: bool = False
    latency: Callable[[Window], dict[str, float]] | None = None  # p50/p99 ms of one 44-frame plan


def _interp(cfg: InbetweenConfig) -> Method:
    return Method(lambda w, _seed: np.vstack((baselines.interp(w.context, w.target, w.length), w.target)))


def _hermite(cfg: InbetweenConfig) -> Method:
    def predict(w: Window, _seed: int) -> FloatArray:
        velocity = baselines.finite_velocity(w.target, w.after_target)
        return np.vstack((baselines.hermite(w.context, w.target, w.length, velocity), w.target))

    return Method(predict)


def _zerovel(cfg: InbetweenConfig) -> Method:
    return Method(lambda w, _seed: np.vstack((baselines.zerovel(w.context, w.target, w.length), w.context[-1])))


def _ours(cfg: InbetweenConfig, target_velocity: bool = False) -> Method:
    from controller.planner.runtime import Planner  # noqa: PLC0415 - the learned planner is optional here

    planner = Planner.load(cfg.model_dir, threads=1, temperature=cfg.temperature, residual_gain=cfg.residual_gain)

    def request(w: Window, seed: int, lengths: tuple[int, ...] | None = None, frame: int | None = None) -> PlanRequest:
        velocity = baselines.finite_velocity(w.target, w.after_target) if target_velocity else None
        key = Keyframe(frame=w.length if frame is None else frame, qpos=w.target, velocity=velocity)
        return PlanRequest(context=w.context, keyframes=(key,), lengths=lengths or (plan_length(w.length),), seed=seed)

    def predict(w: Window, seed: int) -> FloatArray:
        return np.asarray(planner.plan(request(w, seed)).qpos[: w.length + 1], dtype=np.float64)

    def latency(w: Window) -> dict[str, float]:
        req = request(w, cfg.seed, lengths=(LATENCY_PLAN_FRAMES,), frame=LATENCY_PLAN_FRAMES - 1)
        for _ in range(cfg.latency_warmup):
            planner.plan(req)
        times = []
        for _ in range(cfg.latency_repeats):
            started = time.perf_counter()
            planner.plan(req)
            times.append(time.perf_counter() - started)
        return percentiles_ms(times)

    return Method(predict, stochastic=True, latency=None if target_velocity else latency)


def _ours_vel(cfg: InbetweenConfig) -> Method:
    """`ours` told the true velocity at the target (`Keyframe.velocity`), as `hermite` is: judged against it."""
    return _ours(cfg, target_velocity=True)


METHODS: dict[str, Callable[[InbetweenConfig], Method]] = {
    "ours": _ours, "interp": _interp, "hermite": _hermite, "zerovel": _zerovel, "ours_vel": _ours_vel,
}  # fmt: skip


def plan_length(length: int) -> int:
    """The shortest allowed plan that holds L transition frames and the target frame."""
    fits = [n for n in ALLOWED_LENGTHS if n >= length + 1]
    if not fits:
        raise ConfigError(
            f"a transition of {length} frames does not fit a plan of at most {MAX_LENGTH} frames; use lengths up to {MAX_LENGTH - 1}"
        )
    return fits[0]


def parse_methods(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in METHODS]
    if unknown or not names:
        raise ConfigError(f"unknown in-betweening method '{unknown[0] if unknown else text}'; valid methods: {', '.join(METHODS)}")
    return tuple(dict.fromkeys(names))


def parse_lengths(text: str) -> tuple[int, ...]:
    try:
        lengths = tuple(int(n) for n in text.split(",") if n.strip())
    except ValueError as exc:
        raise ConfigError(f"--lengths must be comma-separated frame counts like 15,30,45, got '{text}'") from exc
    if not lengths or min(lengths) < 1:
        raise ConfigError(f"transition lengths must be at least 1 frame, got '{text}'")
    return tuple(dict.fromkeys(lengths))


def validate(cfg: InbetweenConfig) -> None:
    """ConfigError for a run that cannot start, before anything heavy is loaded."""
    for name in cfg.methods:
        if name not in METHODS:
            raise ConfigError(f"unknown in-betweening method '{name}'; valid methods: {', '.join(METHODS)}")
    if not cfg.methods:
        raise ConfigError(f"no in-betweening method given; valid methods: {', '.join(METHODS)}")
    if not cfg.lengths or min(cfg.lengths) < 1:
        raise ConfigError(f"transition lengths must be at least 1 frame, got {list(cfg.lengths)}")
    if cfg.windows < 1:
        raise ConfigError(f"--windows must be at least 1, got {cfg.windows}")
    if "ours" in cfg.methods or "ours_vel" in cfg.methods:
        for length in cfg.lengths:
            plan_length(length)


def draw_windows(clips: Sequence[Clip], length: int, count: int, seed: int) -> list[Window]:
    """Up to `count` distinct windows for transition length `length`, uniform over every (clip, offset) that fits.

    A window whose target pose has a joint outside the G1's limits is not drawn: the planner
    refuses such a keyframe (`PlanRequest`), and a robot's recorded pose can be one (MuJoCo's
    soft limits let a loaded joint pass its limit by up to 0.05 rad in `data/rec2`).
    """
    span = CONTEXT_FRAMES + length + 2
    offsets = [_targets_within_limits(c.qpos, length, span) for c in clips]
    starts = np.array([len(o) for o in offsets], dtype=np.int64)
    total = int(starts.sum())
    if total == 0:
        longest = max((len(c.qpos) for c in clips), default=0)
        raise ConfigError(f"no test clip is long enough for a {length}-frame transition ({span} frames needed, the longest has {longest})")
    rng = np.random.default_rng([seed, length])
    picks = np.sort(rng.choice(total, size=min(count, total), replace=False))
    bounds = np.cumsum(starts)
    windows = []
    for pick in picks:
        index = int(np.searchsorted(bounds, pick, side="right"))
        start = int(offsets[index][pick - (bounds[index] - starts[index])])
        clip = clips[index]
        frames = np.asarray(clip.qpos[start : start + span], dtype=np.float64)
        windows.append(Window(clip.name, start, length, frames))
    return windows


def _targets_within_limits(qpos: FloatArray, length: int, span: int) -> NDArray[np.int64]:
    """The offsets of a clip where a window fits and its target frame is within the joint limits."""
    fits = max(len(qpos) - span + 1, 0)
    targets = np.asarray(qpos[CONTEXT_FRAMES + length : CONTEXT_FRAMES + length + fits, g1.QPOS_JOINTS], dtype=np.float64)
    inside = ~plausibility.beyond_limits(targets, KEYFRAME_LIMIT_TOLERANCE_RAD).any(axis=-1)
    return np.flatnonzero(inside).astype(np.int64)


class _Kinematics(Protocol):
    def forward(self, qpos: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]: ...


def _fk(kin: _Kinematics, frames: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """FK of frames [..., T, 36] -> positions [..., T, B, 3], quaternions [..., T, B, 4], feet [..., T, 2, 3]."""
    lead = frames.shape[:-1]
    pos, quat, feet = kin.forward(frames.reshape(-1, frames.shape[-1]))
    return pos.reshape(*lead, *pos.shape[1:]), quat.reshape(*lead, *quat.shape[1:]), feet.reshape(*lead, *feet.shape[1:])


def evaluate(
    method: Method, windows: list[Window], kin: _Kinematics, truth: tuple[FloatArray, ...], cfg: InbetweenConfig
) -> dict[str, float]:
    """Every metric of one method on the windows of one length.

    `truth` is (frames, positions, quaternions, feet) of the true frames [N, L + 3]: the
    context's last two frames, the transition, the target (see `run_on_clips`).
    """
    length = windows[0].length
    true_frames, true_pos, true_quat, true_feet = truth
    pred = np.stack([method.predict(w, cfg.seed) for w in windows])  # [N, L + 1, 36]
    if pred.shape != (len(windows), length + 1, true_frames.shape[-1]) or not np.isfinite(pred).all():
        raise ValueError(f"an in-betweening method returned frames of shape {pred.shape} or non-finite values")
    pos, quat, feet = _fk(kin, pred)
    inner, gap, at = slice(0, length), slice(2, length + 2), length + 2
    root, rot, joints = g1.QPOS_ROOT_POS, g1.QPOS_ROOT_QUAT, g1.QPOS_JOINTS
    # The motion as executed: the known context, the method's transition, the target keyframe.
    motion_pos = np.concatenate((true_pos[:, :2], pos[:, inner], true_pos[:, at:]), axis=1)
    motion_feet = np.concatenate((true_feet[:, 1:2], feet[:, inner], true_feet[:, at:]), axis=1)
    result = {
        "l2p": mt.l2p(pos[:, inner], true_pos[:, gap]),
        "l2q": mt.l2q(quat[:, inner], true_quat[:, gap]),
        "npss": mt.npss(pred[:, inner, joints], true_frames[:, gap, joints]),
        "foot_skate": mt.foot_skate(motion_feet),
        "joint_jitter": mt.joint_jitter(motion_pos),
        "root_jitter": mt.root_jitter(motion_pos),
        "wild_share": float(plausibility.wild_frames(pred[:, inner], true_frames[:, 1]).mean()),
        "beyond_limits_share": float(plausibility.beyond_limits(pred[:, inner, joints]).mean()),
        "tgt_keyframe_err": float(mt.keyframe_error(pos[:, length], true_pos[:, at]).mean()),
        "tgt_root_err": float(mt.root_error(pred[:, length, root], true_frames[:, at, root]).mean()),
        "reach_success": float(
            mt.reached(pred[:, length, root], pred[:, length, rot], true_frames[:, at, root], true_frames[:, at, rot]).mean()
        ),
        "diversity": 0.0,
    }
    if method.stochastic:
        spreads = []
        for w in windows[: cfg.diversity_windows]:
            samples = np.stack([method.predict(w, s)[:length] for s in range(cfg.diversity_seeds)])
            spreads.append(mt.diversity(_fk(kin, samples)[0]))
        result["diversity"] = float(np.mean(spreads))
    return {k: round(v, 6) for k, v in result.items()}


def run_on_clips(clips: Sequence[Clip], cfg: InbetweenConfig, kin: _Kinematics) -> dict[str, Any]:
    """The benchmark on given clips and kinematics: the report without the data source."""
    validate(cfg)
    methods = {name: METHODS[name](cfg) for name in cfg.methods}
    started = time.perf_counter()
    results: dict[str, dict[str, dict[str, float]]] = {name: {} for name in methods}
    reference: dict[str, dict[str, float]] = {}
    counts: dict[str, int] = {}
    first_window = None
    for length in cfg.lengths:
        windows = draw_windows(clips, length, cfg.windows, cfg.seed)
        first_window = first_window or windows[0]
        counts[str(length)] = len(windows)
        true_frames = np.stack([w.frames[CONTEXT_FRAMES - 2 : CONTEXT_FRAMES + length + 1] for w in windows])  # [N, L + 3, 36]
        true_pos, true_quat, true_feet = _fk(kin, true_frames)
        truth = (true_frames, true_pos, true_quat, true_feet)
        reference[str(length)] = {
            "foot_skate": round(mt.foot_skate(true_feet[:, 1:]), 6),
            "joint_jitter": round(mt.joint_jitter(true_pos), 6),
            "root_jitter": round(mt.root_jitter(true_pos), 6),
            "wild_share": round(float(plausibility.wild_frames(true_frames[:, 2:-1], true_frames[:, 1]).mean()), 6),
            "beyond_limits_share": round(float(plausibility.beyond_limits(true_frames[:, 2:-1, g1.QPOS_JOINTS]).mean()), 6),
        }
        for name, method in methods.items():
            results[name][str(length)] = evaluate(method, windows, kin, truth, cfg)
    latency = None
    ours = methods.get("ours")
    if ours is not None and ours.latency is not None and first_window is not None:
        latency = ours.latency(first_window)
    return {
        "benchmark": "inbetween",
        "methods": list(methods),
        "lengths": list(cfg.lengths),
        "seed": cfg.seed,
        "fps": FPS,
        "context_frames": CONTEXT_FRAMES,
        "windows": counts,
        "results": results,
        "ground_truth": reference,
        "latency_ms": latency,
        "latency_protocol": {
            "plan_frames": LATENCY_PLAN_FRAMES,
            "threads": 1,
            "repetitions": cfg.latency_repeats,
            "warmup": cfg.latency_warmup,
        },
        "diversity_protocol": {"windows": cfg.diversity_windows, "seeds": cfg.diversity_seeds},
        "wall_seconds": round(time.perf_counter() - started, 3),
    }


def load_test_clips(path: Path, split: str = "test", only: tuple[str, ...] = ()) -> Sequence[Clip]:
    if not Path(path).exists():
        raise ConfigError(f"no motion data at {path}; pass --data with a recorded dataset folder")
    if split not in ("test", "val", "all"):
        raise ConfigError(f"the benchmark runs on held-out clips: split 'test', 'val' or 'all' (with --only), got '{split}'")
    if split == "all" and not only:
        raise ConfigError("--split all scores clips a model may have trained on; give --only with the style it was trained without")
    from controller.motion_data import styles  # noqa: PLC0415
    from controller.motion_data.dataset import load_dataset  # noqa: PLC0415 - written beside this benchmark

    clips = list(load_dataset(Path(path), split=None if split == "all" else split))
    if only:
        missing = styles.unmatched([c.name for c in clips], only)
        if missing:
            known = ", ".join(styles.folder_prefixes(c.name for c in clips))
            which = "" if split == "all" else f"{split} "
            raise ConfigError(f"--only {','.join(missing)} matches no {which}clip in {path}; its clips' folders: {known}")
        clips = [c for c in clips if styles.matches(c.name, only)]
    if not clips:
        raise ConfigError(f"no {split} clips in {path}; the benchmark runs on held-out clips only")
    return clips


def run_inbetween_bench(cfg: InbetweenConfig) -> dict[str, Any]:
    """Load the test clips and the G1 kinematics, run every method, return the JSON report."""
    validate(cfg)
    clips = load_test_clips(cfg.data, cfg.split, cfg.only)
    from controller.assets import ensure_assets  # noqa: PLC0415 - MuJoCo only for this command
    from sim.kinematics import G1Kinematics  # noqa: PLC0415

    kin = G1Kinematics(ensure_assets(cfg.assets_dir, quiet=True).g1_mjcf)
    report = run_on_clips(clips, cfg, kin)
    return {
        "benchmark": "inbetween",
        "data": str(cfg.data),
        "split": cfg.split,
        "only": list(cfg.only),
        "clips": len(clips),
        "temperature": cfg.temperature,
        "residual_gain": cfg.residual_gain,
        **report,
    }


def format_table(report: dict[str, Any]) -> str:
    """The report's results as a readable table: one block per length, one row per method."""
    width = 12
    header = f"{'method':<10}" + "".join(f"{label:>{width}}" for _, label in TABLE_COLUMNS)
    source = f"{report.get('data', '')}, {report.get('split', 'test')} split"
    if report.get("only"):
        source += f", only {','.join(report['only'])}"
    lines = [f"in-betweening benchmark: {source} (seed {report['seed']}, {report['fps']:g} fps)"]
    for length in report["lengths"]:
        key = str(length)
        lines += ["", f"transition {length} frames, {report['windows'][key]} windows", header]
        for name in report["methods"]:
            row = report["results"][name][key]
            lines.append(f"{name:<10}" + "".join(f"{row[metric]:>{width}.4f}" for metric, _ in TABLE_COLUMNS))
        gt = report["ground_truth"][key]
        cells = {key: gt[key] for key in ("foot_skate", "joint_jitter", "root_jitter", "wild_share", "beyond_limits_share")}
        lines.append(f"{'truth':<10}" + "".join(f"{cells[m]:>{width}.4f}" if m in cells else f"{'':>{width}}" for m, _ in TABLE_COLUMNS))
    if report.get("latency_ms"):
        lat = report["latency_ms"]
        lines += ["", f"ours latency, one {LATENCY_PLAN_FRAMES}-frame plan, 1 thread: p50 {lat['p50']:.3f} ms, p99 {lat['p99']:.3f} ms"]
    return "\n".join(lines)
