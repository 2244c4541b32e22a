"""Train a tiny planner on synthetic walks, export it, and plan with the onnxruntime-only runtime."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from controller.motion_data.dataset import MotionClip, save_dataset
from controller.planner.request import TEXT_EMBEDDING_DIM, Keyframe, PlanRequest, PlanRequestError, target_root
from controller.planner.runtime import Planner
from hw.errors import AssetError, ConfigError
from tests.conftest import fake_embed, g1ctl, one_line_error, turning_walk

pytestmark = pytest.mark.train
torch = pytest.importorskip("torch", reason="the train extra (torch) is not installed")

from controller.training.planner import TrainConfig, faster, train_planner  # noqa: E402
from controller.training.windows import TrainClip  # noqa: E402

TINY = TrainConfig(steps=30, batch=32, width=64, depth=1, latent=16, sampling_steps=4, pca_windows=1000, checkpoint_every=15, threads=1)


@pytest.fixture(scope="module")
def tiny_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("planner")
    captions = (((0, "walk forward"), (100, "turn left in place")), ((0, "walk forward slowly while waving the right hand"),))
    clips = [
        MotionClip(f"walk{i}", turning_walk(200, yaw0=i, turn=0.01 * i, seed=i), np.zeros((200, 2), bool), split, captions=captions[i % 2])
        for i, split in enumerate(("train", "train", "train", "val", "test"))
    ]
    save_dataset(root / "data", clips, seed=0)
    imported = [MotionClip("dance-J_Dance2_Salsa", turning_walk(150, seed=9), np.zeros((150, 2), bool), "train", source="csv:x.csv")]
    save_dataset(root / "mocap", imported, seed=0)
    data = [root / "data", root / "mocap"]
    train_planner(data, root / "model", replace(TINY, steps=15), progress=False, embed=fake_embed)
    summary = train_planner(data, root / "model", TINY, progress=False, embed=fake_embed)  # resumes at step 15
    assert summary["steps"] == 30
    training = json.loads((root / "model" / "training.json").read_text())
    assert [h["step"] for h in training["history"]] == [15, 30] and "val_loss_no_text" in training["history"][-1]
    assert summary["captions"] == 4  # three recorded captions and the imported clip's name (mirrored: the same words)
    return root / "model"


def test_plans_meet_their_constraints_and_continue_the_context(tiny_model: Path) -> None:
    walk = turning_walk(100, seed=7)
    planner = Planner.load(tiny_model)
    request = PlanRequest(walk[:4], (Keyframe(30, walk[34]),), lengths=(32, 44), seed=1)
    plan = planner.plan(request)
    assert plan.qpos.shape == (32, 36) and plan.contacts.shape == (32, 2) and plan.latency_ms > 0
    assert np.allclose(plan.qpos[30], walk[34] * np.sign(plan.qpos[30, 3] * walk[34, 3]) ** np.r_[np.zeros(3), np.ones(4), np.zeros(29)])
    assert np.linalg.norm(plan.qpos[0, :2] - walk[3, :2]) < 0.1  # no jump out of the context
    other = planner.plan(replace(request, seed=2))
    assert not np.allclose(plan.qpos[10:25], other.qpos[10:25])  # generative: seeds differ
    assert np.allclose(plan.qpos, planner.plan(request).qpos)  # and a seed is reproducible
    root_only = planner.plan(PlanRequest(walk[:4], (target_root(43, 1.0, -0.5, 0.7),), lengths=(44,)))
    assert np.allclose(root_only.qpos[43, :2], [1.0, -0.5])


def test_a_keyframe_velocity_shapes_the_plan_and_needs_a_model_trained_with_it(tiny_model: Path, tmp_path: Path) -> None:
    from controller.bench.baselines import finite_velocity

    walk = turning_walk(100, seed=7)
    planner = Planner.load(tiny_model)
    spec = json.loads((tiny_model / "planner.json").read_text())
    assert planner.keyframe_velocities and spec["velocity_fade_frames"] == 16.0 and spec["residual_gain"] == 1.0
    assert spec["velocity_residual_gain"] == 1.0 and spec["momentum_with_velocity"] is True
    assert spec["velocity_fade_delay_frames"] == 8.0
    plain = PlanRequest(walk[:4], (Keyframe(30, walk[34]),), lengths=(32,), seed=1)
    moving = replace(plain, keyframes=(Keyframe(30, walk[34], velocity=finite_velocity(walk[34], walk[35])),))
    a, b = planner.plan(plain).qpos, planner.plan(moving).qpos
    assert np.allclose(b[30, 7:], walk[34, 7:]) and not np.allclose(a[20:30], b[20:30])  # the keyframe is met, the way in differs
    older = tmp_path / "older"
    older.mkdir()
    (older / "planner.json").write_text(json.dumps({k: v for k, v in spec.items() if k != "keyframe_velocities"}))
    (older / "planner.onnx").write_bytes((tiny_model / "planner.onnx").read_bytes())
    with pytest.raises(PlanRequestError, match="trained without keyframe velocities"):
        Planner.load(older).plan(moving)
    textless = tmp_path / "textless"
    textless.mkdir()
    (textless / "planner.json").write_text(json.dumps(spec | {"text_conditioned": False}))
    (textless / "planner.onnx").write_bytes((tiny_model / "planner.onnx").read_bytes())
    with pytest.raises(PlanRequestError, match="trained without text"):
        Planner.load(textless).plan(replace(plain, text_embedding=fake_embed(["walk forward"])[0]))
    assert Planner.load(textless).plan(plain).qpos.shape == (32, 36)


def test_the_residual_gain_scales_what_the_model_adds_to_the_anchor(tiny_model: Path) -> None:
    walk = turning_walk(100, seed=7)
    request = PlanRequest(walk[:4], (Keyframe(30, walk[34]),), lengths=(32,), seed=1)
    full = Planner.load(tiny_model, foot_lock=False).plan(request).qpos
    half = Planner.load(tiny_model, foot_lock=False, residual_gain=0.5).plan(request).qpos
    anchor = Planner.load(tiny_model, foot_lock=False, residual_gain=0.0).plan(request).qpos
    # The residual is squashed into the room left to the joint limits (room * tanh(c / room), concave in the gain):
    # half the gain moves each joint the same way as the full one, by at least half as far and at most as far.
    full_move, half_move = full[:, 7:] - anchor[:, 7:], half[:, 7:] - anchor[:, 7:]
    assert np.all(half_move * full_move >= 0) and np.abs(full_move).max() > 1e-3
    assert np.all(np.abs(half_move) <= np.abs(full_move) + 1e-6)
    assert np.all(np.abs(half_move) >= 0.5 * np.abs(full_move) - 1e-6)
    assert np.allclose(anchor[30], full[30])  # constraints stay exact at any gain
    with pytest.raises(PlanRequestError, match="residual gain 1.5 is out of range"):
        Planner.load(tiny_model, residual_gain=1.5)


def test_a_held_out_style_is_left_out_of_every_split(tmp_path: Path) -> None:
    clips = [
        MotionClip(name, turning_walk(120, seed=i), np.zeros((120, 2), bool), split, source="csv:x.csv")
        for i, (name, split) in enumerate((("dance-a", "train"), ("dance-b", "val"), ("bonus-c", "train"), ("bonus-d", "val")))
    ]
    save_dataset(tmp_path / "data", clips, seed=0)
    fast = replace(TINY, steps=2, checkpoint_every=2, hold_out=("bonus",), speed_factors=(0.8, 1.25))
    summary = train_planner([tmp_path / "data"], tmp_path / "model", fast, progress=False, embed=fake_embed)
    assert summary["held_out_clips"] == ["bonus-c", "bonus-d"]
    assert json.loads((tmp_path / "model" / "planner.json").read_text())["held_out"] == ["bonus"]
    with pytest.raises(ConfigError, match="--hold-out jazz matches no clip"):
        train_planner([tmp_path / "data"], tmp_path / "other", replace(fast, hold_out=("jazz",)), progress=False, embed=fake_embed)
    with pytest.raises(ConfigError, match="no 'train' clips"):
        train_planner(
            [tmp_path / "data"], tmp_path / "none", replace(fast, hold_out=("dance-a", "bonus")), progress=False, embed=fake_embed
        )


def test_train_cli_names_bad_style_and_speed_options(tmp_path: Path) -> None:
    clips = [MotionClip("dance-a", turning_walk(120), np.zeros((120, 2), bool), "train", source="csv:x.csv")]
    save_dataset(tmp_path / "data", clips, seed=0)
    base = ("train", "planner", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "model"), "--no-progress")
    assert "--hold-out bonus matches no clip" in one_line_error(g1ctl(*base, "--hold-out", "bonus"))
    assert "--speed-factors must be comma-separated numbers" in one_line_error(g1ctl(*base, "--speed-factors", "fast"))
    assert "speed_factors must be within 0.5..2" in one_line_error(g1ctl(*base, "--speed-factors", "3"))


def test_a_faster_clip_keeps_its_path_in_less_time() -> None:
    walk = turning_walk(121)
    contacts = np.zeros((121, 2))
    contacts[60:] = 1.0
    quick = faster(TrainClip(walk, contacts, ((0, "walk"), (60, "stop"))), 1.25)
    assert len(quick.qpos) == 97 and np.allclose(quick.qpos[-1], walk[-1]) and np.allclose(quick.qpos[0], walk[0])
    assert quick.captions == ((0, "walk"), (48, "stop")) and quick.contacts[47, 0] == 0 and quick.contacts[49, 0] == 1
    assert len(faster(TrainClip(walk, contacts), 0.8).qpos) == 151


def test_invalid_requests_and_missing_models_are_named(tiny_model: Path, tmp_path: Path) -> None:
    planner = Planner.load(tiny_model)
    with pytest.raises(PlanRequestError, match="NaN"):
        planner.plan(PlanRequest(np.full((4, 36), np.nan)))
    with pytest.raises(AssetError, match="no planner model"):
        Planner.load(tmp_path)


def test_a_caption_conditions_the_plan(tiny_model: Path) -> None:
    planner = Planner.load(tiny_model)
    assert planner.text_conditioned and planner.text_encoder == "all-MiniLM-L6-v2"
    walk = turning_walk(100, seed=7)
    request = PlanRequest(walk[:4], (target_root(43, 1.0, 0.0, 0.0),), lengths=(44,))
    text = fake_embed(["turn left in place"])[0]
    plain, texted = planner.plan(request), planner.plan(replace(request, text_embedding=text))
    assert not np.allclose(plain.qpos, texted.qpos)  # the text slot reaches the network
    assert np.allclose(texted.qpos[43, :2], [1.0, 0.0])  # and constraints stay exact
    with pytest.raises(PlanRequestError, match=rf"text embedding must have shape \[{TEXT_EMBEDDING_DIM}\]"):
        planner.plan(replace(request, text_embedding=np.zeros(64)))


def test_a_model_without_the_text_encoder_is_refused(tiny_model: Path, tmp_path: Path) -> None:
    for name, change in {
        "v1": {"version": 1, "cond_dim": 1116},  # the 64-number slot of spec version 1
        "no-encoder": {"text_encoder": None},
        "other-encoder": {"text_encoder": "some-other-encoder"},
    }.items():
        folder = tmp_path / name
        folder.mkdir()
        spec = json.loads((tiny_model / "planner.json").read_text()) | change
        spec = {k: v for k, v in spec.items() if v is not None}
        (folder / "planner.json").write_text(json.dumps(spec))
        (folder / "planner.onnx").write_bytes((tiny_model / "planner.onnx").read_bytes())
        with pytest.raises(AssetError, match="does not match this runtime") as info:
            Planner.load(folder)
        assert "retrain" in str(info.value) and "\n" not in str(info.value)
        if name != "other-encoder":
            assert "all-MiniLM-L6-v2 sentence embeddings" in str(info.value)


def test_runtime_never_imports_torch(tiny_model: Path) -> None:
    code = (
        "import sys, numpy as np\n"
        "from controller.planner.runtime import Planner\n"
        "from controller.planner.request import PlanRequest\n"
        f"p = Planner.load({str(tiny_model)!r})\n"
        "q = np.zeros((4, 36)); q[:, 2] = 0.78; q[:, 3] = 1\n"
        "p.plan(PlanRequest(q))\n"
        "print('torch' in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"


@pytest.mark.slow
def test_viz_plan_draws_a_filmstrip_and_names_bad_input(tiny_model: Path, tmp_path: Path) -> None:
    out = tmp_path / "plan.png"
    result = g1ctl("viz", "plan", "--model", str(tiny_model), "--out", str(out), "--seeds", "2", "--length", "24")
    assert result.returncode == 0, result.stderr
    assert out.stat().st_size > 10_000
    assert "--out must end in .png, .mp4 or .gif" in one_line_error(g1ctl("viz", "plan", "--model", str(tiny_model), "--out", "plan.txt"))
    bad_target = g1ctl("viz", "plan", "--model", str(tiny_model), "--out", str(out), "--target", "1,2")
    assert "--target must be x,y,heading" in one_line_error(bad_target)
