"""The text planner as one object: the sentence encoder loaded once, prompts resolved, programs run.

What `g1ctl plan` and `g1ctl bench text` share: resolution (`resolve`), the printable
decomposition (`describe`), a run with its report (`simulate`: on the simulator, through simulated
hardware, or on a real G1),
and the composed plan's transition score on paper (`composed_transition`). The planner's
text slot gets each clause's sentence embedding when the shipped planner was trained with
text (`text_conditioned` in its spec) and the caller asks for it (`condition_text`).

Off by default (`--text` turns it on), since 2026-12-02. Measured with `g1ctl bench text --text-slot`:
the clause text moves a composed plan about as much as another sampling seed does, and what it adds
is what the prompt did not ask for: in "walk an arc ..., then walk straight ahead one metre" the
planner raised the right arm for a second during the straight walk (the training captions' arm
motion), a gesture the per-clause checks count as unasked; without the text, none (both before the
free arms were held in every clause). The figures are in docs/text-planning.md ("The text slot").
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from controller.text.encoder import SentenceEncoder, shared_encoder
from controller.text.executor import TextRunConfig
from controller.text.gesture_detector import detect_gestures
from controller.text.program import Program
from controller.text.resolve import describe_program, plan_program
from hw.errors import ConfigError

if TYPE_CHECKING:
    from controller.runtime.backend_registry import BackendChoice


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

    def text_embedding(self, asked: bool | None = None) -> Any:
        """Clause text -> the planner's text conditioning; None unless asked for (`asked`, default `condition_text`).
        Asked for with a shipped planner trained without text, it refuses (ConfigError) rather than plan without it."""
        if not (self.condition_text if asked is None else asked):
            return None
        import json  # noqa: PLC0415

        from hw.shipped import model_dir  # noqa: PLC0415

        spec = json.loads((model_dir("planner") / "planner.json").read_text())
        if not spec.get("text_conditioned"):
            raise ConfigError(
                "the shipped planner was trained without text (models/planner/planner.json: text_conditioned false), so a "
                "clause's text cannot condition it; leave out --text (models/planner/MODEL_CARD.md says why the slot was dropped)"
            )
        return self.encoder.embed_one

    def simulate(
        self, program: Program, seed: int = 0, policy: str = "fastsac", video: Path | None = None, report: Path | None = None,
        blend: bool = True, progress: bool = False, hardware: BackendChoice | None = None, status: bool = False,
        record: Path | None = None, max_corrections: int = 1,
    ) -> dict[str, Any]:  # fmt: skip
        """Run `program` on the simulated G1 (through `hardware` when given: its config as `choose_backend` loaded it, or on
        the real G1 it names): the text report, with the run's report under "run"."""
        from controller.text.job import TextSimConfig, run_text_sim  # noqa: PLC0415

        cfg = TextSimConfig(
            policy=policy, seed=seed, video=video, report=report, progress=progress, hardware=hardware, status=status, record=record
        )
        cfg = replace(cfg, run=replace(cfg.run, max_corrections=max_corrections))
        if not blend:
            cfg = replace(cfg, run=replace(cfg.run, blend_frames=None))
        return run_text_sim(program, cfg, self.encoder.embed, detect_gestures, self.text_embedding())

    def composed_transition(self, program: Program, blend_frames: int | None, seed: int = 0, continue_motion: bool = True) -> float | None:
        """The transition score of the composed plan alone (an ideal robot: the root moves as commanded): blended, the crossfade
        baseline (`continue_motion` False) or naive (`blend_frames` None)."""
        from controller.planner.runtime import Planner  # noqa: PLC0415
        from controller.text.job import composed_transition_score  # noqa: PLC0415

        if self._planner is None:
            self._planner = Planner.load()
            self._planner.warm_up()
        return composed_transition_score(
            program, self._planner.plan, blend_frames, seed, self.text_embedding(), continue_motion=continue_motion
        )

    def composed_frames(self, program: Program, seed: int = 0, text: bool = True) -> Any:
        """The reference frames [T, 36] of `program` composed on paper with blended joins, with each clause's text in the
        planner's text slot or with none (for measuring what the text slot changes)."""
        from controller.planner.runtime import Planner  # noqa: PLC0415
        from controller.text.job import composed_frames  # noqa: PLC0415

        if self._planner is None:
            self._planner = Planner.load()
            self._planner.warm_up()
        blend = TextRunConfig().blend_frames
        return composed_frames(program, self._planner.plan, blend, seed, self.text_embedding(asked=text))[0]
