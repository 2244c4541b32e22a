"""The whole-body tracker: observation assembly and loading against tiny ONNX graphs built here, the
real holosoma exports, and (slow) the real policy standing on the simulated G1 with a planned reference."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from controller.commands.velocity import VelocityCommand
from controller.reference.buffer import ReferenceSample
from controller.reference.window import ReferenceWindow
from controller.tracking.observation import ObservationLayout, ObsTerm
from controller.tracking.registry import TrackerSpec, available_trackers, make_tracker
from controller.tracking.whole_body import WholeBodyConfig, WholeBodyTracker, load_whole_body, torso_quat, whole_body_preset
from hw import g1
from hw import quat as quaternion
from hw.errors import ConfigError, PolicyError
from hw.g1 import EFFORT_LIMITS, JOINT_NAMES
from hw.shipped import config_dir
from hw.types import RobotState

N = len(JOINT_NAMES)
# holosoma-inference 0.1.3's 'wbt' observation, its terms in alphabetical order (154 values).
LAYOUT = ObservationLayout(
    terms=(
        ObsTerm("actions", N),
        ObsTerm("base_ang_vel", 3),
        ObsTerm("dof_pos", N),
        ObsTerm("dof_vel", N),
        ObsTerm("motion_command", 2 * N),
        ObsTerm("motion_ref_ori_b", 6),
    )
)
IDENTITY_6 = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]  # the first two columns of the identity, row-major


def make_wbt_onnx(
    path: Path,
    weight: np.ndarray,
    joint_names: tuple[str, ...] = JOINT_NAMES,
    inputs: tuple[str, ...] = ("obs", "time_step"),
    metadata: dict[str, object] | None = None,
    nan_output: bool = False,
) -> Path:
    """`actions = obs @ weight` (or all-NaN) with holosoma's whole-body export's names: inputs 'obs' and
    'time_step' (the clip index: passed through to 'joint_pos' as a stand-in for the clip outputs)."""
    n_in, n_out = weight.shape
    obs_name = inputs[0]
    inits = [numpy_helper.from_array(weight.astype(np.float32), name="W")]
    nodes = [helper.make_node("MatMul", [obs_name, "W"], ["mm"])]
    if nan_output:
        inits.append(numpy_helper.from_array(np.full((1, n_out), np.nan, dtype=np.float32), name="N"))
        nodes.append(helper.make_node("Add", ["mm", "N"], ["actions"]))
    else:
        nodes.append(helper.make_node("Identity", ["mm"], ["actions"]))
    graph_inputs = [helper.make_tensor_value_info(obs_name, TensorProto.FLOAT, [1, n_in])]
    graph_outputs = [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, n_out])]
    for extra in inputs[1:]:
        nodes.append(helper.make_node("Identity", [extra], [f"{extra}_out"]))
        graph_inputs.append(helper.make_tensor_value_info(extra, TensorProto.FLOAT, [1, 1]))
        graph_outputs.append(helper.make_tensor_value_info(f"{extra}_out", TensorProto.FLOAT, [1, 1]))
    graph = helper.make_graph(nodes, "tiny_wbt", graph_inputs, graph_outputs, initializer=inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    meta: dict[str, object] = {"dof_names": list(joint_names), "kp": [40.0] * len(joint_names), "kd": [2.0] * len(joint_names)}
    meta.update(metadata or {})
    for key, value in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value if isinstance(value, str) else json.dumps(value)
    onnx.save(model, str(path))
    return path


def config(**kwargs: object) -> WholeBodyConfig:
    base: dict[str, object] = {"onnx": "tiny.onnx", "observation": LAYOUT, "rate_hz": 50.0, "default_joint_pos": {"left_knee_joint": 0.5}}
    base.update(kwargs)
    if "action_scale" not in base and "effort_action_scale" not in base:
        base["action_scale"] = 0.5
    return WholeBodyConfig(**base)  # type: ignore[arg-type]


def tracker(
    tmp_path: Path, weight: np.ndarray | None = None, robot_joints: tuple[str, ...] = JOINT_NAMES, **kwargs: object
) -> WholeBodyTracker:
    onnx_kwargs = {k: kwargs.pop(k) for k in ("inputs", "metadata", "nan_output", "joint_names") if k in kwargs}
    w = np.zeros((LAYOUT.size, N)) if weight is None else weight
    path = make_wbt_onnx(tmp_path / "tiny.onnx", w, **onnx_kwargs)  # type: ignore[arg-type]
    return WholeBodyTracker(path, config(**kwargs), robot_joints)


def state(joint_pos: np.ndarray | None = None, quat: np.ndarray | None = None, seed: int = 0) -> RobotState:
    rng = np.random.default_rng(seed)
    return RobotState(
        time=0.0,
        joint_pos=rng.normal(scale=0.3, size=N) if joint_pos is None else joint_pos,
        joint_vel=rng.normal(size=N),
        base_quat=np.array([1.0, 0.0, 0.0, 0.0]) if quat is None else quat,
        base_ang_vel=np.array([0.4, -0.8, 1.2]),
        base_pos=np.zeros(3),
        base_lin_vel=np.zeros(3),
    )


def window(qpos: np.ndarray, joint_velocity: np.ndarray | None = None) -> ReferenceWindow:
    vel = np.zeros(N) if joint_velocity is None else joint_velocity
    sample = ReferenceSample(time=0.0, qpos=qpos, root_velocity=np.zeros(3), yaw_rate=0.0, joint_velocity=vel, held=False)
    return ReferenceWindow(0.0, VelocityCommand(), plan=sample, ahead=sample)


def plan_qpos(joints: np.ndarray, root_quat: np.ndarray | None = None) -> np.ndarray:
    qpos = np.zeros(g1.QPOS_SIZE)
    qpos[g1.QPOS_ROOT_POS] = (3.0, -2.0, 0.78)  # anywhere: the policy never sees the root position
    qpos[g1.QPOS_ROOT_QUAT] = (1.0, 0.0, 0.0, 0.0) if root_quat is None else root_quat
    qpos[g1.QPOS_JOINTS] = joints
    return qpos


def matrix_columns(q: np.ndarray) -> np.ndarray:
    return quaternion.to_matrix(q)[:, :2].reshape(-1)


# -- observation -------------------------------------------------------------------------------


def test_observation_holds_the_wbt_terms_in_layout_order(tmp_path: Path) -> None:
    policy = tracker(tmp_path)
    s = state()
    rng = np.random.default_rng(1)
    ref_joints, ref_vel = rng.normal(scale=0.3, size=N), rng.normal(size=N)
    ref_joints[g1.joint_indices(g1.WAIST_JOINTS)] = s.joint_pos[g1.joint_indices(g1.WAIST_JOINTS)]  # same torso as the robot
    obs = policy.observe(s, window(plan_qpos(ref_joints), ref_vel))[0]
    assert obs.shape == (154,) and obs.dtype == np.float32
    default = np.zeros(N)
    default[JOINT_NAMES.index("left_knee_joint")] = 0.5
    expected = np.concatenate(
        [np.zeros(N), s.base_ang_vel, s.joint_pos - default, s.joint_vel, ref_joints, ref_vel, IDENTITY_6]  # absolute reference angles
    )
    assert np.allclose(obs, expected, atol=1e-6)


def test_last_action_is_observed_next_tick(tmp_path: Path) -> None:
    weight = np.zeros((LAYOUT.size, N))
    weight[N, :] = 1.0  # every action = base_ang_vel x (obs column N)
    policy = tracker(tmp_path, weight)
    s = state()
    qpos = plan_qpos(s.joint_pos)
    policy.step(s, window(qpos))
    assert np.allclose(policy.observe(s, window(qpos))[0][:N], s.base_ang_vel[0], atol=1e-6)


def test_torso_orientation_goes_through_the_waist_chain() -> None:
    yaw, roll, pitch = 0.3, -0.2, 0.4
    pelvis = quaternion.exp([0.1, 0.2, -0.3])
    chain = quaternion.multiply(
        quaternion.multiply(quaternion.from_axis_angle([0, 0, 1], yaw), quaternion.from_axis_angle([1, 0, 0], roll)),
        quaternion.from_axis_angle([0, 1, 0], pitch),
    )
    assert np.allclose(torso_quat(pelvis, np.array([yaw, roll, pitch])), quaternion.multiply(pelvis, chain), atol=1e-12)


def test_torso_orientation_matches_mujoco_forward_kinematics(g1_model) -> None:
    import mujoco

    data = mujoco.MjData(g1_model)
    qpos = np.array(g1.standing_qpos())
    qpos[g1.QPOS_ROOT_QUAT] = quaternion.exp([0.2, -0.1, 1.3])
    qpos[g1.QPOS_JOINTS] = np.random.default_rng(2).uniform(-0.4, 0.4, N)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(g1_model, data)
    expected = data.xquat[g1_model.body(g1.TORSO_BODY).id]
    waist = qpos[g1.QPOS_JOINTS][g1.joint_indices(g1.WAIST_JOINTS)]
    assert abs(abs(float(np.dot(torso_quat(qpos[g1.QPOS_ROOT_QUAT], waist), expected))) - 1.0) < 1e-9


def test_reference_orientation_is_in_the_robot_torso_frame(tmp_path: Path) -> None:
    policy = tracker(tmp_path)
    joints = np.zeros(N)
    s = state(joint_pos=joints)
    pitched = quaternion.from_axis_angle([0, 1, 0], 0.3)
    obs = policy.observe(s, window(plan_qpos(joints, pitched)))[0]
    assert np.allclose(obs[-6:], matrix_columns(pitched), atol=1e-6)
    assert np.allclose(obs[-6:], [math.cos(0.3), 0.0, 0.0, 1.0, -math.sin(0.3), 0.0], atol=1e-6)
    # The same torso reached through waist pitch instead of the root: the same observation.
    waist_pitched = joints.copy()
    waist_pitched[JOINT_NAMES.index("waist_pitch_joint")] = 0.3
    assert np.allclose(policy.observe(s, window(plan_qpos(waist_pitched)))[0][-6:], obs[-6:], atol=1e-6)


def test_heading_is_aligned_at_the_start_and_after_reset(tmp_path: Path) -> None:
    """holosoma removes each torso's yaw at the start: a reference facing elsewhere reads as aligned, then turns count."""
    policy = tracker(tmp_path)
    joints = np.zeros(N)
    robot = state(joint_pos=joints, quat=quaternion.from_yaw(1.0))
    reference = plan_qpos(joints, quaternion.from_yaw(-0.5))
    assert np.allclose(policy.observe(robot, window(reference))[0][-6:], IDENTITY_6, atol=1e-6)
    turned = state(joint_pos=joints, quat=quaternion.from_yaw(1.2))  # the robot turned 0.2 rad left of the reference
    assert np.allclose(policy.observe(turned, window(reference))[0][-6:], matrix_columns(quaternion.from_yaw(-0.2)), atol=1e-6)
    policy.reset()
    assert np.allclose(policy.observe(turned, window(reference))[0][-6:], IDENTITY_6, atol=1e-6)


def test_robot_joint_order_differs_from_the_policy(tmp_path: Path) -> None:
    robot_joints = tuple(reversed(JOINT_NAMES))
    policy = tracker(tmp_path, robot_joints=robot_joints)
    s = state()  # arrays in the robot's (reversed) order
    ref = np.random.default_rng(3).normal(size=N)  # qpos order: g1.JOINT_NAMES, as the planner writes it
    obs = policy.observe(s, window(plan_qpos(ref)))[0]
    default = np.zeros(N)
    default[JOINT_NAMES.index("left_knee_joint")] = 0.5
    assert np.allclose(obs[N + 3 : 2 * N + 3], s.joint_pos[::-1] - default, atol=1e-6)
    assert np.allclose(obs[3 * N + 3 : 4 * N + 3], ref, atol=1e-6)
    command = policy.step(s, window(plan_qpos(ref)))
    assert np.allclose(command.q, default)  # targets in the policy's order (JOINT_NAMES)


def test_no_plan_is_refused_with_the_way_out(tmp_path: Path) -> None:
    policy = tracker(tmp_path)
    with pytest.raises(ConfigError, match="--planner"):
        policy.step(state(), ReferenceWindow(0.0, VelocityCommand(vx=0.5)))


# -- actions -----------------------------------------------------------------------------------


def test_action_maps_to_target_around_default_pose(tmp_path: Path) -> None:
    weight = np.zeros((LAYOUT.size, N))
    weight[N, :] = 1.0  # action = base_ang_vel x = 0.4
    policy = tracker(tmp_path, weight)
    command = policy.step(state(), window(plan_qpos(np.zeros(N))))
    default = np.zeros(N)
    default[JOINT_NAMES.index("left_knee_joint")] = 0.5
    assert np.allclose(command.q, default + 0.4 * 0.5, atol=1e-6)
    assert np.allclose(command.kp, 40.0) and np.allclose(command.kd, 2.0)
    assert np.allclose(command.dq, 0.0) and np.allclose(command.tau_ff, 0.0)


def test_effort_action_scale_uses_the_metadata_gains(tmp_path: Path) -> None:
    kp = np.linspace(10.0, 100.0, N)
    policy = tracker(tmp_path, metadata={"kp": kp.tolist()}, effort_action_scale=0.25, kp={"left_knee_joint": 500.0})
    effort = np.array([EFFORT_LIMITS[j] for j in JOINT_NAMES])
    assert np.allclose(policy.action_scale, 0.25 * effort / kp)  # the trained gains, not the override
    assert policy.kp[JOINT_NAMES.index("left_knee_joint")] == 500.0


@pytest.mark.parametrize(("meta", "expected"), [(0.3, 0.3), ([0.1] * N, 0.1), ("0.2, " * (N - 1) + "0.2", 0.2)])
def test_metadata_action_scale_number_list_or_text(tmp_path: Path, meta: object, expected: float) -> None:
    policy = tracker(tmp_path, metadata={"action_scale": meta}, action_scale=None)
    assert np.allclose(policy.action_scale, expected)


def test_config_action_scale_overrides_metadata(tmp_path: Path) -> None:
    assert np.allclose(tracker(tmp_path, metadata={"action_scale": 0.3}, action_scale=1.0).action_scale, 1.0)


def test_missing_action_scale_asks_for_config(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="no action scale"):
        tracker(tmp_path, action_scale=None)


def test_nonfinite_output_holds_last_target_then_latches_damping(tmp_path: Path) -> None:
    policy = tracker(tmp_path, nan_output=True)
    qpos = plan_qpos(np.zeros(N))
    first = policy.step(state(), window(qpos))
    assert np.allclose(first.q, policy.default_pos) and policy.latched_fault is None
    policy.step(state(), window(qpos))
    third = policy.step(state(), window(qpos))
    assert policy.nonfinite_events == 3 and policy.latched_fault is not None and "non-finite" in policy.latched_fault
    assert np.allclose(third.kp, 0.0) and np.allclose(third.kd, 2.0)
    assert np.allclose(policy.step(state(), window(qpos)).kp, 0.0)  # latched
    policy.reset()
    assert policy.latched_fault is None


def test_clip_index_input_is_fed_zero(tmp_path: Path) -> None:
    policy = tracker(tmp_path)
    assert set(policy._feed) == {"time_step"} and float(policy._feed["time_step"][0, 0]) == 0.0
    assert policy.step(state(), window(plan_qpos(np.zeros(N)))).q.shape == (N,)


def test_export_without_clip_input(tmp_path: Path) -> None:
    policy = tracker(tmp_path, inputs=("obs",), clip_input=None)
    assert policy.step(state(), window(plan_qpos(np.zeros(N)))).q.shape == (N,)


# -- loading errors ----------------------------------------------------------------------------


def test_input_size_mismatch_is_named(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="takes 153 values but the observation layout makes 154"):
        tracker(tmp_path, np.zeros((LAYOUT.size - 1, N)))


def test_output_size_mismatch_is_named(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="has 28 values but the metadata names 29 joints"):
        tracker(tmp_path, np.zeros((LAYOUT.size, N - 1)))


def test_wrong_input_name_lists_real_inputs(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="no input 'obs' \\(inputs: actor_obs, time_step\\)"):
        tracker(tmp_path, inputs=("actor_obs", "time_step"))


def test_missing_clip_input_is_named(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="no input 'time_step'.*clip_input"):
        tracker(tmp_path, inputs=("obs",))


def test_an_input_nobody_feeds_is_named(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="inputs \\['phase'\\] are not fed"):
        tracker(tmp_path, inputs=("obs", "time_step", "phase"))


def test_term_this_tracker_does_not_compute_is_refused(tmp_path: Path) -> None:
    layout = ObservationLayout(terms=(*LAYOUT.terms[:-1], ObsTerm("sin_phase", 2), ObsTerm("motion_ref_ori_b", 6)))
    with pytest.raises(ConfigError, match="'sin_phase' is not one this tracker computes"):
        tracker(tmp_path, np.zeros((layout.size, N)), observation=layout)


def test_motion_command_dimension_is_two_per_joint(tmp_path: Path) -> None:
    layout = ObservationLayout(terms=(*LAYOUT.terms[:4], ObsTerm("motion_command", N), LAYOUT.terms[5]))
    with pytest.raises(ConfigError, match="'motion_command' has dim 29, expected 58"):
        tracker(tmp_path, np.zeros((layout.size, N)), observation=layout)


def test_policy_joint_missing_on_robot_is_named(tmp_path: Path) -> None:
    with pytest.raises(PolicyError, match="left_knee_joint"):
        tracker(tmp_path, robot_joints=tuple(j for j in JOINT_NAMES if j != "left_knee_joint"))


def test_corrupt_onnx_file_is_one_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a protobuf")
    with pytest.raises(PolicyError, match="cannot load ONNX policy"):
        WholeBodyTracker(bad, config(), JOINT_NAMES)


def test_a_rate_other_than_the_exports_training_rate_is_refused(tmp_path: Path) -> None:
    trained = {"experiment_config": {"simulator": {"config": {"sim": {"fps": 200, "control_decimation": 4}}}}}
    assert tracker(tmp_path, metadata=trained).rate_hz == 50.0
    with pytest.raises(ConfigError, match=r"rate_hz 60 is not the rate tiny.onnx was trained at \(50 Hz: .*\); set rate_hz: 50"):
        tracker(tmp_path, metadata=trained, rate_hz=60.0)
    assert tracker(tmp_path, rate_hz=60.0).rate_hz == 60.0  # an export that does not say: the config's rate


def test_the_shipped_wbt_ppo_rate_is_its_exports(assets, tmp_path: Path) -> None:
    """The one holosoma export that records its training config (wbt_ppo) agrees with its preset's rate_hz."""
    text = (config_dir("policies") / "wbt_ppo.yaml").read_text()
    assert load_whole_body("wbt_ppo", assets, JOINT_NAMES).rate_hz == 50.0
    wrong = tmp_path / "wbt_ppo_100hz.yaml"
    wrong.write_text(text.replace("rate_hz: 50", "rate_hz: 100", 1))  # the export is still the cached one
    with pytest.raises(ConfigError, match=f"{wrong}: rate_hz 100 is not the rate ppo_g1_29dof_dancing.onnx was trained at"):
        load_whole_body(str(wrong), assets, JOINT_NAMES)


# -- presets and the registry ------------------------------------------------------------------


def test_preset_for_the_policy_option() -> None:
    assert whole_body_preset("fastsac") == "wbt_fastsac"  # the default --policy: the whole-body policy trained the same way
    assert whole_body_preset("ppo") == "wbt_ppo"
    assert whole_body_preset("wbt_ppo") == "wbt_ppo"
    assert whole_body_preset("/somewhere/mine.yaml") == "/somewhere/mine.yaml"
    with pytest.raises(ConfigError, match="no whole-body counterpart.*wbt_fastsac, wbt_ppo"):
        whole_body_preset("mine")


def test_real_holosoma_exports_load_and_act(assets) -> None:
    assert "whole-body" in available_trackers()
    default = make_tracker("whole-body", TrackerSpec("fastsac", assets, JOINT_NAMES))
    assert default.name == "whole-body" and isinstance(default, WholeBodyTracker) and default.path.name == "fastsac_g1_29dof_dancing.onnx"
    ppo = load_whole_body("wbt_ppo", assets, JOINT_NAMES)
    # holosoma-inference 0.1.3 config_values/robot.py G1_29DOF_PER_JOINT_ACTION_SCALE (0.25 * effort / kp), a few joints.
    table = {"left_hip_pitch_joint": 0.547546465219, "left_knee_joint": 0.350661466378, "left_ankle_pitch_joint": 0.438577313919}
    table |= {"left_wrist_pitch_joint": 0.074500870329, "waist_roll_joint": 0.438577313919}
    for joint, scale in table.items():
        assert ppo.action_scale[JOINT_NAMES.index(joint)] == pytest.approx(scale, rel=1e-6)
    assert np.allclose(default.action_scale, 1.0)  # the fastsac export acts in radians (configs/policies/wbt_fastsac.yaml)
    for policy in (default, ppo):
        assert policy.joint_names == JOINT_NAMES
        s = state(joint_pos=policy.default_pos.copy())
        command = policy.step(s, window(plan_qpos(np.array(g1.default_joint_vector()))))
        assert np.all(np.isfinite(command.q)) and np.abs(command.q - policy.default_pos).max() < 1.0


# -- the real policy on the simulated G1 -------------------------------------------------------


def test_real_policy_stands_and_waves_with_the_planner() -> None:
    """The default preset (wbt_fastsac) on the shipped `wave` scenario, first 6 s: standing, the right hand waving."""
    from controller.runtime.driver import run
    from controller.runtime.run_config import RunConfig

    report = run(RunConfig(scenario="wave", planner=True, tracker="whole-body", duration=6.0))
    assert report["tracker"] == "whole-body"
    assert report["falls"] == 0 and report["final_mode"] != "damp"
    assert report["nonfinite_actions"] == 0
    assert 0.0 < report["upper_body_error_mean"] < 0.3  # measured 0.20 rad (0.27 over the whole 12 s)
    assert np.hypot(*report["final_base_position"][:2]) < 0.3  # it stays where it stood (measured 0.05 m)


def test_without_the_planner_the_run_is_refused_before_it_starts() -> None:
    from controller.runtime.driver import run
    from controller.runtime.run_config import RunConfig

    with pytest.raises(ConfigError, match="the whole-body tracker follows planned whole-body motion: add --planner"):
        run(RunConfig(tracker="whole-body", duration=0.1))
