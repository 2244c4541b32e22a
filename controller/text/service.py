"""The text planner as one object: the sentence encoder loaded once, prompts resolved, programs run.

What `g1ctl plan` and `g1ctl bench text` share: resolution (`resolve`), the printable
decomposition (`describe`), a simulated run with its report (`simulate`, imports MuJoCo),
and the composed plan's transition score on paper (`composed_transition`). The planner's
text slot gets each clause's sentence embedding when the shipped planner was trained with
text (`text_conditioned` in its spec) and the caller asks for it (`condition_text`).

Off by default, measured: with each clause's text in the slot, the arms the prompt leaves free
picked up gestures from the training captions ("turn around" raised the right arm and the turn
timed out; the detector saw wave_right where wave_both was asked; the prompt's transition
score went from 0.20 to 9.97); `g1ctl bench text` passed 58 of 59 prompts against 59 without.
The decoupled tracker executes the planned arms, so an unasked-for arm motion is executed.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from controller.text.encoder import SentenceEncoder, shared_encoder
from controller.text.gesture_detector import detect_gestures
from controller.text.program import Program
from controller.text.resolve import describe_program, plan_program


class TextPlanner:
    def __init__(self, encoder: SentenceEncoder, condition_text: bool = False) -> None:
        self.encoder = encoder
        self.condition_text = condition_text
        self._planner: Any = None

    @classmethod
    def load(cls, condition_text: bool = False) -> TextPlanner:
        return cls(shared_encoder(), condition_text)

    def resolve(self, prompt: str) -> Program:
        """The program of `prompt`, or `PromptRefused` naming what cannot be planned."""
        return plan_program(prompt, self.encoder)

    def describe(self, program: Program) -> str:
        return describe_program(program)

    def text_embedding(self) -> Any:
        """Clause text -> the planner's text conditioning; None unless asked for and the shipped planner was trained with text."""
        if not self.condition_text:
            return None
        import json  # noqa: PLC0415

        from hw.shipped import model_dir  # noqa: PLC0415

        spec = json.loads((model_dir("planner") / "planner.json").read_text())
        return self.encoder.embed_one if spec.get("text_conditioned") else None

    def simulate(
        self, program: Program, seed: int = 0, policy: str = "fastsac", video: Path | None = None, report: Path | None = None,
        blend: bool = True, progress: bool = False,
    ) -> dict[str, Any]:  # fmt: skip
        """Run `program` on the simulated G1: the text report, with the run's report under "run"."""
        from controller.text.job import TextSimConfig, run_text_sim  # noqa: PLC0415 - imports MuJoCo

        cfg = TextSimConfig(policy=policy, seed=seed, video=video, report=report, progress=progress)
        if not blend:
            cfg = replace(cfg, run=replace(cfg.run, blend_frames=None))
        return run_text_sim(program, cfg, self.encoder.embed, detect_gestures, self.text_embedding())

    def composed_transition(self, program: Program, blend_frames: int | None, seed: int = 0) -> float | None:
        """The transition score of the composed plan alone (an ideal robot: the root moves as commanded), blended or naive (None)."""
        from controller.planner.runtime import Planner  # noqa: PLC0415
        from controller.text.job import composed_transition_score  # noqa: PLC0415

        if self._planner is None:
            self._planner = Planner.load()
            self._planner.warm_up()
        return composed_transition_score(program, self._planner.plan, blend_frames, seed, self.text_embedding())
