"""`g1ctl bench gestures`: the arm gesture detector's recall and precision per gesture, on labelled executed motion.

Usage:
    g1ctl bench gestures --data PATH [--data PATH ...] [--report PATH]
    g1ctl bench gestures --run-prompts DIR --seed S [--policy fastsac]

Two kinds of labelled executed motion, both from the simulated G1 (`--data` takes either kind of folder):
- a recorded motion dataset (`g1ctl dataset record`, labels per frame): every stretch where one
  gesture label holds for 2 s or more, 0.5 s cut at each end (the blends in and out), is a sample
  asking for that gesture (the dataset's "wave" is wave_right, "none" asks for nothing);
- executed clauses (`--run-prompts DIR`): the prompts of `PROMPTS` planned and run on the simulator
  as `g1ctl plan PROMPT --sim` runs them; each clause's executed frames, whole (as the text report
  judges them), are a sample asking for the clause's gestures.

A sample's detected names are compared with those it asks for: per gesture name, recall (asked and
detected) and precision (detected and asked); per label (the asked names joined by "+", or "none"),
the share of samples whose detected set is exactly the asked one. A name detected but not asked is
a false positive, whatever else was asked. The labels say what was asked, not what the robot did: a
clause the robot got wrong counts against the detector (the `wrong` list names each sample to look
at). Train and test are told apart by seed: record each with its own seed and pass each folder on
its own (every clip of a dataset counts, whatever its split).
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from controller.motion_data.dataset import load_dataset
from controller.text.program import GESTURE_NAMES, LIBRARY_NAME
from hw.errors import ConfigError
from hw.types import FloatArray

Detect = Callable[[FloatArray, float], tuple[str, ...]]
# Prompts whose clauses together ask for every gesture, standing, walking, turning, on a curve, one and two
# arms at once, and for none while walking, turning and standing.
PROMPTS: tuple[str, ...] = (
    "raise your left arm for three seconds, then raise your right arm for three seconds, then raise both arms for three seconds",
    "wave with your left hand for three seconds, then wave with your right hand for three seconds, "
    "then wave with both hands for three seconds",
    "point for four seconds, then reach out for four seconds, then cross your arms for four seconds, "
    "then put your hands on your hips for four seconds",
    "walk forward two meters while pointing, then walk back two meters while reaching out",
    "walk forward one meter with your arms crossed, then turn left 90 degrees with your hands on your hips",
    "walk forward two meters, then turn right 90 degrees, then stand still for three seconds",
    "wave with your left hand while pointing for four seconds",
    "raise your left arm while reaching out for four seconds",
    "walk forward one meter while waving, then turn left while raising both arms",
    "walk in a circle with a radius of one meter while waving with your left hand",
    "step to the left one meter with your hands on your hips, then walk backward one meter with your arms crossed",
    "point for three seconds, then wave with your right hand for three seconds, then reach out for three seconds, "
    "then raise your right arm for three seconds",
)
SEGMENT_MIN_S = 2.0  # a dataset stretch with one label counts when it lasts this long ...
SEGMENT_TRIM_S = 0.5  # ... less the blends in and out (the dataset's 0.5 s) at each end


@dataclass(frozen=True)
class Sample:
    """Executed G1 motion `qpos` [T, 36] at `fps` that asks for the gestures `asked` (detector names); `source` says where from."""

    source: str
    asked: tuple[str, ...]
    qpos: FloatArray
    fps: float

    @property
    def label(self) -> str:
        return "+".join(self.asked) or "none"


def dataset_samples(path: Path, split: str | None = None, min_s: float = SEGMENT_MIN_S, trim_s: float = SEGMENT_TRIM_S) -> list[Sample]:
    """The stretches of a recorded dataset (`split`, None: every clip) where one gesture label holds for `min_s` or more, `trim_s`
    cut at each end."""
    names = json.loads((path / "manifest.json").read_text())["gestures"]
    detector_name = {library: name for name, library in LIBRARY_NAME.items()}
    out = []
    for clip in load_dataset(path, split=split):
        if clip.gesture is None:
            raise ConfigError(f"{path}: clip {clip.name} has no gesture labels; record the dataset with `g1ctl dataset record`")
        change = np.flatnonzero(np.diff(clip.gesture)) + 1
        for start, stop in zip(np.r_[0, change], np.r_[change, clip.frames], strict=True):
            if stop - start >= min_s * clip.fps:
                label = names[clip.gesture[start]]
                trim = round(trim_s * clip.fps)
                asked = () if label == "none" else (detector_name.get(label, label),)
                out.append(Sample(f"{path.name}/{clip.name}@{start}", asked, clip.qpos[start + trim : stop - trim], clip.fps))
    return out


def save_clause(file: Path, qpos: FloatArray, fps: float, gestures: Sequence[str], text: str) -> None:
    """Keep one executed clause: its frames `qpos` [T, 36] at `fps`, the gestures it asked for, its text."""
    np.savez_compressed(file, qpos=np.asarray(qpos, dtype=np.float32), fps=fps, gestures=json.dumps(list(gestures)), text=text)


def clause_samples(path: Path) -> list[Sample]:
    """The executed clauses kept by `save_clause` in the folder `path`."""
    out = []
    for file in sorted(path.glob("*.npz")):
        with np.load(file) as f:
            asked = tuple(json.loads(str(f["gestures"])))
            out.append(Sample(f"{path.name}/{file.stem}: {f['text']}", asked, np.asarray(f["qpos"], dtype=np.float64), float(f["fps"])))
    return out


def load_samples(path: Path) -> list[Sample]:
    """Samples of a recorded dataset (a folder with manifest.json) or of a folder of executed clauses (*.npz)."""
    if not path.is_dir():
        raise ConfigError(f"{path}: no such folder; make one with `g1ctl dataset record` or `g1ctl bench gestures --run-prompts`")
    if (path / "manifest.json").is_file():
        return dataset_samples(path)
    if any(path.glob("*.npz")):
        return clause_samples(path)
    raise ConfigError(f"{path}: neither a recorded dataset (manifest.json) nor executed clauses (*.npz from --run-prompts)")


def record_clauses(
    prompts: Sequence[str], out: Path, seed: int, policy: str = "fastsac", progress: Callable[[str], None] | None = None
) -> int:
    """Plan and run each prompt on the simulator (seed `seed`), as `g1ctl plan --sim` does; keep each clause's executed frames and
    asked gestures in `out` (one .npz per clause). Returns the number of clauses kept."""
    from controller.text.gesture_detector import detect_gestures  # noqa: PLC0415
    from controller.text.job import TextSimConfig, run_text_sim  # noqa: PLC0415 - imports the runtime
    from controller.text.service import TextPlanner  # noqa: PLC0415

    out.mkdir(parents=True, exist_ok=True)
    planner = TextPlanner.load()
    kept = 0
    for p, prompt in enumerate(prompts):
        program = planner.resolve(prompt)
        executed: list[tuple[FloatArray, float]] = []

        def keep(qpos: FloatArray, fps: float, executed: list[tuple[FloatArray, float]] = executed) -> tuple[str, ...]:
            executed.append((np.asarray(qpos), fps))
            return detect_gestures(qpos, fps)

        report = run_text_sim(program, TextSimConfig(policy=policy, seed=seed), planner.encoder.embed, keep, planner.text_embedding())
        for c, ((qpos, fps), clause) in enumerate(zip(executed, report["clauses"], strict=True)):
            save_clause(out / f"seed{seed}-prompt{p:02d}-clause{c}.npz", qpos, fps, clause["goal"]["gestures"], clause["text"])
            kept += 1
            if progress is not None:
                progress(f"seed {seed} '{clause['text']}': asked {clause['goal']['gestures']}, detected {clause['gestures']}")
    return kept


def score(samples: Iterable[Sample], detect: Detect, names: Sequence[str] = GESTURE_NAMES) -> dict[str, Any]:
    """Per gesture name: samples asking for it, recall, precision, false positives; per label: samples and exact-set share."""
    asked_n, hit, detected_n = Counter[str](), Counter[str](), Counter[str]()
    label_n, label_exact = Counter[str](), Counter[str]()
    wrong = []
    for sample in samples:
        found = set(detect(sample.qpos, sample.fps))
        asked = set(sample.asked)
        asked_n.update(asked)
        hit.update(asked & found)
        detected_n.update(found)
        label_n[sample.label] += 1
        label_exact[sample.label] += found == asked
        if found != asked:
            wrong.append({"source": sample.source, "asked": sorted(asked), "detected": sorted(found)})
    per_name = {
        name: {
            "asked": asked_n[name],
            "recall": round(hit[name] / asked_n[name], 3) if asked_n[name] else None,
            "precision": round(hit[name] / detected_n[name], 3) if detected_n[name] else None,
            "false_positives": detected_n[name] - hit[name],
        }
        for name in names
    }
    per_label = {label: {"samples": label_n[label], "exact": round(label_exact[label] / label_n[label], 3)} for label in sorted(label_n)}
    return {"samples": sum(label_n.values()), "per_name": per_name, "per_label": per_label, "wrong": wrong}


def format_table(report: dict[str, Any]) -> str:
    """The per-name and per-label figures as a text table."""
    lines = [f"{'gesture':15s} {'asked':>5s}  recall  precision  false positives"]
    for name, r in report["per_name"].items():
        recall = "-" if r["recall"] is None else f"{r['recall']:.3f}"
        precision = "-" if r["precision"] is None else f"{r['precision']:.3f}"
        lines.append(f"{name:15s} {r['asked']:5d}  {recall:6s}  {precision:9s}  {r['false_positives']}")
    lines.append(f"{'label':24s} {'n':>4s}  exact set")
    lines += [f"{label:24s} {r['samples']:4d}  {r['exact']:.3f}" for label, r in report["per_label"].items()]
    lines += [f"wrong: {w['source']}: asked {w['asked']}, detected {w['detected']}" for w in report["wrong"]]
    return "\n".join(lines)


def run_gesture_bench(paths: Sequence[Path], detect: Detect) -> dict[str, Any]:
    """`score` over the samples of every folder in `paths`, with the number of samples each folder gave."""
    loaded = {str(path): load_samples(path) for path in paths}
    report = score((s for samples in loaded.values() for s in samples), detect)
    report["data"] = {path: len(samples) for path, samples in loaded.items()}
    return report
