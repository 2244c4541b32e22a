"""The planner's motion dataset: format, split rule, CSV import, recording in MuJoCo and the CLI."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from controller.commands.gestures import GESTURE_LABELS
from controller.motion_data.csv_import import read_csv_clip, resample_qpos
from controller.motion_data.dataset import (
    FPS,
    MotionClip,
    dataset_summary,
    episode_seed,
    load_dataset,
    name_seed,
    save_dataset,
    split_for_seed,
)
from hw import quat
from hw.errors import ConfigError
from hw.g1 import JOINT_NAMES, STANDING_PELVIS_HEIGHT, default_joint_vector
from tests.conftest import ROOT, g1ctl, one_line_error

if TYPE_CHECKING:
    from controller.eval.dataset_recorder import Recorder

# The g1-moves clips sit beside the repository (../shared/data/g1-moves), or where G1_MOVES_DIR says.
G1_MOVES = Path(os.environ.get("G1_MOVES_DIR", ROOT.parent / "shared" / "data" / "g1-moves"))


def standing_qpos(frames: int, yaw: float = 0.0) -> np.ndarray:
    q = np.zeros((frames, 36))
    q[:, 2] = STANDING_PELVIS_HEIGHT
    q[:, 3:7] = quat.from_yaw(yaw)
    q[:, 7:] = default_joint_vector()
    return q


def make_clip(name: str, frames: int = 20, split: str = "train", labels: bool = True) -> MotionClip:
    rng = np.random.default_rng(len(name))
    qpos = standing_qpos(frames)
    qpos[:, 0] = np.linspace(0.0, 1.0, frames)
    qpos[:, 7:] += rng.normal(0.0, 0.1, (frames, 29))
    return MotionClip(
        name=name,
        qpos=qpos,
        contacts=rng.random((frames, 2)) < 0.5,
        split=split,
        command=rng.normal(0.0, 0.3, (frames, 3)) if labels else None,
        gesture=rng.integers(0, len(GESTURE_LABELS), frames).astype(np.int16) if labels else None,
        captions=((0, "walk forward slowly"), (frames // 2, "turn left in place with hands on hips")) if labels else (),
        source="record" if labels else "csv:x.csv",
        seed=7,
    )


# --- split rule ----------------------------------------------------------------------------------


def test_split_follows_the_seed() -> None:
    assert [split_for_seed(s) for s in range(12)] == ["test", "val", *["train"] * 8, "test", "val"]
    assert [split_for_seed(episode_seed(3, i)) for i in (0, 1, 2, 10, 11, 19)] == ["test", "val", "train", "test", "val", "train"]
    assert episode_seed(3, 7) == 3007
    # a stable hash of the file name, the same on every machine and run
    assert name_seed("B_HandsUp.csv") == int.from_bytes(__import__("hashlib").sha256(b"B_HandsUp.csv").digest()[:4], "big")
    shares = [split_for_seed(name_seed(f"clip{i}.csv")) for i in range(2000)]
    assert 0.07 < shares.count("test") / 2000 < 0.13 and 0.07 < shares.count("val") / 2000 < 0.13


# --- save / load ---------------------------------------------------------------------------------


def test_save_load_round_trip(tmp_path: Path) -> None:
    clips = [make_clip("rec-1000", split="test"), make_clip("rec-1001", 31, "val"), make_clip("dance-a", 12, labels=False)]
    manifest_path = save_dataset(tmp_path / "ds", clips, seed=1, extra={"policy": "fastsac"})
    manifest = json.loads(manifest_path.read_text())
    assert manifest["version"] == 1 and manifest["fps"] == 30 and manifest["seed"] == 1 and manifest["policy"] == "fastsac"
    assert manifest["joint_names"] == list(JOINT_NAMES) and manifest["gestures"] == list(GESTURE_LABELS)
    assert "w,x,y,z" in manifest["qpos_layout"]
    assert manifest["clips"][1] == {"file": "rec-1001.npz", "name": "rec-1001", "split": "val", "frames": 31, "source": "record", "seed": 7}
    with np.load(tmp_path / "ds" / "rec-1000.npz") as z:
        assert z["qpos"].dtype == np.float32 and z["contacts"].dtype == np.uint8 and z["gesture"].dtype == np.int16

    loaded = load_dataset(tmp_path / "ds")
    assert [c.name for c in loaded] == ["rec-1000", "rec-1001", "dance-a"]
    for a, b in zip(clips, loaded, strict=True):
        np.testing.assert_allclose(b.qpos, a.qpos, atol=1e-6)
        assert b.qpos.dtype == np.float64
        np.testing.assert_array_equal(b.contacts, a.contacts)
        assert (b.split, b.source, b.seed, b.captions, b.fps) == (a.split, a.source, a.seed, a.captions, a.fps)
        if a.command is None:
            assert b.command is None and b.gesture is None
        else:
            assert b.command is not None and b.gesture is not None
            np.testing.assert_allclose(b.command, a.command, atol=1e-6)
            np.testing.assert_array_equal(b.gesture, a.gesture)
    assert [c.name for c in load_dataset(tmp_path / "ds" / "manifest.json", split="val")] == ["rec-1001"]
    assert [c.name for c in load_dataset(tmp_path / "ds", split="train")] == ["dance-a"]

    summary = dataset_summary(tmp_path / "ds")
    assert summary["clips"] == {"train": 1, "val": 1, "test": 1}
    assert summary["minutes"]["val"] == round(31 / 30 / 60, 2) and summary["frames"] == 63
    assert summary["sources"] == {"record": 2, "csv": 1}
    assert sum(summary["gesture_seconds"].values()) == pytest.approx(51 / 30, abs=0.2)

    # writing again replaces the dataset: shards of the old manifest that are gone are removed
    save_dataset(tmp_path / "ds", clips[:1], seed=2)
    assert sorted(p.name for p in (tmp_path / "ds").iterdir()) == ["manifest.json", "rec-1000.npz"]


def one_line(exc: pytest.ExceptionInfo[ConfigError]) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_load_errors_name_the_path(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as exc:
        load_dataset(tmp_path / "none")
    assert str(tmp_path / "none") in one_line(exc) and "no dataset manifest" in one_line(exc)
    save_dataset(tmp_path / "ds", [make_clip("a")], seed=0)
    manifest_path = tmp_path / "ds" / "manifest.json"
    good = json.loads(manifest_path.read_text())
    cases = [
        ("{not json", "not a valid JSON manifest"),
        (json.dumps({**good, "version": 2}), "unknown dataset version 2"),
        (json.dumps({**good, "joint_names": list(reversed(JOINT_NAMES))}), "joint_names differ"),
        (json.dumps({**good, "clips": [{"file": "a.npz"}]}), "'clips' must be a list"),
        (json.dumps({**good, "clips": [{**good["clips"][0], "split": "dev"}]}), "unknown split 'dev'"),
        (json.dumps({**good, "clips": [{**good["clips"][0], "file": "gone.npz"}]}), "cannot read the shard"),
    ]
    for text, message in cases:
        manifest_path.write_text(text)
        with pytest.raises(ConfigError) as exc:
            load_dataset(tmp_path / "ds")
        assert str(tmp_path / "ds") in one_line(exc) and message in one_line(exc), text
    with pytest.raises(ConfigError, match="unknown split 'dev'"):
        load_dataset(tmp_path / "ds", split="dev")


def test_clip_checks_its_shapes() -> None:
    with pytest.raises(ConfigError, match=r"qpos must be \[T, 36\]"):
        MotionClip("a", np.zeros((5, 35)), np.zeros((5, 2), bool), "train")
    with pytest.raises(ConfigError, match="contacts must be"):
        MotionClip("a", np.zeros((5, 36)), np.zeros((4, 2), bool), "train")
    with pytest.raises(ConfigError, match="unknown split"):
        MotionClip("a", np.zeros((5, 36)), np.zeros((5, 2), bool), "training")
    with pytest.raises(ConfigError, match="names may hold only"):
        MotionClip("../a", np.zeros((5, 36)), np.zeros((5, 2), bool), "train")
    with pytest.raises(ConfigError, match="gesture must be"):
        MotionClip("a", np.zeros((5, 36)), np.zeros((5, 2), bool), "train", gesture=np.full(5, 99, np.int16))


# --- CSV import ----------------------------------------------------------------------------------


def write_csv(path: Path, rows: np.ndarray) -> Path:
    path.write_text("\n".join(",".join(f"{v:.9f}" for v in row) for row in rows) + "\n")
    return path


def yaw_csv_rows(n: int, fps: float, yaw_rate: float = 1.0, flip_every_other: bool = True) -> np.ndarray:
    """Rows in the CSV layout (quaternion x,y,z,w) turning about z at `yaw_rate` and moving in x at 1 m/s."""
    t = np.arange(n) / fps
    rows = np.zeros((n, 36))
    rows[:, 0] = t
    rows[:, 2] = 0.8
    half = yaw_rate * t / 2
    rows[:, 3:7] = np.stack([np.zeros(n), np.zeros(n), np.sin(half), np.cos(half)], axis=1)
    if flip_every_other:
        rows[1::2, 3:7] *= -1.0  # the same rotations: the reader must make the signs continuous
    rows[:, 7:] = np.asarray(default_joint_vector()) + 0.5 * t[:, None]
    return rows


def test_csv_at_60_fps_is_resampled_to_30_with_wxyz_quaternions(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "turn.csv", yaw_csv_rows(61, 60.0))
    q = read_csv_clip(path, 60.0)
    assert q.shape == (31, 36)
    t = np.arange(31) / 30.0
    np.testing.assert_allclose(q[:, 0], t, atol=1e-8)
    np.testing.assert_allclose(q[:, 2], 0.8)
    np.testing.assert_allclose(q[:, 7:], np.asarray(default_joint_vector()) + 0.5 * t[:, None], atol=1e-8)
    expected = np.stack([np.cos(t / 2), np.zeros(31), np.zeros(31), np.sin(t / 2)], axis=1)  # w, x, y, z
    np.testing.assert_allclose(q[:, 3:7], expected, atol=1e-8)


def test_csv_resampling_between_frames_uses_slerp(tmp_path: Path) -> None:
    # 25 fps -> 30 fps: most output frames fall between input frames
    path = write_csv(tmp_path / "turn.csv", yaw_csv_rows(26, 25.0, yaw_rate=2.5))
    q = read_csv_clip(path, 25.0)
    assert q.shape == (31, 36)
    t = np.arange(31) / 30.0
    np.testing.assert_allclose(q[:, 0], t, atol=1e-8)
    np.testing.assert_allclose(q[:, 3], np.cos(2.5 * t / 2), atol=1e-8)  # slerp is exact for a constant turn
    np.testing.assert_allclose(q[:, 6], np.sin(2.5 * t / 2), atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(q[:, 3:7], axis=1), 1.0)


def test_resampling_keeps_the_span() -> None:
    frames = standing_qpos(3)
    assert resample_qpos(frames, 30.0).shape == (3, 36)
    assert resample_qpos(standing_qpos(101), 100.0).shape == (31, 36)


@pytest.mark.parametrize(
    ("text", "fps", "message"),
    [
        ("1,2,3\n4,5,6\n", 60.0, "line 1 has 3 columns, expected 36"),
        (",".join(["a"] * 36) + "\n", 60.0, "line 1 holds a non-numeric value 'a'"),
        ("\n".join([",".join(["0.5"] * 36), ",".join(["nan"] * 36)]), 60.0, "NaN or infinite values from data row 2"),
        (",".join(["0.5"] * 36), 60.0, "1 frame(s); a clip needs at least 2"),
        ("\n".join([",".join(["0.5"] * 36)] * 3), 0.0, "frame rate must be positive"),
        ("\n".join([",".join(["0"] * 36)] * 3), 60.0, "zero root quaternion"),
    ],
)
def test_bad_csv_is_one_clear_line(tmp_path: Path, text: str, fps: float, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ConfigError) as exc:
        read_csv_clip(path, fps)
    assert message in one_line(exc) and str(path) in one_line(exc)


@pytest.mark.skipif(not G1_MOVES.is_dir(), reason=f"g1-moves clips not at {G1_MOVES} (set G1_MOVES_DIR)")
def test_g1_moves_clips_import(tmp_path: Path) -> None:
    from controller.motion_data.csv_import import import_csv

    summary = import_csv(G1_MOVES / "bonus", tmp_path / "moves", fps=60.0)
    clips = load_dataset(tmp_path / "moves")
    assert summary["clips"] == len(clips) >= 1
    for clip in clips:
        src = G1_MOVES / "bonus" / clip.source.removeprefix("csv:")
        rows = sum(1 for line in src.read_text().splitlines() if line.strip())
        assert clip.frames == (rows - 1) // 2 + 1
        assert clip.split == split_for_seed(name_seed(src.name))
        np.testing.assert_allclose(np.linalg.norm(clip.qpos[:, 3:7], axis=1), 1.0, atol=1e-5)
        assert 0.5 < np.median(clip.qpos[:, 2]) < 0.95  # a standing G1's pelvis height
        assert clip.contacts.any(axis=1).mean() > 0.8  # dancing on the floor: mostly some foot down


# --- recording -----------------------------------------------------------------------------------


def test_command_programs_and_captions() -> None:
    from controller.commands.velocity import CommandLimits
    from controller.motion_data.command_programs import SEGMENT_SECONDS, command_program, with_gesture

    segments = command_program(np.random.default_rng(4), 300.0, CommandLimits())
    assert segments[0].kind == "stand" and segments[0].start == 0.0
    assert sum(s.duration for s in segments) == pytest.approx(300.0)
    assert all(SEGMENT_SECONDS[0] - 1e-9 <= s.duration <= SEGMENT_SECONDS[1] + SEGMENT_SECONDS[0] for s in segments)
    assert {s.kind for s in segments} == {"stand", "forward", "backward", "strafe", "turn", "walk_turn", "diagonal", "speed_change"}
    assert {s.gesture for s in segments} == set(range(len(GESTURE_LABELS)))
    for s in segments:
        vx, vy, yaw = s.cmd
        assert -0.6 <= vx <= 0.8 and abs(vy) <= 0.4 and abs(yaw) <= 0.8
    assert command_program(np.random.default_rng(4), 300.0, CommandLimits()) == segments
    assert with_gesture("walk forward slowly", GESTURE_LABELS.index("wave")) == "walk forward slowly while waving the right hand"
    assert with_gesture("stand still", GESTURE_LABELS.index("hands_on_hips")) == "stand still with hands on hips"
    assert with_gesture("walk forward while turning left", 1) == "walk forward while turning left and waving the right hand"


def test_gesture_blending_and_limits(g1_model: Any) -> None:
    from controller.commands.gestures import BLEND_S, UPPER_JOINTS, GesturePlayer
    from controller.motion_data.command_programs import Segment, gesture_weight

    ids = [g1_model.joint(j).id for j in JOINT_NAMES]
    lo, hi = g1_model.jnt_range[ids, 0], g1_model.jnt_range[ids, 1]
    player = GesturePlayer(JOINT_NAMES, lo, hi)
    base = np.asarray(default_joint_vector())
    upper = [JOINT_NAMES.index(j) for j in UPPER_JOINTS]
    for g in range(1, len(GESTURE_LABELS)):
        for tau in np.linspace(0.0, 2.0, 9):
            q = player.apply(base, g, 1.0, tau)
            assert (q >= lo).all() and (q <= hi).all(), GESTURE_LABELS[g]
            np.testing.assert_array_equal(q[:12], base[:12])  # the legs stay the policy's
        np.testing.assert_array_equal(player.apply(base, g, 0.0, 0.3), base)
        assert not np.allclose(player.apply(base, g, 1.0, 0.3)[upper], base[upper])

    seg = [Segment(0.0, 2.0, "stand", (0, 0, 0), (0, 0, 0), 0.3, 0, ""), Segment(2.0, 3.0, "stand", (0, 0, 0), (0, 0, 0), 0.3, 1, "")]
    seg.append(Segment(5.0, 2.0, "stand", (0, 0, 0), (0, 0, 0), 0.3, 1, ""))
    seg.append(Segment(7.0, 2.0, "stand", (0, 0, 0), (0, 0, 0), 0.3, 2, ""))
    assert gesture_weight(seg, 1, 2.0) == 0.0 and gesture_weight(seg, 1, 2.0 + BLEND_S / 2) == pytest.approx(0.5)
    assert gesture_weight(seg, 1, 2.0 + BLEND_S) == 1.0 and gesture_weight(seg, 1, 4.99) == 1.0  # same gesture next: no blend out
    assert gesture_weight(seg, 2, 7.0 - BLEND_S / 2) == pytest.approx(0.5) and gesture_weight(seg, 2, 7.0) == 0.0


def test_foot_contacts_and_frame_sampling(g1_model: Any) -> None:
    from sim.recorder import FootContacts, FrameSampler
    from sim.robot import SimRobot

    robot = SimRobot(g1_model)
    sampler = FrameSampler(robot, 30.0)
    sampler.advance_to(robot.time + 0.5)  # damped, the robot settles onto its feet
    assert sampler.frames == 16  # frames at 0, 1/30, ..., 15/30 (= 0.5 s)
    qpos, contacts = sampler.take()
    assert qpos.shape == (16, 36) and contacts.shape == (16, 2)
    assert contacts[-1].all()
    sampler.advance_to(robot.time + 0.5)
    assert sampler.frames == 31  # no drift: 30 frames per second
    robot.data.qpos[2] = 2.0  # lifted into the air
    import mujoco

    mujoco.mj_forward(robot.model, robot.data)
    assert not FootContacts(robot.model).read(robot.data).any()
    robot.close()


@pytest.fixture(scope="module")
def recorder() -> Iterator[Recorder]:
    from controller.eval.dataset_recorder import Recorder

    recorder = Recorder("fastsac", None)
    yield recorder
    recorder.close()


def test_record_a_short_dataset(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, recorder: Recorder) -> None:
    from controller.eval import dataset_recorder as dataset_record
    from controller.eval.dataset_recorder import RecordConfig, record

    monkeypatch.setattr(dataset_record, "Recorder", lambda policy, assets_dir: recorder)
    report = record(RecordConfig(out=tmp_path / "rec", minutes=0.2, seed=4, episode_seconds=(4.0, 6.0)))
    assert report["falls"] == 0 and report["clips"] == report["episodes"] >= 2
    assert sum(report["minutes"].values()) == pytest.approx(0.2, abs=0.01)
    clips = load_dataset(tmp_path / "rec")
    assert sum(c.frames for c in clips) == pytest.approx(0.2 * 60 * FPS, abs=2)
    for i, clip in enumerate(clips):
        assert clip.name == f"rec-{4000 + i}" and clip.seed == 4000 + i and clip.split == split_for_seed(4000 + i)
        assert clip.source == "record" and clip.command is not None and clip.gesture is not None
        assert np.isfinite(clip.qpos).all() and (clip.qpos[:, 2] > 0.6).all()
        np.testing.assert_allclose(np.linalg.norm(clip.qpos[:, 3:7], axis=1), 1.0, atol=1e-5)
        assert clip.captions[0][0] == 0 and all(isinstance(c, str) and c for _, c in clip.captions)
        assert clip.contacts.any(axis=1).mean() > 0.9  # walking: some foot is down
        assert np.abs(clip.command).max() <= 0.8 + 1e-9
    # the first seconds stand still after the warm-up: both feet down, no command
    command = clips[0].command
    assert command is not None and clips[0].contacts[:30].all() and not command[:30].any()


def test_episode_is_deterministic_and_a_fall_drops_two_seconds(recorder: Recorder, monkeypatch: pytest.MonkeyPatch) -> None:
    first = recorder.episode(123, 3.0)
    second = recorder.episode(123, 3.0)
    assert first.clip is not None and second.clip is not None and first.clip.frames == 90
    np.testing.assert_array_equal(first.clip.qpos, second.clip.qpos)

    # each episode's clock starts at 0: 1 s warm-up, then a fall 5 s into the recording
    monkeypatch.setattr(recorder.robot, "has_fallen", lambda: recorder.robot.time > 1.0 + 5.0)
    fallen = recorder.episode(124, 10.0)
    monkeypatch.undo()
    assert fallen.fell and fallen.clip is not None
    assert fallen.clip.frames == pytest.approx(3.0 * FPS, abs=2)
    assert max(f for f, _ in fallen.clip.captions) < fallen.clip.frames


# --- command line --------------------------------------------------------------------------------


@pytest.mark.slow
def test_cli_record_import_info(tmp_path: Path) -> None:
    result = g1ctl("dataset", "record", "--out", str(tmp_path / "rec"), "--minutes", "0.05", "--seed", "3")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["clips"] == 1 and report["minutes"]["test"] == 0.05 and report["sim_seconds_per_wall_second"] > 0

    folder = tmp_path / "csv" / "dance"
    folder.mkdir(parents=True)
    rows = yaw_csv_rows(61, 60.0, flip_every_other=False)
    rows[:, 2] = STANDING_PELVIS_HEIGHT
    rows[:, 7:] = default_joint_vector()
    write_csv(folder / "Turn One.csv", rows)
    write_csv(tmp_path / "csv" / "b.csv", rows)
    result = g1ctl("dataset", "import", "--csv", str(tmp_path / "csv"), "--out", str(tmp_path / "moves"))
    assert result.returncode == 0, result.stderr
    clips = {c.name: c for c in load_dataset(tmp_path / "moves")}
    assert set(clips) == {"b", "dance-Turn_One"}
    assert clips["dance-Turn_One"].source == "csv:Turn One.csv" and clips["b"].frames == 31
    assert clips["b"].contacts.all()  # standing pose at standing height: both feet on the floor

    result = g1ctl("dataset", "info", str(tmp_path / "rec"))
    assert result.returncode == 0, result.stderr
    info = json.loads(result.stdout)
    assert info["clips"] == {"train": 0, "val": 0, "test": 1} and set(info["gesture_seconds"]) == set(GESTURE_LABELS)


@pytest.mark.slow
def test_cli_mistakes_are_one_line(tmp_path: Path) -> None:
    assert str(tmp_path / "nope") in one_line_error(g1ctl("dataset", "info", str(tmp_path / "nope")))
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2,3\n")
    line = one_line_error(g1ctl("dataset", "import", "--csv", str(bad), "--out", str(tmp_path / "out")))
    assert line.startswith("g1ctl: ") and "3 columns, expected 36" in line
    line = one_line_error(g1ctl("dataset", "record", "--out", str(tmp_path / "r"), "--minutes", "0"))
    assert line.startswith("g1ctl: ") and "--minutes must be positive" in line


@pytest.mark.slow  # a local Ray instance
def test_recording_on_two_ray_workers_writes_the_same_clips(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason="the eval extra (ray) is not installed")
    from controller.eval.dataset_recorder import RecordConfig, record

    common = {"minutes": 0.25, "seed": 6, "episode_seconds": (3.0, 5.0)}
    alone = record(RecordConfig(out=tmp_path / "one", **common))  # type: ignore[arg-type]
    together = record(RecordConfig(out=tmp_path / "two", workers=2, **common))  # type: ignore[arg-type]
    assert (alone["episodes"], alone["clips"]) == (together["episodes"], together["clips"]) and together["workers"] == 2
    one, two = load_dataset(tmp_path / "one"), load_dataset(tmp_path / "two")
    assert [c.name for c in one] == [c.name for c in two] and len(one) >= 3
    for a, b in zip(one, two, strict=True):
        assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.contacts, b.contacts) and a.captions == b.captions
