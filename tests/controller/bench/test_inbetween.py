"""The in-betweening benchmark harness on synthetic clips with the real G1 kinematics (baselines, a fake planner)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from controller.assets import Assets
from controller.bench import baselines
from controller.bench import inbetween as bi
from controller.cli.main import main
from controller.planner.plausibility import JOINT_LOWER, JOINT_UPPER
from controller.planner.request import FPS
from hw import g1, quat
from hw.errors import ConfigError
from sim.kinematics import G1Kinematics


@dataclass(frozen=True)
class Clip:
    name: str
    qpos: np.ndarray


def uniform_clip(name: str, frames: int, yaw_rate: float = 0.3) -> Clip:
    """Walking-like motion that is linear in time: constant root velocity, yaw rate and joint rates."""
    t = np.arange(frames) / FPS
    qpos = np.zeros((frames, g1.QPOS_SIZE))
    qpos[:, 0], qpos[:, 1], qpos[:, 2] = 0.5 * t, 0.1 * t, g1.STANDING_PELVIS_HEIGHT
    qpos[:, 3], qpos[:, 6] = np.cos(yaw_rate * t / 2), np.sin(yaw_rate * t / 2)
    qpos[:, 7:] = np.array(g1.default_joint_vector()) + 0.05 * t[:, None]
    return Clip(name, qpos)


def swaying_clip(name: str, frames: int) -> Clip:
    """Motion that baselines cannot reproduce: swaying joints and a weaving root."""
    clip = uniform_clip(name, frames)
    t = np.arange(frames) / FPS
    qpos = clip.qpos.copy()
    qpos[:, 1] += 0.1 * np.sin(2 * np.pi * 0.7 * t)
    qpos[:, 7:] += 0.3 * np.sin(2 * np.pi * 1.1 * t[:, None] + np.arange(g1.NUM_JOINTS))
    qpos[:, 7:] = np.clip(qpos[:, 7:], JOINT_LOWER, JOINT_UPPER)  # a pose the planner takes as a keyframe
    return Clip(name, qpos)


@pytest.fixture(scope="module")
def kin(assets: Assets) -> G1Kinematics:
    return G1Kinematics(assets.g1_mjcf)


def cfg(**kwargs: object) -> bi.InbetweenConfig:
    base: dict[str, object] = {"data": Path("unused"), "methods": ("interp", "hermite", "zerovel"), "lengths": (5, 12), "windows": 8}
    base.update(kwargs)
    return bi.InbetweenConfig(**base)  # type: ignore[arg-type]


def test_windows_are_seeded_distinct_and_fit_their_clips() -> None:
    clips = [uniform_clip("a", 40), uniform_clip("b", 15), uniform_clip("c", 60)]
    windows = bi.draw_windows(clips, 12, 30, seed=3)
    assert len(windows) == 30
    assert len({(w.clip, w.start) for w in windows}) == 30
    assert "b" not in {w.clip for w in windows}  # 4 + 12 + 2 frames do not fit in 15
    for w in windows:
        clip = next(c for c in clips if c.name == w.clip)
        np.testing.assert_array_equal(w.frames, clip.qpos[w.start : w.start + 18])
        np.testing.assert_array_equal(w.target, clip.qpos[w.start + 16])
        assert w.context.shape == (4, 36) and w.transition.shape == (12, 36)
    again = bi.draw_windows(clips, 12, 30, seed=3)
    assert [(w.clip, w.start) for w in again] == [(w.clip, w.start) for w in windows]
    assert [(w.clip, w.start) for w in bi.draw_windows(clips, 12, 30, seed=4)] != [(w.clip, w.start) for w in windows]
    assert len(bi.draw_windows(clips, 12, 10_000, seed=0)) == (40 - 17) + (60 - 17)  # every window, once
    with pytest.raises(ConfigError, match="long enough"):
        bi.draw_windows(clips, 80, 5, seed=0)


def test_baselines_on_uniform_motion(kin: G1Kinematics) -> None:
    report = bi.run_on_clips([uniform_clip("walk", 90), uniform_clip("turn", 70, yaw_rate=-0.5)], cfg(), kin)
    assert report["windows"] == {"5": 8, "12": 8}
    assert set(report["results"]) == {"interp", "hermite", "zerovel"}
    assert report["latency_ms"] is None
    for length in ("5", "12"):
        for name in ("interp", "hermite"):
            row = report["results"][name][length]
            assert row["l2p"] < 1e-6 and row["l2q"] < 1e-6 and row["npss"] < 1e-6  # linear motion is reproduced exactly
            assert row["tgt_keyframe_err"] < 1e-6 and row["tgt_root_err"] < 1e-6 and row["reach_success"] == 1.0
            assert row["diversity"] == 0.0
        held = report["results"]["zerovel"][length]
        assert held["l2p"] > 0.05 and held["tgt_root_err"] > 0.1 and held["reach_success"] == 0.0
        assert held["root_jitter"] > report["results"]["interp"][length]["root_jitter"]  # the jump onto the target
        assert set(held) == {
            "l2p", "l2q", "npss", "foot_skate", "joint_jitter", "root_jitter", "wild_share", "beyond_limits_share",
            "tgt_keyframe_err", "tgt_root_err", "reach_success", "diversity",
        }  # fmt: skip
        assert held["wild_share"] == 0.0 and held["beyond_limits_share"] == 0.0  # walking upright, joints near the default pose
    table = bi.format_table(report)
    assert "hermite" in table and "transition 12 frames, 8 windows" in table
    json.dumps(report)


def test_a_stochastic_method_gets_diversity_and_latency(kin: G1Kinematics, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[str, int]] = []

    def fake_ours(config: bi.InbetweenConfig) -> bi.Method:
        def predict(w: bi.Window, seed: int) -> np.ndarray:
            seen.append((w.clip, w.start))
            out = np.vstack((baselines.interp(w.context, w.target, w.length), w.target))
            out[: w.length, 7:] += 0.01 * np.random.default_rng(seed).standard_normal((w.length, g1.NUM_JOINTS))
            return out

        return bi.Method(predict, stochastic=True, latency=lambda w: {"p50": 1.0, "p99": 2.0})

    monkeypatch.setitem(bi.METHODS, "ours", fake_ours)
    report = bi.run_on_clips([swaying_clip("sway", 120)], cfg(methods=("ours", "interp"), lengths=(10,), diversity_windows=3), kin)
    assert report["latency_ms"] == {"p50": 1.0, "p99": 2.0}
    row = report["results"]["ours"]["10"]
    assert row["diversity"] > 0 and report["results"]["interp"]["10"]["diversity"] == 0
    assert row["tgt_keyframe_err"] < 1e-6 and row["reach_success"] == 1.0
    assert len(seen) == 8 + 3 * 10  # every window once, then 10 seeds on the first 3
    assert report["results"]["interp"]["10"]["l2p"] > 0.01  # the swaying is not linear
    assert "ours latency" in bi.format_table(report)


def test_plausibility_counts_wild_frames_and_joints_beyond_the_limits(kin: G1Kinematics, monkeypatch: pytest.MonkeyPatch) -> None:
    knee = g1.joint_indices(["left_knee_joint"], qpos=True)[0]

    def implausible(config: bi.InbetweenConfig) -> bi.Method:
        def predict(w: bi.Window, seed: int) -> np.ndarray:
            out = np.vstack((baselines.interp(w.context, w.target, w.length), w.target))
            out[2:4, knee] = 3.2  # two joint values beyond the limits
            out[5, g1.QPOS_ROOT_QUAT] = quat.from_axis_angle([1.0, 0.0, 0.0], np.radians(80.0))  # one frame tilted past the data
            out[-1, knee] = 3.2  # the frame at the target is not the transition's
            return out

        return bi.Method(predict)

    monkeypatch.setitem(bi.METHODS, "ours", implausible)
    report = bi.run_on_clips([uniform_clip("walk", 90)], cfg(methods=("ours", "interp"), lengths=(10,)), kin)
    row = report["results"]["ours"]["10"]
    assert row["wild_share"] == pytest.approx(1 / 10)
    assert row["beyond_limits_share"] == round(2 / (10 * g1.NUM_JOINTS), 6)  # rounded as reported
    assert report["results"]["interp"]["10"]["wild_share"] == 0.0
    assert report["ground_truth"]["10"]["wild_share"] == 0.0 and report["ground_truth"]["10"]["beyond_limits_share"] == 0.0
    assert "beyond lim" in bi.format_table(report)


def test_method_and_length_parsing() -> None:
    assert bi.parse_methods("interp, zerovel,interp") == ("interp", "zerovel")
    with pytest.raises(ConfigError, match="valid methods: ours, interp, hermite, zerovel"):
        bi.parse_methods("interp,slerp")
    assert bi.parse_lengths("15,30") == (15, 30)
    for bad in ("0", "a,b", ""):
        with pytest.raises(ConfigError):
            bi.parse_lengths(bad)
    assert [bi.plan_length(n) for n in (1, 15, 30, 31, 45, 63)] == [24, 24, 32, 32, 48, 64]
    with pytest.raises(ConfigError, match="at most 64"):
        bi.validate(cfg(methods=("ours",), lengths=(64,)))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--methods", "interp"], "needs --data"),
        (["--data", "{missing}", "--methods", "interp"], "no motion data"),
        (["--data", "{tmp}", "--methods", "interp,magic"], "unknown in-betweening method 'magic'"),
        (["--data", "{tmp}", "--methods", "interp", "--lengths", "0,15"], "at least 1 frame"),
        (["--data", "{tmp}", "--methods", "interp", "--windows", "0"], "at least 1"),
    ],
)
def test_cli_mistakes_are_one_line(args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [a.format(tmp=tmp_path, missing=tmp_path / "nope") for a in args]
    assert main(["bench", "inbetween", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("g1ctl: ") and message in err and "\n" not in err


def test_cli_runs_baselines_on_a_dataset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from controller.motion_data.dataset import MotionClip, save_dataset

    def clip(name: str, split: str) -> MotionClip:
        qpos = swaying_clip(name, 80).qpos
        return MotionClip(name, qpos, np.zeros((80, 2), dtype=bool), split)

    save_dataset(tmp_path / "data", [clip("train0", "train")], seed=0)
    assert main(["bench", "inbetween", "--data", str(tmp_path / "data"), "--methods", "interp"]) == 2
    assert "no test clips" in capsys.readouterr().err

    save_dataset(tmp_path / "data", [clip("train0", "train"), clip("test0", "test")], seed=0)
    report_path = tmp_path / "out" / "inbetween.json"
    argv = ["bench", "inbetween", "--data", str(tmp_path / "data"), "--methods", "interp,zerovel", "--lengths", "15", "--windows", "5"]
    assert main([*argv, "--report", str(report_path)]) == 0
    out = capsys.readouterr().out
    assert "interp" in out and "zerovel" in out and str(report_path) in out
    report = json.loads(report_path.read_text())
    assert report["windows"] == {"15": 5} and report["clips"] == 1 and report["data"] == str(tmp_path / "data")
    assert report["results"]["interp"]["15"]["reach_success"] == 1.0


def test_cli_scores_one_held_out_style_across_its_splits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from controller.motion_data.dataset import MotionClip, save_dataset

    clips = [
        MotionClip(name, swaying_clip(name, 80).qpos, np.zeros((80, 2), dtype=bool), split)
        for name, split in (("dance-a", "test"), ("bonus-b", "train"), ("bonus-c", "val"))
    ]
    save_dataset(tmp_path / "data", clips, seed=0)
    base = ["bench", "inbetween", "--data", str(tmp_path / "data"), "--methods", "interp", "--lengths", "15", "--windows", "500"]
    report_path = tmp_path / "bonus.json"
    assert main([*base, "--only", "bonus", "--split", "all", "--report", str(report_path)]) == 0
    report = json.loads(report_path.read_text())
    assert report["clips"] == 2 and report["only"] == ["bonus"] and report["windows"] == {"15": 2 * (80 - 4 - 15 - 2 + 1)}
    assert "only bonus" in capsys.readouterr().out
    assert main([*base, "--split", "all"]) == 2
    assert "give --only with the style it was trained without" in capsys.readouterr().err
    assert main([*base, "--only", "jazz", "--split", "all"]) == 2
    assert "--only jazz matches no clip in" in capsys.readouterr().err


def test_windows_whose_target_is_beyond_the_limits_are_not_drawn() -> None:
    """A recorded pose can pass a limit (MuJoCo's soft limits); the planner refuses it as a keyframe, so no window ends there."""
    clip = swaying_clip("a", 60)
    qpos = clip.qpos.copy()
    qpos[30:40, 7 + 3] = JOINT_UPPER[3] + 0.02  # the left knee 0.02 rad past its limit for 10 frames
    windows = bi.draw_windows([Clip("a", qpos)], length=5, count=1000, seed=0)
    targets = {w.start + 4 + 5 for w in windows}
    assert len(windows) == 60 - (4 + 5 + 2) + 1 - 10 and not targets & set(range(30, 40))
