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
from hw.errors import AssetError
from tests.conftest import fake_embed, g1ctl, one_line_error, turning_walk

pytestmark = pytest.mark.train
torch = pytest.importorskip("torch", reason="the train extra (torch) is not installed")

from controller.training.planner import TrainConfig, train_planner  # noqa: E402

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
