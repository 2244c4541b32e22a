"""Observation assembly and policy loading against tiny ONNX graphs built here."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.reference.window import ReferenceWindow
from controller.tracking.observation import ObservationBuilder, ObservationLayout, ObsTerm
from controller.tracking.velocity_policy import GaitConfig, PolicyConfig, VelocityPolicy
from hw import quat as quaternion
from hw.errors import ConfigError, PolicyError
from hw.g1 import JOINT_NAMES
from hw.types import RobotState

N = len(JOINT_NAMES)
LAYOUT = ObservationLayout(
    terms=(
        ObsTerm("actions", N),
        ObsTerm("base_ang_vel", 3, 0.25),
        ObsTerm("command_ang_vel", 1),
        ObsTerm("command_lin_vel", 2),
        ObsTerm("cos_phase", 2),
        ObsTerm("dof_pos", N),
        ObsTerm("dof_vel", N, 0.05),
        ObsTerm("projected_gravity", 3),
        ObsTerm("sin_phase", 2),
    )
)


def config(onnx: str = "tiny.onnx", **kwargs: object) -> PolicyConfig:
    base: dict[str, object] = {"onnx": onnx, "observation": LAYOUT, "rate_hz": 50.0, "default_joint_pos": {"left_knee_joint": 0.5}}
    base["action_scale"] = 0.25
    base.update(kwargs)
    return PolicyConfig(**base)  # type: ignore[arg-type]


def state(joint_pos: np.ndarray | None = None, quat: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0)) -> RobotState:
    rng = np.random.default_rng(0)
    return RobotState(
        time=0.0,
        joint_pos=rng.normal(size=N) if joint_pos is None else joint_pos,
        joint_vel=rng.normal(size=N),
        base_quat=np.array(quat),
        base_ang_vel=np.array([0.4, -0.8, 1.2]),
        base_pos=np.zeros(3),
        base_lin_vel=np.zeros(3),
    )


def test_observation_concatenates_scaled_terms_in_layout_order(linear_onnx) -> None:
    policy = VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(), JOINT_NAMES)
    s = state()
    obs = policy.observe(s, VelocityCommand(0.3, -0.2, 0.7))[0]
    assert obs.shape == (100,) and obs.dtype == np.float32
    default = np.zeros(N)
    default[JOINT_NAMES.index("left_knee_joint")] = 0.5
    expected = np.concatenate(
        [
            np.zeros(N),  # last action
            s.base_ang_vel * 0.25,
            [0.7],
            [0.3, -0.2],
            [math.cos(math.pi)] * 2,  # standing gait phase
            s.joint_pos - default,
            s.joint_vel * 0.05,
            [0.0, 0.0, -1.0],
            [math.sin(math.pi)] * 2,
        ]
    )
    assert np.allclose(obs, expected, atol=1e-6)


def test_history_keeps_each_term_oldest_first() -> None:
    layout = ObservationLayout(terms=(ObsTerm("a", 2), ObsTerm("b", 1, 10.0)), history_length=3)
    builder = ObservationBuilder(layout)
    builder.build({"a": np.array([1.0, 2.0]), "b": np.array([1.0])})
    out = builder.build({"a": np.array([3.0, 4.0]), "b": np.array([2.0])})[0]
    assert out.tolist() == [0, 0, 1, 2, 3, 4, 0, 10, 20]


def test_projected_gravity_of_tilted_base() -> None:
    half = math.radians(90) / 2  # pitched 90 deg nose-down about y
    q = np.array([math.cos(half), 0.0, math.sin(half), 0.0])
    assert np.allclose(quaternion.rotate_inverse_one(q, np.array([0.0, 0.0, -1.0])), [1.0, 0.0, 0.0], atol=1e-12)


def test_action_maps_to_target_around_default_pose(linear_onnx) -> None:
    weight = np.zeros((LAYOUT.size, N))
    weight[32, :] = 1.0  # every action equals the yaw-rate command
    policy = VelocityPolicy(linear_onnx(weight), config(), JOINT_NAMES)
    cmd = policy.step(state(), ReferenceWindow(0.0, VelocityCommand(yaw_rate=0.8)))
    assert np.allclose(cmd.q, 0.8 * 0.25 + policy.default_pos, atol=1e-6)
    assert np.allclose(cmd.kp, 40.0) and np.allclose(cmd.kd, 2.0)
    assert np.allclose(policy.last_action, 0.8, atol=1e-6)


def test_gain_override_from_config(linear_onnx) -> None:
    policy = VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(kp={"left_knee_joint": 99.0}), JOINT_NAMES)
    assert policy.kp[JOINT_NAMES.index("left_knee_joint")] == 99.0
    assert policy.kp[0] == 40.0


def test_gait_phase_walks_and_stands(linear_onnx) -> None:
    policy = VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(gait=GaitConfig(period=1.0)), JOINT_NAMES)
    policy.step(state(), ReferenceWindow(0.0, VelocityCommand(vx=0.5)))
    assert policy.gait.phase.tolist() == [0.0, math.pi]  # feet start half a period apart
    policy.step(state(), ReferenceWindow(0.0, VelocityCommand(vx=0.5)))
    assert policy.gait.phase[0] == pytest.approx(2 * math.pi / 50)
    policy.step(state(), ReferenceWindow(0.0, VelocityCommand()))
    assert policy.gait.phase.tolist() == [math.pi, math.pi]


def test_nonfinite_output_holds_last_target_then_latches_damping(linear_onnx) -> None:
    policy = VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N)), nan_output=True), config(max_consecutive_nonfinite=3), JOINT_NAMES)
    first = policy.step(state(), ReferenceWindow(0.0, VelocityCommand()))
    assert np.all(np.isfinite(first.q)) and np.allclose(first.q, policy.default_pos)
    assert np.allclose(first.kp, 40.0)
    policy.step(state(), ReferenceWindow(0.0, VelocityCommand()))
    damped = policy.step(state(), ReferenceWindow(0.0, VelocityCommand()))
    assert policy.nonfinite_events == 3
    assert policy.latched_fault is not None and "non-finite" in policy.latched_fault
    assert np.all(damped.kp == 0.0) and np.all(damped.kd > 0.0) and np.all(np.isfinite(damped.q))


def test_input_size_mismatch_is_named(linear_onnx) -> None:
    with pytest.raises(PolicyError, match="takes 90 values but the observation layout makes 100"):
        VelocityPolicy(linear_onnx(np.zeros((90, N))), config(), JOINT_NAMES)


def test_output_size_mismatch_is_named(linear_onnx) -> None:
    with pytest.raises(PolicyError, match="output 'action' has 12 values"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, 12))), config(), JOINT_NAMES)


def test_wrong_input_name_lists_real_inputs(linear_onnx) -> None:
    with pytest.raises(PolicyError, match="no input 'obs'.*actor_obs"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(input_name="obs"), JOINT_NAMES)


def test_unknown_joint_in_metadata_is_named(linear_onnx) -> None:
    names = ("left_hip_pitch_jiont", *JOINT_NAMES[1:])
    with pytest.raises(PolicyError, match="left_hip_pitch_jiont"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N)), joint_names=names), config(), JOINT_NAMES)


def test_unknown_observation_term_lists_known_ones(linear_onnx) -> None:
    layout = ObservationLayout(terms=(*LAYOUT.terms[:-1], ObsTerm("sin_fase", 2)))
    with pytest.raises(ConfigError, match="unknown observation term 'sin_fase'.*sin_phase"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(observation=layout), JOINT_NAMES)


def test_wrong_term_dimension_is_named(linear_onnx) -> None:
    layout = ObservationLayout(terms=(*LAYOUT.terms[:-2], ObsTerm("projected_gravity", 2), LAYOUT.terms[-1]))
    with pytest.raises(ConfigError, match="'projected_gravity' has dim 2, expected 3"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size - 1, N))), config(observation=layout), JOINT_NAMES)


def test_corrupt_onnx_file_is_one_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a protobuf")
    with pytest.raises(PolicyError, match="cannot load ONNX policy"):
        VelocityPolicy(bad, config(), JOINT_NAMES)


def test_missing_action_scale_asks_for_config(linear_onnx) -> None:
    with pytest.raises(PolicyError, match="no action scale"):
        VelocityPolicy(linear_onnx(np.zeros((LAYOUT.size, N))), config(action_scale=None), JOINT_NAMES)


def test_real_holosoma_policies_load_and_act(assets) -> None:
    from controller.tracking.presets import available_policies, load_policy

    assert {"fastsac", "ppo"} <= set(available_policies())
    for name in ("fastsac", "ppo"):
        policy = load_policy(name, assets, JOINT_NAMES)
        assert policy.joint_names == JOINT_NAMES
        assert policy.command_limits.vx == (-1.0, 1.0)
        cmd = policy.step(state(joint_pos=policy.default_pos.copy()), ReferenceWindow(0.0, VelocityCommand(vx=0.5)))
        assert np.all(np.isfinite(cmd.q)) and np.abs(cmd.q - policy.default_pos).max() < 3.0
