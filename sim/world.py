"""Build the MuJoCo scene of the G1: the holosoma MJCF plus floor, light and sky.

Actuators are rewritten as joint-space PD servos evaluated inside MuJoCo at every
physics step (force = kp (q* - q) + kd (dq* - dq) + tau_ff, clamped to the joint's
effort limit), so one `mj_step(nstep=n)` call runs a control tick's n PD updates without a
Python round trip per step. Gains are set per command through `actuator_biasprm`. The
physics step is the hardware cycle's period (`hw.g1.CONTROL_CYCLE_HZ`, 500 Hz: 2 ms): the
simulated robot updates its PD servos as often as the real one's motors get a command.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from hw.errors import AssetError
from hw.g1 import CONTROL_CYCLE_HZ, EFFORT_LIMITS


@dataclass(frozen=True)
class SceneConfig:
    timestep: float = 1.0 / CONTROL_CYCLE_HZ  # s: one physics step per hardware cycle
    floor_friction: float = 0.8
    solver_iterations: int = 50
    terrain_height: float = 0.0  # m: > 0 makes the floor uneven ground (a seeded height field), flat within 1 m of the start
    terrain_seed: int = 0


TERRAIN_SIZE_M = 20.0  # the height field's side, centred on the start
TERRAIN_CELLS = 161  # samples per side: 0.125 m apart
TERRAIN_FLAT_RADIUS_M = 1.0  # the robot starts standing on flat ground


def terrain_heights(height: float, seed: int) -> np.ndarray:
    """Smooth seeded bumps in [0, 1] (times `height` in the scene), flat at 0 around the start: noise blurred over about 0.5 m."""
    rng = np.random.default_rng([seed, 7])
    noise = rng.standard_normal((TERRAIN_CELLS, TERRAIN_CELLS))
    kernel = np.exp(-0.5 * (np.arange(-8, 9) / 3.0) ** 2)
    for axis in (0, 1):  # a separable Gaussian blur
        noise = np.apply_along_axis(lambda row: np.convolve(row, kernel / kernel.sum(), mode="same"), axis, noise)
    heights = (noise - noise.min()) / max(float(np.ptp(noise)), 1e-9)
    coords = np.linspace(-TERRAIN_SIZE_M / 2, TERRAIN_SIZE_M / 2, TERRAIN_CELLS)
    radius = np.hypot(*np.meshgrid(coords, coords))
    ramp = np.clip((radius - TERRAIN_FLAT_RADIUS_M) / TERRAIN_FLAT_RADIUS_M, 0.0, 1.0)  # 0 at the start, full 2 m out
    return heights * ramp


def build_model(mjcf_path: Path, cfg: SceneConfig = SceneConfig()) -> mujoco.MjModel:
    """Compile the G1 scene from the MJCF at `mjcf_path` (meshes beside it in `meshes/`)."""
    if not mjcf_path.is_file():
        raise AssetError(f"G1 model not found at {mjcf_path}; run 'g1ctl assets fetch' or set G1CTL_ASSETS_DIR")
    try:
        spec = mujoco.MjSpec.from_file(str(mjcf_path))
    except Exception as exc:  # mujoco raises a bare ValueError with the parser's message
        raise AssetError(f"cannot parse G1 model {mjcf_path}: {exc}; run 'g1ctl assets fetch' to restore it") from exc
    _add_environment(spec, cfg)
    _make_pd_actuators(spec)
    try:
        return spec.compile()
    except Exception as exc:
        raise AssetError(f"cannot compile G1 model {mjcf_path}: {exc}; run 'g1ctl assets fetch' to restore it") from exc


def _add_environment(spec: mujoco.MjSpec, cfg: SceneConfig) -> None:
    spec.option.timestep = cfg.timestep
    spec.option.iterations = cfg.solver_iterations
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.add_texture(
        name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.3, 0.5, 0.7], rgb2=[0.0, 0.0, 0.0], width=512, height=3072,
    )  # fmt: skip
    spec.add_texture(
        name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        mark=mujoco.mjtMark.mjMARK_EDGE, rgb1=[0.2, 0.3, 0.4], rgb2=[0.1, 0.2, 0.3], markrgb=[0.8, 0.8, 0.8],
        width=300, height=300,
    )  # fmt: skip
    material = spec.add_material(name="grid", texuniform=True, texrepeat=[5, 5])
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    # The holosoma MJCF pairs each foot capsule with a geom named "floor": uneven ground keeps the name.
    if cfg.terrain_height > 0:
        half = TERRAIN_SIZE_M / 2
        heights = terrain_heights(cfg.terrain_height, cfg.terrain_seed)
        spec.add_hfield(name="terrain", size=[half, half, cfg.terrain_height, 0.1], nrow=TERRAIN_CELLS, ncol=TERRAIN_CELLS,
                        userdata=heights.ravel().tolist())  # fmt: skip
        spec.worldbody.add_geom(
            name="floor", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain", material="grid",
            friction=[cfg.floor_friction, 0.005, 0.0001], group=2,
        )  # fmt: skip
    else:
        spec.worldbody.add_geom(
            name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.01], material="grid",
            friction=[cfg.floor_friction, 0.005, 0.0001], group=2,
        )  # fmt: skip
    spec.worldbody.add_light(pos=[0, 0, 3], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, castshadow=0)
    # A camera that follows the pelvis, for videos.
    pelvis = spec.body("pelvis")
    pelvis.add_camera(
        name="track", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=[1.6, -1.6, 0.35], xyaxes=[0.707, 0.707, 0, -0.107, 0.107, 0.988]
    )


def _make_pd_actuators(spec: mujoco.MjSpec) -> None:
    for actuator in spec.actuators:
        limit = EFFORT_LIMITS[actuator.target]
        actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        actuator.gainprm[0] = 1.0
        actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        actuator.biasprm[:3] = [0.0, 0.0, 0.0]
        actuator.ctrllimited = False
        actuator.forcelimited = True
        actuator.forcerange = [-limit, limit]
