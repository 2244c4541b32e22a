"""Captions in training windows: imported clips named, the caption in force, paraphrase draws, text dropout, mirroring."""

from __future__ import annotations

import numpy as np
import pytest

from controller.motion_data.dataset import MotionClip
from controller.motion_data.mirror import mirror_contacts, mirror_qpos
from controller.planner import encoding as enc
from controller.planner.request import TEXT_EMBEDDING_DIM
from controller.training.captions import TextTable, caption_in_force, mocap_caption
from controller.training.windows import TrainClip, WindowSampler, random_constraints
from hw import g1
from tests.conftest import fake_embed, turning_walk


@pytest.mark.parametrize(
    ("name", "caption"),
    [
        ("dance-J_Dance2_Salsa", "dance salsa"),
        ("J_Dance2_Salsa.csv", "dance salsa"),
        ("dance-J_Dance18_TikTok", "dance tik tok"),
        ("dance-J_ShortDance16_JazzWalk", "dance jazz walk"),
        ("dance-B_WiggleDance", "dance a wiggle dance"),
        ("bonus-B_HandsUp", "raise both hands"),
        ("bonus-B_Fence1", "fence with a sword"),
        ("B_Fence2", "fence with a sword"),
    ],
)
def test_mocap_captions_from_file_names(name: str, caption: str) -> None:
    assert mocap_caption(name) == caption


def test_caption_in_force_is_the_one_over_most_plan_frames() -> None:
    captions = ((0, "stand still"), (50, "walk forward"), (100, "turn left in place"))
    assert caption_in_force(captions, 30, 94) == "walk forward"  # 44 of 64 frames
    assert caption_in_force(captions, 4, 48) == "stand still"
    assert caption_in_force(captions, 120, 160) == "turn left in place"  # the last caption runs to the end
    assert caption_in_force(((0, "a"), (20, "b"), (40, "c")), 10, 50) is None  # no caption over half the frames
    assert caption_in_force((), 0, 44) is None
    assert caption_in_force(captions, 40, 100, majority=0.9) is None


def test_text_table_draws_paraphrases_and_drops_text() -> None:
    table, strings = TextTable.build(["walk forward", "turn left in place"], fake_embed, variants=6, dropout=0.3, seed=0)
    assert table.embeddings.shape == (len(strings), TEXT_EMBEDDING_DIM) and len(set(strings)) == len(strings)
    assert all(len(rows) == 6 for rows in table.rows.values())
    rng = np.random.default_rng(0)
    captions = ["walk forward"] * 2000 + [None] * 100
    text, present = table.draw(rng, captions)
    assert not present[2000:].any() and not text[2000:].any()  # no caption, no text
    assert 0.25 < 1 - present[:2000].mean() < 0.35  # the dropout rate
    drawn = {tuple(np.round(v[:4], 6)) for v in text[:2000][present[:2000]]}
    assert len(drawn) == 6  # every paraphrase of the caption gets drawn
    walk_rows = {tuple(np.round(table.embeddings[i, :4], 6)) for i in table.rows["walk forward"]}
    assert drawn == walk_rows
    never = TextTable(table.embeddings, table.rows, dropout=1.0).draw(rng, captions)[1]
    assert not never.any()


def _clip(frames: int, captions: tuple[tuple[int, str], ...], seed: int) -> TrainClip:
    return TrainClip(turning_walk(frames, seed=seed), np.zeros((frames, 2)), captions)


def test_windows_carry_their_caption_in_force_and_its_text() -> None:
    walk = _clip(300, ((0, "walk forward"),), 0)
    turn = _clip(300, ((0, "turn left in place"), (150, "walk backward")), 1)
    table, _ = TextTable.build(["walk forward", "turn left in place", "walk backward"], fake_embed, variants=4, dropout=0.3)
    sampler = WindowSampler([[walk], [turn]], text=table)
    batch = sampler.sample(np.random.default_rng(0), 400)
    assert batch.has_text is not None and len(batch.captions) == 400
    assert set(batch.captions) <= {"walk forward", "turn left in place", "walk backward", None}
    assert {"walk forward", "turn left in place", "walk backward"} <= set(batch.captions)
    slot = batch.cond[:, enc.TEXT_SLOT]
    assert np.array_equal(slot[:, -1] == 1.0, batch.has_text)
    assert not slot[~batch.has_text].any()
    for caption, has, vector in zip(batch.captions, batch.has_text, slot[:, :-1], strict=True):
        if has:  # the text is one of the paraphrases of the window's caption, as the encoder embeds it (normalized on its way)
            rows = table.embeddings[table.rows[caption]]
            assert np.isclose(np.abs(rows - vector).sum(axis=1), 0, atol=1e-9).any()
    assert 0.2 < 1 - batch.has_text.mean() < 0.45  # dropout (plus the few windows between captions)
    untexted = WindowSampler([[walk], [turn]]).sample(np.random.default_rng(0), 50)
    assert not untexted.cond[:, enc.TEXT_SLOT].any()


def test_group_weights_set_each_folder_share() -> None:
    a, b = _clip(200, (), 0), _clip(200, (), 1)
    sampler = WindowSampler([[a], [b]], group_weights=(1.0, 3.0))
    assert np.allclose(sampler._weights, [0.25, 0.75])
    with pytest.raises(ValueError, match="group_weights"):
        WindowSampler([[a], [b]], group_weights=(1.0,))


def test_a_share_of_windows_is_free_of_constraints_when_asked_for() -> None:
    masks = random_constraints(np.random.default_rng(0), np.full(2000, 44), free_share=0.1)
    free = ~masks.any(axis=(1, 2))
    assert 0.07 < free.mean() < 0.13
    assert random_constraints(np.random.default_rng(0), np.full(200, 44)).any(axis=(1, 2)).all()  # none by default


def test_mirroring_swaps_sides_and_undoes_itself() -> None:
    walk = turning_walk(60, seed=2)
    mirrored = mirror_qpos(walk)
    assert np.allclose(mirror_qpos(mirrored), walk)
    assert np.allclose(mirror_qpos(g1.standing_qpos()), g1.standing_qpos())  # the default pose is symmetric
    names = g1.JOINT_NAMES
    left_roll, right_roll = 7 + names.index("left_shoulder_roll_joint"), 7 + names.index("right_shoulder_roll_joint")
    left_pitch, right_pitch = 7 + names.index("left_knee_joint"), 7 + names.index("right_knee_joint")
    assert np.allclose(mirrored[:, right_roll], -walk[:, left_roll]) and np.allclose(mirrored[:, right_pitch], walk[:, left_pitch])
    assert np.allclose(mirrored[:, 1], -walk[:, 1]) and np.allclose(mirrored[:, [0, 2]], walk[:, [0, 2]])
    contacts = np.array([[1, 0], [0, 1]], dtype=bool)
    assert np.array_equal(mirror_contacts(contacts), [[0, 1], [1, 0]])


def test_mirrored_pose_is_the_mirror_image_in_forward_kinematics(assets) -> None:  # type: ignore[no-untyped-def]
    from sim.kinematics import G1Kinematics

    kin = G1Kinematics(assets.g1_mjcf)
    rng = np.random.default_rng(0)
    pose = turning_walk(5, seed=3)
    pose[:, 7:] += rng.normal(scale=0.3, size=(5, 29))
    pos, _, feet = kin.forward(pose)
    mpos, _, mfeet = kin.forward(mirror_qpos(pose))
    flip = np.array([1.0, -1.0, 1.0])
    assert np.allclose(np.sort((mpos * flip).reshape(-1, 3), axis=0), np.sort(pos.reshape(-1, 3), axis=0), atol=1e-6)
    assert np.allclose(mfeet[:, ::-1] * flip, feet, atol=1e-6)  # left foot of the mirror = right foot mirrored


@pytest.mark.train
def test_training_clips_caption_and_mirror_imports() -> None:
    pytest.importorskip("torch", reason="the train extra (torch) is not installed")
    from controller.training.planner import training_clips

    qpos = turning_walk(120, seed=4)
    contacts = np.zeros((120, 2), bool)
    contacts[:, 0] = True
    imported = MotionClip("dance-J_Dance2_Salsa", qpos, contacts, "train", source="csv:J_Dance2_Salsa.csv")
    plain, mirrored = training_clips(imported, mirror=True)
    assert plain.captions == ((0, "dance salsa"),) and mirrored.captions == ((0, "dance salsa"),)
    assert np.allclose(mirrored.qpos, mirror_qpos(qpos)) and (mirrored.contacts[:, 1] == 1).all()
    assert len(training_clips(imported, mirror=False)) == 1
    recorded = MotionClip("rec-1", qpos, contacts, "train", captions=((0, "turn left in place"),))
    assert [c.captions for c in training_clips(recorded, mirror=True)] == [((0, "turn left in place"),)]  # recorded: never mirrored


def test_windows_with_keyframe_velocities_keep_the_roots_momentum_as_the_runtime_does() -> None:
    walk = _clip(300, (), 0)
    draws = {
        keep: WindowSampler([[walk]], velocity_share=0.5, fade_frames=16.0, momentum_with_velocity=keep).sample(
            np.random.default_rng(3), 64
        )
        for keep in (False, True)
    }
    moved = np.abs(draws[True].curve - draws[False].curve).max(axis=(1, 2)) > 1e-9
    assert 0 < moved.sum() < len(moved)  # about half the windows carry velocities; only theirs changed
    assert np.array_equal(draws[True].curve[~moved], draws[False].curve[~moved])
    changed = np.abs(draws[True].curve - draws[False].curve)[moved]
    assert changed[..., 2:].max() < 1e-9 and changed[..., :2].max() > 1e-4  # the root's horizontal channels alone
    # A fade delay changes the same windows, on every channel that fades.
    delayed = WindowSampler([[walk]], velocity_share=0.5, fade_frames=16.0, velocity_fade_delay=8.0).sample(np.random.default_rng(3), 64)
    by_delay = np.abs(delayed.curve - draws[False].curve).max(axis=(1, 2)) > 1e-9
    assert np.array_equal(by_delay, moved) and np.abs(delayed.curve - draws[False].curve)[moved][..., 2:].max() > 1e-4
