"""The caption benchmark on synthetic clips with the real G1 kinematics and a fake text-following planner."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from controller.assets import Assets
from controller.bench import captions as bc
from controller.planner.request import CONTEXT_FRAMES, FPS, PlanRequest
from hw import g1, quat
from hw.errors import ConfigError
from sim.kinematics import G1Kinematics
from tests.conftest import fake_embed


@dataclass(frozen=True)
class Clip:
    name: str
    qpos: np.ndarray
    captions: tuple[tuple[int, str], ...]


class FollowsWalkForward:
    """Walks forward 0.5 m/s when its text is 'walk forward''s embedding, stands otherwise; seeds add a little noise."""

    text_conditioned = True

    def __init__(self) -> None:
        self.forward = fake_embed(["walk forward"])[0]

    def sample(self, request: PlanRequest, seeds: list[int]) -> tuple[np.ndarray, np.ndarray]:
        length = request.plan_length()
        last = request.context[-1]
        plans = np.tile(last, (len(seeds), length, 1))
        yaw = float(quat.heading(last[g1.QPOS_ROOT_QUAT]))
        if request.text_embedding is not None and np.allclose(request.text_embedding, self.forward):
            steps = 0.5 * np.arange(1, length + 1) / FPS
            plans[:, :, 0] += steps * np.cos(yaw)
            plans[:, :, 1] += steps * np.sin(yaw)
        for i, seed in enumerate(seeds):
            plans[i, :, 7:] += 0.001 * np.random.default_rng(seed).standard_normal(g1.NUM_JOINTS)
        return plans, np.zeros((len(seeds), length, 2), dtype=bool)


@pytest.fixture(scope="module")
def kin(assets: Assets) -> G1Kinematics:
    return G1Kinematics(assets.g1_mjcf)


def _walk_clip(name: str, frames: int) -> Clip:
    t = np.arange(frames) / FPS
    qpos = np.tile(g1.standing_qpos(), (frames, 1))
    qpos[:, 0] = 0.5 * t
    return Clip(name, qpos, ((0, "walk forward"),))


def test_a_caption_that_moves_the_plan_is_measured(kin: G1Kinematics) -> None:
    cfg = bc.CaptionConfig(seeds=2, windows=8, length=24, captions=(None, "walk forward", "turn left in place"))
    standing = Clip("b", np.tile(g1.standing_qpos(), (90, 1)), ((0, "stand still"),))
    clips = [_walk_clip("a", 120), standing]
    report = bc.run_on(FollowsWalkForward(), fake_embed, kin, cfg, clips)
    from_standing = report["standing"]
    assert from_standing["none"]["change_vs_none_m"] == 0.0 and abs(from_standing["none"]["forward_m"]) < 1e-9
    walk = from_standing["walk forward"]
    assert walk["forward_m"] == pytest.approx(0.5 * 24 / FPS, abs=1e-3)
    assert abs(walk["left_m"]) < 1e-6 and abs(walk["heading_deg"]) < 1e-6
    assert walk["change_vs_none_m"] > 0.1 > from_standing["turn left in place"]["change_vs_none_m"]
    assert report["test_contexts_count"] == 8
    windows = report["captioned_windows"]
    assert windows["windows"] == 8 and windows["transition_frames"] == 23 and windows["distinct_captions"] == 2
    l2p = windows["l2p_m"]["free"]
    assert l2p["true"] < 0.01 < l2p["none"] < l2p["wrong"]  # the true caption brings the plan to the truth, a wrong one away
    assert 0 < windows["true_beats_none_share"]["free"] < 1  # standing windows: no text already stands
    assert "walk forward" in bc.format_table(report)


def test_plan_motion_is_in_the_heading_frame_of_the_context() -> None:
    last = np.array(g1.standing_qpos(), dtype=float)
    last[g1.QPOS_ROOT_QUAT] = quat.from_yaw(np.pi / 2)  # facing +y
    plans = np.tile(last, (1, 10, 1))
    plans[0, :, 1] += 1.0  # moved 1 m along +y: forward for this robot
    plans[0, -1, g1.QPOS_ROOT_QUAT] = quat.from_yaw(np.pi / 2 + 0.5)
    motion = bc.plan_motion(plans, last)
    assert motion["forward_m"][0] == pytest.approx(1.0) and motion["left_m"][0] == pytest.approx(0.0, abs=1e-9)
    assert motion["heading_deg"][0] == pytest.approx(np.rad2deg(0.5))


def test_bad_settings_are_named() -> None:
    with pytest.raises(ConfigError, match="--length 30 is not a plan length"):
        bc.validate(bc.CaptionConfig(length=30))
    with pytest.raises(ConfigError, match="must include no text"):
        bc.validate(bc.CaptionConfig(captions=("walk forward",)))
    assert CONTEXT_FRAMES == 4


def test_the_shipped_planner_without_text_has_no_caption_to_measure(capsys: pytest.CaptureFixture[str]) -> None:
    from controller.cli.main import main

    assert main(["bench", "caption", "--seeds", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "trained without text" in err and "--model" in err and len(err.splitlines()) == 1
