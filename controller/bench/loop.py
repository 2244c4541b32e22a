"""`g1ctl bench loop`: what the full `g1ctl sim` stack costs over a minimal inline loop.

The minimal loop is written out here on purpose, with nothing but what walking needs:
the same compiled model (PD inside the MuJoCo step), the same ONNX session, a
hand-assembled observation, the same command timeline. Both run in this process,
alternating, and the best real-time factor of each is compared.
"""

from __future__ import annotations

import math
import time
from typing import Any

import mujoco
import numpy as np

from controller.assets import ensure_assets
from controller.inputs.scripted import load_scenario
from controller.runtime.driver import run
from controller.runtime.run_config import RunConfig
from controller.tracking.presets import load_policy
from hw import g1 as constants
from sim.world import build_model


def minimal_loop_rtf(policy_name: str, duration: float, assets_dir: str | None) -> float:
    """Real-time factor of a bare MuJoCo + ONNX + PD loop on walk_turn_stop."""
    assets = ensure_assets(assets_dir, quiet=True)
    model = build_model(assets.g1_mjcf)
    data = mujoco.MjData(model)
    policy = load_policy(policy_name, assets, constants.JOINT_NAMES)
    session, in_name, out_name = policy._session, policy.cfg.input_name, policy.cfg.output_name
    steps = load_scenario("walk_turn_stop").steps
    times = np.array([s.t for s in steps])
    cmds = np.array([[s.vx, s.vy, s.yaw_rate] for s in steps])
    default = policy.default_pos
    kp, kd, scale = policy.kp, policy.kd, policy.action_scale
    data.qpos[:3] = [0.0, 0.0, constants.STANDING_PELVIS_HEIGHT]
    data.qpos[3] = 1.0
    data.qpos[7:] = default
    mujoco.mj_forward(model, data)
    model.actuator_biasprm[:, 1] = -kp
    model.actuator_biasprm[:, 2] = -kd
    decimation = round(1.0 / (policy.cfg.rate_hz * model.opt.timestep))
    obs = np.zeros((1, policy.cfg.observation.size), dtype=np.float32)
    action = np.zeros(29)
    phase = np.array([math.pi, math.pi])
    dphase = 2 * math.pi / (policy.cfg.rate_hz * policy.cfg.gait.period)
    standing = True
    n_ticks = round(duration * policy.cfg.rate_hz)
    start = time.perf_counter()
    for k in range(n_ticks):
        cmd = cmds[np.searchsorted(times, k / policy.cfg.rate_hz, side="right") - 1]
        w, x, y, z = data.qpos[3:7]
        gravity = (2 * (w * y - x * z), -2 * (y * z + w * x), 2 * (x * x + y * y) - 1)  # R^T (0, 0, -1)
        # Alphabetical holosoma layout: actions, base_ang_vel, command_ang_vel, command_lin_vel,
        # cos_phase, dof_pos, dof_vel, projected_gravity, sin_phase.
        obs[0, 0:29] = action
        obs[0, 29:32] = data.qvel[3:6] * 0.25
        obs[0, 32] = cmd[2]
        obs[0, 33:35] = cmd[:2]
        obs[0, 35:37] = np.cos(phase)
        obs[0, 37:66] = data.qpos[7:] - default
        obs[0, 66:95] = data.qvel[6:] * 0.05
        obs[0, 95:98] = gravity
        obs[0, 98:100] = np.sin(phase)
        action = np.clip(session.run([out_name], {in_name: obs})[0][0].astype(float), -100, 100)
        data.ctrl[:] = kp * (action * scale + default)
        mujoco.mj_step(model, data, nstep=decimation)
        phase = np.fmod(phase + dphase + math.pi, 2 * math.pi) - math.pi
        if abs(cmd).max() < 0.01:
            phase[:], standing = math.pi, True
        elif standing:
            phase, standing = np.array([0.0, math.pi]), False
    wall = time.perf_counter() - start
    if data.qpos[2] < 0.45:
        raise RuntimeError("the minimal loop's robot fell: its observation no longer matches the policy")
    return duration / wall


def stack_rtf(policy_name: str, duration: float, assets_dir: str | None, estimator: bool = False) -> float:
    report = run(RunConfig(scenario="walk_turn_stop", policy=policy_name, duration=duration, assets_dir=assets_dir, estimator=estimator))
    if report["falls"]:
        raise RuntimeError("the stack's robot fell during the benchmark")
    return float(report["real_time_factor"])


def run_loop_bench(policy_name: str, rounds: int, duration: float, assets_dir: str | None, estimator: bool = False) -> dict[str, Any]:
    """`estimator`: the stack runs the state estimator (as on hardware), the minimal loop does not."""
    stack, minimal = [], []
    for _ in range(max(rounds, 1)):
        minimal.append(minimal_loop_rtf(policy_name, duration, assets_dir))
        stack.append(stack_rtf(policy_name, duration, assets_dir, estimator))
    best_stack, best_minimal = max(stack), max(minimal)
    return {
        "benchmark": "loop",
        "policy": policy_name,
        "scenario": "walk_turn_stop",
        "estimator": estimator,
        "sim_seconds": duration,
        "rounds": len(stack),
        "stack_rtf": round(best_stack, 3),
        "minimal_rtf": round(best_minimal, 3),
        "ratio": round(best_stack / best_minimal, 3),
        "stack_rtf_runs": [round(v, 3) for v in stack],
        "minimal_rtf_runs": [round(v, 3) for v in minimal],
    }
