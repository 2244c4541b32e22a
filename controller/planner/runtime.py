"""The runtime planner: a plan request in, G1 `qpos` frames at 30 fps out, onnxruntime only.

Per request: canonicalize the context and keyframes to the frame of the last context frame,
build the anchor curve and the conditioning vector, draw the seed's noise, run the exported
sampler (encoder once, a few flow steps, latent decode: one ONNX call), add the windowed
residual to the curve, and map back to world `qpos`. Never imports torch.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import onnxruntime as ort

from controller.onnx_session import open_session
from controller.planner import encoding as enc
from controller.planner import features as ft
from controller.planner.foot_lock import LegChains, lock_feet
from controller.planner.joint_room import within_room
from controller.planner.plausibility import JOINT_LOWER, JOINT_UPPER
from controller.planner.request import CONTEXT_FRAMES, FPS, TEXT_EMBEDDING_DIM, TEXT_ENCODER, Plan, PlanRequest, PlanRequestError
from hw import g1
from hw.errors import AssetError
from hw.shipped import model_dir as model_dir_of

_LIMITS = (JOINT_LOWER, JOINT_UPPER)  # the G1's joint limits, in joint order
_EACH_LEG_IN_JOINTS = (g1.joint_slice(g1.LEFT_LEG_JOINTS), g1.joint_slice(g1.RIGHT_LEG_JOINTS))  # in the joint vector


class Planner:
    """Generative in-betweening planner loaded from a model folder (`planner.json` + `planner.onnx`)."""

    def __init__(
        self,
        session: ort.InferenceSession,
        spec: dict[str, Any],
        foot_lock: bool = True,
        temperature: float | None = None,
        residual_gain: float | None = None,
    ):
        self._session = session
        self.spec = spec
        self.latent = int(spec["latent"])
        # The noise scale: below 1 trades diversity for likelihood; the spec holds the one chosen on validation data.
        self.temperature = float(spec["temperature"] if temperature is None else temperature)
        if not 0.0 <= self.temperature <= 2.0:
            raise PlanRequestError(f"sampling temperature {self.temperature} is out of range: use 0 (the mode) to 2")
        self.legs = LegChains.from_spec(spec["legs"]) if foot_lock else None
        # Whether the text slot was trained (captions in the training windows); an untrained slot is ignored by the model.
        self.text_conditioned = bool(spec.get("text_conditioned", False))
        self.text_encoder = str(spec["text_encoder"])
        # The anchor curve the model was trained over (models before keyframe velocities: no fade, none given).
        fade = spec.get("velocity_fade_frames")
        self.velocity_fade_frames = None if fade is None else float(fade)
        # Where a keyframe carries its velocity, the root's horizontal velocity keeps its momentum (features.anchor_curve).
        self.momentum_with_velocity = bool(spec.get("momentum_with_velocity", False))
        # Where a keyframe carries its velocity, the velocities are carried whole this many frames before they fade.
        self.velocity_fade_delay_frames = float(spec.get("velocity_fade_delay_frames", 0.0))
        self.keyframe_velocities = bool(spec.get("keyframe_velocities", False))
        # How much of the learned residual is added to the anchor (1: all); chosen on validation data (MODEL_CARD.md). Where
        # a keyframe carries its velocity the anchor already arrives as the motion does and its own gain applies; a gain
        # given here sets both.
        self.residual_gain = float(spec.get("residual_gain", 1.0) if residual_gain is None else residual_gain)
        with_velocity = spec.get("velocity_residual_gain", self.residual_gain) if residual_gain is None else residual_gain
        self.velocity_residual_gain = float(with_velocity)
        for gain in (self.residual_gain, self.velocity_residual_gain):
            if not 0.0 <= gain <= 1.0:
                raise PlanRequestError(f"residual gain {gain} is out of range: use 0 (the anchor curve alone) to 1")

    @classmethod
    def load(
        cls,
        model_dir: Path | None = None,
        threads: int = 1,
        foot_lock: bool = True,
        temperature: float | None = None,
        residual_gain: float | None = None,
    ) -> Planner:
        folder = Path(model_dir) if model_dir is not None else model_dir_of("planner")
        spec_path = folder / "planner.json"
        try:
            spec = json.loads(spec_path.read_text())
        except FileNotFoundError as exc:
            raise AssetError(
                f"no planner model in {folder} (planner.json missing); train one with 'g1ctl train planner' or pass --model"
            ) from exc
        except json.JSONDecodeError as exc:
            raise AssetError(f"{spec_path} is not valid JSON ({exc}); restore it from the repository") from exc
        if "legs" not in spec or len(spec["legs"]) != 2:
            raise AssetError(f"{spec_path} has no leg chains for foot locking; re-export the model with 'g1ctl train planner'")
        expected = {
            "version": enc.SPEC_VERSION, "cond_dim": enc.COND_DIM, "frames": enc.FRAMES, "out_channels": enc.OUT_CHANNELS,
            "text_encoder": TEXT_ENCODER, "text_dim": TEXT_EMBEDDING_DIM,
        }  # fmt: skip
        wrong = {k: spec.get(k) for k, v in expected.items() if spec.get(k) != v}
        if wrong:
            hint = ""
            if spec.get("version", 1) < enc.SPEC_VERSION or "text_encoder" not in spec:
                hint = f" it was exported before the text slot held {TEXT_ENCODER} sentence embeddings ({TEXT_EMBEDDING_DIM} numbers);"
            raise AssetError(
                f"planner model in {folder} does not match this runtime ({wrong}, expected {expected});{hint} retrain or update it"
            )
        session = open_session(folder / spec["onnx"], AssetError, "planner ONNX", threads)
        return cls(session, spec, foot_lock, temperature, residual_gain)

    def warm_up(self) -> None:
        """One plan from standing: onnxruntime's first run costs tens of milliseconds, so do it before the control loop."""
        self.plan(PlanRequest(context=np.tile(g1.standing_qpos(), (CONTEXT_FRAMES, 1))))

    def plan(self, request: PlanRequest) -> Plan:
        """One plan; raises PlanRequestError for an invalid request. A keyframe out of reach is met anyway, and the plan
        says so (`Plan.unreachable`)."""
        started = time.perf_counter()
        request = request.validated()
        qpos, contacts = self.sample(request, [request.seed])
        return Plan(qpos[0], contacts[0], (time.perf_counter() - started) * 1000.0, request.unreachable())

    def sample(self, request: PlanRequest, seeds: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """Plans for one validated request under several seeds in one batch: qpos [S, N, 36], contacts [S, N, 2]."""
        length = request.plan_length()
        origin, context, values, mask = enc.request_channels(request)
        origin_xy, origin_yaw = origin[:2], origin[2]
        if request.text_embedding is not None and not self.text_conditioned:
            raise PlanRequestError(
                "this planner model was trained without text (planner.json: text_conditioned false); send no text_embedding"
            )
        velocities = enc.request_velocities(request, origin)
        if velocities is not None and not self.keyframe_velocities:
            raise PlanRequestError(
                "this planner model was trained without keyframe velocities (planner.json); leave Keyframe.velocity unset "
                "or retrain with 'g1ctl train planner'"
            )
        vel, vel_mask = velocities if velocities is not None else (None, None)
        fade_root_xy = not (self.momentum_with_velocity and velocities is not None)
        delay = self.velocity_fade_delay_frames if velocities is not None else 0.0
        curve, window = ft.anchor_curve(context, values, mask, vel, vel_mask, self.velocity_fade_frames, fade_root_xy, delay)
        cond = enc.conditioning(context, curve, mask, np.array(length), request.text_embedding)
        noise = self.temperature * np.stack([np.random.default_rng(s).standard_normal(self.latent) for s in seeds])
        noise = noise.astype(np.float32)
        cond_batch = np.broadcast_to(cond.astype(np.float32), (len(seeds), enc.COND_DIM))
        (residual,) = self._session.run(None, {"cond": np.ascontiguousarray(cond_batch), "noise": noise})
        base = np.broadcast_to(curve[:length], (len(seeds), length, ft.NUM_CHANNELS))
        gain = self.residual_gain if velocities is None else self.velocity_residual_gain
        channels = base + window[:length] * gain * residual[:, :length, : ft.NUM_CHANNELS]
        # The joints' residual within the room the anchor leaves them (joint_room.py): no joint is planned past a limit.
        channels[..., ft.JOINTS] = within_room(base[..., ft.JOINTS], channels[..., ft.JOINTS] - base[..., ft.JOINTS], *_LIMITS)
        qpos = ft.from_channels(channels, origin_xy, origin_yaw)
        qpos = _continue_sign(qpos, request.context[-1])
        contacts = residual[:, :length, ft.NUM_CHANNELS :] > 0.0
        if self.legs is not None:
            joints_fixed = mask[:length, ft.JOINTS]
            legs_fixed = np.stack([joints_fixed[:, leg].any(axis=-1) for leg in _EACH_LEG_IN_JOINTS], axis=-1)  # [N, 2]: left, right
            # Where keyframes carry velocities the context is measured motion: its feet's own speed tells a swing.
            before = request.context[-2] if velocities is not None else None
            locked = lock_feet(qpos, contacts, self.legs, request.context[-1], legs_fixed, FPS, before)
            joints = qpos[..., g1.QPOS_JOINTS]
            locked[..., g1.QPOS_JOINTS] = within_room(joints, locked[..., g1.QPOS_JOINTS] - joints, *_LIMITS)
            qpos = locked
        return qpos, contacts


def _continue_sign(qpos: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Flip plans whose root quaternion starts on the other hemisphere from the context's."""
    rot = g1.QPOS_ROOT_QUAT
    flip = np.sum(qpos[..., :1, rot] * last[rot], axis=-1, keepdims=True) < 0
    qpos[..., rot] = np.where(flip, -qpos[..., rot], qpos[..., rot])
    return qpos
