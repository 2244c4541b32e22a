"""Shared fixtures: the real G1 assets and model, and tiny ONNX policies built in-process."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from controller.assets import Assets, ensure_assets
from controller.commands.velocity import ZERO, VelocityCommand
from controller.text.kinematic import ideal_state
from hw import g1, quat
from hw.g1 import JOINT_NAMES
from hw.types import RobotState

if TYPE_CHECKING:
    import mujoco

    from controller.reference.planned import PlannedReference
    from controller.reference.source import ReferenceSource
    from controller.reference.window import ReferenceWindow

ROOT = Path(__file__).resolve().parent.parent  # the repository

# A suite started in the background without job control (`.ci/run &`, nohup) inherits SIGINT ignored, and an ignored
# signal stays ignored across exec: the runs that tests stop with Ctrl-C would not stop. A handled one is reset to the
# default in the runs started from here.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session", autouse=True)
def _process_scheduling_is_left_alone() -> Iterator[None]:
    """No test may pin the pytest process or change its scheduling (later tests would run under it):
    pinning and real-time requests belong in a subprocess or a helper thread."""
    before = (os.sched_getaffinity(0), os.sched_getscheduler(0))
    yield
    after = (os.sched_getaffinity(0), os.sched_getscheduler(0))
    assert after == before, f"a test changed the pytest process's (CPU affinity, scheduler) from {before} to {after}"


def _repository_status() -> list[str] | None:
    """`git status` of the repository, ignored files included (caches and the venv left out); None outside a git checkout."""
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], capture_output=True, text=True, cwd=ROOT, timeout=60)
    except FileNotFoundError:  # no git on this machine
        return None
    if top.returncode != 0 or Path(top.stdout.strip()).resolve() != ROOT:
        return None  # an installed copy of the tests, or a tree inside another repository
    caches = (".venv", ".pytest_cache", ".mypy_cache", ".ruff_cache", "*.egg-info")
    excluded = [f":(exclude,glob){c}/**" for c in caches] + [":(exclude,glob)**/__pycache__/**"]
    status = subprocess.run(
        ["git", "--no-optional-locks", "status", "--porcelain", "--untracked-files=all", "--ignored=traditional", "--", ".", *excluded],
        capture_output=True, text=True, cwd=ROOT, check=True, timeout=60,
    )  # fmt: skip
    return status.stdout.splitlines()


@pytest.fixture(scope="session", autouse=True)
def _nothing_is_left_in_the_repository() -> Iterator[None]:
    """A test writes into its tmp_path, never into the checkout (ignored outputs such as runs/ and MUJOCO_LOG.TXT included)."""
    before = _repository_status()
    yield
    if before is None:
        return
    left = sorted(set(_repository_status() or []) - set(before))
    assert not left, f"the tests left these in the repository (git status): {left}"


@pytest.fixture(scope="session", autouse=True)
def _work_in_a_temporary_directory(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The session works in a temporary directory, and so does every process it starts (the CLI, the simulated robot):
    whatever lands in the working directory (MuJoCo's MUJOCO_LOG.TXT on a warning) stays out of the repository."""
    home = Path.cwd()
    os.chdir(tmp_path_factory.mktemp("cwd"))
    yield
    os.chdir(home)


@pytest.fixture(scope="session")
def assets() -> Assets:
    return ensure_assets(quiet=True)


@pytest.fixture(scope="session")
def g1_model(assets: Assets) -> mujoco.MjModel:
    from sim.world import build_model

    return build_model(assets.g1_mjcf)


def make_linear_onnx(
    path: Path,
    weight: np.ndarray,
    joint_names: tuple[str, ...] = JOINT_NAMES,
    input_name: str = "actor_obs",
    output_name: str = "action",
    metadata: dict[str, object] | None = None,
    nan_output: bool = False,
) -> Path:
    """An ONNX graph `action = obs @ weight` (or all-NaN), self-describing like holosoma's exports."""
    n_in, n_out = weight.shape
    w = numpy_helper.from_array(weight.astype(np.float32), name="W")
    nodes = [helper.make_node("MatMul", [input_name, "W"], ["mm"])]
    inits = [w]
    if nan_output:
        inits.append(numpy_helper.from_array(np.full((1, n_out), np.nan, dtype=np.float32), name="N"))
        nodes.append(helper.make_node("Add", ["mm", "N"], [output_name]))
    else:
        nodes.append(helper.make_node("Identity", ["mm"], [output_name]))
    graph = helper.make_graph(
        nodes,
        "tiny_policy",
        [helper.make_tensor_value_info(input_name, TensorProto.FLOAT, [1, n_in])],
        [helper.make_tensor_value_info(output_name, TensorProto.FLOAT, [1, n_out])],
        initializer=inits,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    meta = {"dof_names": list(joint_names), "kp": [40.0] * len(joint_names), "kd": [2.0] * len(joint_names)}
    meta.update(metadata or {})
    for key, value in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, json.dumps(value)
    onnx.save(model, str(path))
    return path


@pytest.fixture
def linear_onnx(tmp_path: Path) -> Callable[..., Path]:
    def factory(weight: np.ndarray, name: str = "tiny.onnx", **kwargs: object) -> Path:
        return make_linear_onnx(tmp_path / name, weight, **kwargs)  # type: ignore[arg-type]

    return factory


G1CTL = [sys.executable, "-m", "controller.cli"]


def g1ctl(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """The real CLI in a subprocess, run in a fresh temporary directory (paths it is given are absolute)."""
    with tempfile.TemporaryDirectory(prefix="g1ctl-cwd-") as cwd:
        return subprocess.run([*G1CTL, *args], capture_output=True, text=True, cwd=cwd, env={**os.environ, **(env or {})}, timeout=300)


def one_line_error(result: subprocess.CompletedProcess[str], code: int = 2) -> str:
    """The single stderr line of a CLI run that ended with `code`, checked to be one line and no traceback."""
    assert result.returncode == code, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    return lines[0]


def turning_walk(frames: int = 80, yaw0: float = 2.5, turn: float = 0.04, seed: int = 0) -> np.ndarray:
    """A turning walk far from the origin, with tilt and joint motion."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)
    yaw = yaw0 + turn * t
    qpos = np.zeros((frames, g1.QPOS_SIZE))
    qpos[:, 0] = 5.0 + np.cumsum(0.03 * np.cos(yaw))
    qpos[:, 1] = -3.0 + np.cumsum(0.03 * np.sin(yaw))
    qpos[:, 2] = 0.78 + 0.01 * np.sin(t / 3)
    tilt = quat.exp(np.stack((0.05 * np.sin(t / 5), 0.03 * np.cos(t / 4), np.zeros(frames)), axis=-1))
    qpos[:, 3:7] = quat.multiply(quat.from_yaw(yaw), tilt)
    limits = np.array([joint.position_limits for joint in g1.G1_JOINTS])
    qpos[:, 7:] = np.clip(0.3 * np.sin(t[:, None] / 6 + rng.uniform(0, 6, g1.NUM_JOINTS)), *limits.T)  # keyframes must be within them
    return qpos


HANG_S = 10.0  # how long a test waits for what must happen: only a hang runs into it, a loaded machine is slow, not wrong


def wait_for(condition: Callable[[], bool], timeout: float = HANG_S) -> bool:
    """Poll `condition` every 5 ms until it holds (True) or `timeout` s pass (False): for threads, processes and
    kernel buffers under test."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


_TEXT_DIM = 384  # the planner's text slot (controller.planner.request.TEXT_EMBEDDING_DIM)


def fake_embed(strings: list[str]) -> np.ndarray:
    """A stand-in sentence encoder: a unit vector per string, stable across runs."""
    if not strings:
        return np.zeros((0, _TEXT_DIM))
    out = np.stack([np.random.default_rng(zlib.crc32(s.encode())).standard_normal(_TEXT_DIM) for s in strings])
    return out / np.linalg.norm(out, axis=1, keepdims=True)


@pytest.fixture(scope="session")
def claim_dds_domain() -> Iterator[Callable[[], int]]:
    """A function that claims a DDS domain for this test session alone, as the product claims one for a simulated run
    (`hw.dds.domains`): two test runs on one machine never hear each other, nor a simulated run beside them.

    Every claim is held until the session ends, so no two tests share a domain either: Cyclone keeps a domain's
    configuration for the life of the process, and a robot process of an earlier test may still be winding down.
    """
    from hw.dds.domains import SPARE_DOMAINS, DomainClaim, claim_domain

    claims: list[DomainClaim] = []

    def claim() -> int:
        claims.append(claim_domain(SPARE_DOMAINS.start))
        return claims[-1].domain

    yield claim
    for held in claims:
        held.release()


def a_robot_config(tmp_path: Path, domain: int) -> Path:
    """A copy of the shipped real G1 config (`g1-dds.yaml`) pointed at loopback on `domain`, where a stand-in robot
    (`g1ctl robot --dds`) answers."""
    from hw.shipped import config_dir

    text = (config_dir("hardware") / "g1-dds.yaml").read_text()
    assert "dds: {domain: 0, interface: eth0, peers: []," in text
    path = tmp_path / "my-g1.yaml"
    text = text.replace("dds: {domain: 0, interface: eth0, peers: [],", f"dds: {{domain: {domain}, interface: lo, peers: [127.0.0.1],")
    # The stand-in robot starts standing in the default pose, off any gantry: a 3 s ramp under PD alone would tip it over.
    path.write_text(text.replace("soft_start_time: 3.0", "soft_start_time: 0.2"))
    return path


@pytest.fixture
def sim_dds_config(tmp_path: Path, claim_dds_domain: Callable[[], int]) -> Callable[[], Path]:
    """A function that writes a copy of the shipped sim-dds hardware config on a DDS domain of its own (`claim_dds_domain`)."""
    from hw.shipped import config_dir

    def on_a_domain_of_its_own() -> Path:
        text = (config_dir("hardware") / "sim-dds.yaml").read_text()
        domain = claim_dds_domain()
        path = tmp_path / f"sim-dds-{domain}.yaml"
        path.write_text(text.replace("dds: {domain: 1,", f"dds: {{domain: {domain},"))
        assert f"domain: {domain}," in path.read_text()
        return path

    return on_a_domain_of_its_own


def sim_can_on_real_buses(tmp_path: Path, can0: str | None = None) -> Path:
    """sim-can's joint map as a real robot's config (`simulated: false`, no IMU): nothing answers on its virtual CAN
    channels. `can0`: another definition of bus can0 (such as a socketcan channel that does not exist)."""
    from hw.shipped import config_dir

    text = (config_dir("hardware") / "sim-can.yaml").read_text()
    lines = [line for line in text.splitlines() if not line.startswith(("imu_model:", "imu:", "  imu:"))]
    text = "\n".join(lines).replace("simulated: true", "simulated: false")
    if can0 is not None:
        old = "  can0: {kind: can, interface: virtual, channel: g1-can0, bitrate: 1000000}"
        assert old in text
        text = text.replace(old, f"  can0: {can0}")
    path = tmp_path / "real-buses.yaml"
    path.write_text(text + "\n")
    return path


def planar_state(
    t: float, x: float, y: float, heading_deg: float = 0.0, v: tuple[float, float] = (0.0, 0.0), yaw_rate: float = 0.0
) -> RobotState:
    """The robot at (x, y) facing `heading_deg`, moving at world velocity `v`, turning at `yaw_rate` (no tilt)."""
    joints = np.array(g1.default_joint_vector())
    return RobotState(
        time=t,
        joint_pos=joints,
        joint_vel=np.zeros_like(joints),
        base_quat=quat.from_yaw(math.radians(heading_deg)),
        base_ang_vel=np.array([0.0, 0.0, yaw_rate]),
        base_pos=np.array([x, y, g1.STANDING_PELVIS_HEIGHT]),
        base_lin_vel=np.array([v[0], v[1], 0.0]),
    )


class Terminal:
    """A pseudo-terminal: the source reads its slave side, the test types on the master side."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()

    def fileno(self) -> int:
        return self.slave

    def type(self, keys: str) -> None:
        os.write(self.master, keys.encode())

    def hang_up(self) -> None:
        os.close(self.master)
        self.master = -1

    def close(self) -> None:
        for fd in (self.master, self.slave):
            if fd >= 0:
                os.close(fd)


# An ideal robot ticked one step at a time under a reference source: its root moves exactly as commanded (the kinematic
# module's `ideal_state`), for tests that act between ticks (instructions given while it runs).
class IdealRobot:
    def __init__(self, reference: ReferenceSource, planned: PlannedReference, rate_hz: float = 50.0) -> None:
        self.reference, self.planned, self.dt = reference, planned, 1.0 / rate_hz
        self.t, self.pose, self.velocity = 0.0, (0.0, 0.0, 0.0), ZERO
        qpos = np.array(g1.standing_qpos())
        self.state = RobotState(
            time=0.0, joint_pos=qpos[g1.QPOS_JOINTS], joint_vel=np.zeros(g1.NUM_JOINTS), base_quat=qpos[g1.QPOS_ROOT_QUAT],
            base_ang_vel=np.zeros(3), base_pos=qpos[g1.QPOS_ROOT_POS], base_lin_vel=np.zeros(3),
        )  # fmt: skip
        self.window: ReferenceWindow | None = None
        reference.start(self.state)

    def tick(self, device: VelocityCommand = ZERO, gesture: str = "", hold: bool = False) -> ReferenceWindow:
        """One control period: the robot moves on the last command, then the reference is asked with the device's."""
        x, y, heading = self.pose
        c, s = math.cos(heading), math.sin(heading)
        v, dt = self.velocity, self.dt
        self.pose = (x + dt * (c * v.vx - s * v.vy), y + dt * (s * v.vx + c * v.vy), heading + dt * v.yaw_rate)
        self.t += dt
        self.state = ideal_state(self.planned.buffer.sample(self.t), self.pose, self.velocity, self.t)
        self.window = self.reference.window(self.state, device, gesture, hold)
        self.velocity = self.window.velocity
        return self.window

    def run(self, seconds: float, device: VelocityCommand = ZERO, gesture: str = "", hold: bool = False) -> None:
        for _ in range(round(seconds / self.dt)):
            self.tick(device, gesture, hold)

    def until(self, condition: Callable[[], bool], max_seconds: float, device: VelocityCommand = ZERO) -> bool:
        """Tick until `condition` holds (True) or `max_seconds` of run time pass (False)."""
        for _ in range(round(max_seconds / self.dt)):
            if condition():
                return True
            self.tick(device)
        return condition()
