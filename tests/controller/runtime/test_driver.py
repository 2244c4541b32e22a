"""One run driver: backends from the registry, the plan of the run resolved once, and the simulator and a robot driven alike.

The robot is the stand-in of test_run_robot.py (`g1ctl robot --dds` started by hand, on its gantry so that a loaded
machine cannot tip it over) behind a copy of `g1-dds.yaml`: the registry's `real-dds` backend, no simulator in the run.
"""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest

import hw.jointmap
from controller.assets import Assets
from controller.cli.main import main
from controller.planner import process as planner_process
from controller.runtime.backend import Backend
from controller.runtime.backend_registry import BACKENDS, backend_entry, choose_backend, robot_kind
from controller.runtime.bus_process import BusProcessBackend
from controller.runtime.dds_backend import RealDdsBackend, SimulatedDdsBackend
from controller.runtime.driver import run
from controller.runtime.hardware_backend import RealBusesBackend
from controller.runtime.run_config import RunConfig
from controller.runtime.run_plan import resolve_run
from controller.runtime.session import Session
from controller.runtime.sim_backends import DirectSimBackend, PerturbedSimBackend, SimulatedHardwareBackend
from hw.dds.config import DdsHardwareConfig
from hw.errors import ConfigError, HardwareFault, MotorNotFoundError, RunAborted
from hw.shipped import config_dir
from sim.perturbations import Perturbations
from tests.conftest import a_robot_config, g1ctl

# What each config kind is driven by; the shipped configs name all but real buses (your own config: `a_real_bus_config`).
SHIPPED_KINDS = {None: "simulator", "sim-can": "simulated-buses", "sim-mixed": "simulated-buses", "sim-dds": "simulated-dds",
                 "g1-dds": "real-dds", "sim-can-process": "simulated-buses-process",
                 "sim-mixed-process": "simulated-buses-process"}  # fmt: skip
BACKEND_CLASSES: dict[str, type[Backend]] = {
    "simulator": DirectSimBackend, "simulated-buses": SimulatedHardwareBackend, "simulated-dds": SimulatedDdsBackend,
    "real-dds": RealDdsBackend, "real-buses": RealBusesBackend, "simulated-buses-process": BusProcessBackend,
}  # fmt: skip


def a_real_bus_config(tmp_path: Path) -> Path:
    """sim-can's buses marked as real hardware (`simulated: false`): a robot on real CAN buses (issue 22 point 2)."""
    lines = (config_dir("hardware") / "sim-can.yaml").read_text().splitlines()
    text = "\n".join(line for line in lines if not line.startswith("imu_model:"))  # a real IMU brings its own noise
    assert "simulated: true" in text
    path = tmp_path / "my-can.yaml"
    path.write_text(text.replace("simulated: true", "simulated: false"))
    return path


# -- the registry ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("hardware", "kind"), SHIPPED_KINDS.items(), ids=str)
def test_every_config_kind_maps_to_its_backend(hardware: str | None, kind: str) -> None:
    choice = choose_backend(hardware)
    assert robot_kind(choice.hardware) == kind and choice.entry is BACKENDS[kind] and choice.hardware_name == hardware
    entry, cls = choice.entry, BACKEND_CLASSES[kind]
    module, _, function = entry.build.partition(":")
    assert entry.builder() is getattr(importlib.import_module(module), function)
    # What the plan checks before the run and what the built backend does agree.
    assert cls.measures_base_position == entry.measures_base_position
    assert cls.paced_on_wall_clock == (entry.clock == "wall")


def test_every_backend_kind_is_shipped_or_named(tmp_path: Path) -> None:
    assert set(BACKENDS) == {*SHIPPED_KINDS.values(), "real-buses"}
    assert {name for name, entry in BACKENDS.items() if not entry.simulated} == {"real-dds", "real-buses"}
    choice = choose_backend(str(a_real_bus_config(tmp_path)))  # your robot's bus config
    assert robot_kind(choice.hardware) == "real-buses" and choice.entry is BACKENDS["real-buses"]
    module, _, function = choice.entry.build.partition(":")
    assert choice.entry.builder() is getattr(importlib.import_module(module), function)
    assert RealBusesBackend.paced_on_wall_clock and choice.entry.clock == "wall" and not choice.entry.measures_base_position


def test_a_kind_no_backend_drives_is_refused_in_one_line() -> None:
    with pytest.raises(ConfigError, match=r"^x names a warp-drive robot, which no run backend drives \(run backends: simulator, "):
        backend_entry("warp-drive", "x")


@pytest.mark.parametrize("kind", ["simulator", "simulated-buses"])
def test_the_in_process_builders_make_their_backend(kind: str, assets: Assets) -> None:
    hardware = {"simulator": None, "simulated-buses": "sim-can"}[kind]
    for perturbations in (None, Perturbations(friction_scale=0.8)):
        plan = resolve_run(RunConfig(hardware=hardware, duration=1.0, perturbations=perturbations))
        with ExitStack() as stack:
            side = plan.backend.builder()(plan, assets, stack)
            expected = PerturbedSimBackend if kind == "simulator" and perturbations is not None else BACKEND_CLASSES[kind]
            assert type(side.backend) is expected and side.world is not None and side.remote_dds is None
            assert (side.pushes is not None) == (perturbations is not None or kind == "simulated-buses")
            lower, upper = side.joint_limits
            assert lower.shape == upper.shape == (29,) and (lower < upper).all()


# -- the plan of the run ----------------------------------------------------------------------------------------------


def test_the_plan_decides_tracker_estimator_and_clock() -> None:
    plan = resolve_run(RunConfig())
    assert (plan.tracker, plan.estimator, plan.clock) == ("velocity", False, "simulated")
    assert plan.scenario is not None and plan.duration == plan.scenario.duration and plan.outputs.plot is None
    plan = resolve_run(RunConfig(planner=True, estimator=True, input="keyboard", report=Path("r.json")))
    assert (plan.tracker, plan.estimator, plan.clock, plan.scenario, plan.duration) == ("decoupled", True, "simulated-realtime", None, None)
    assert plan.outputs.plot == Path("r.png")
    plan = resolve_run(RunConfig(hardware="sim-can"))  # hardware measures no base position: the estimator always runs
    assert plan.estimator and plan.clock == "simulated" and plan.backend.name == "simulated-buses"
    plan = resolve_run(RunConfig(hardware="g1-dds", input="unitree-remote"))
    assert plan.estimator and plan.clock == "wall" and plan.backend.name == "real-dds" and plan.scenario is None


@pytest.mark.parametrize(
    ("cfg", "message"),
    [
        (RunConfig(hardware="g1-dds", video=Path("v.mp4"), picture=Path("p.png")), "--video, --picture: not on a real robot (they need"),
        (RunConfig(hardware="g1-dds", faults="dds-stale"), "--faults: not on a real robot (they need the simulator)"),
        (
            RunConfig(rt_priority=50),
            "--rt-priority and --cpu are for a real robot's run (--hardware g1-dds or your copy, or your robot's bus config)",
        ),
        (RunConfig(hardware="sim-dds", perturbations=Perturbations()), "--perturb needs the physics in this process"),
        (RunConfig(faults="lossy-can"), "--faults needs --hardware: faults are injected into simulated hardware"),
        (RunConfig(hardware="sim-can", faults="dds-stale"), "'robot:' faults are for a simulated G1 over DDS"),
        (RunConfig(tracker="whole-body"), "the whole-body tracker follows planned whole-body motion: add --planner"),
        (RunConfig(tracker="mimic"), "unknown tracker 'mimic' (valid: decoupled, velocity, whole-body)"),
        (RunConfig(duration=-1.0), "--duration must be positive, got -1.0"),
        (RunConfig(estimator_config="e.yaml"), "--estimator-config: the simulator measures the base position itself; add --estimator"),
    ],
    ids=lambda v: v if isinstance(v, str) else "",
)
def test_what_a_backend_cannot_honour_is_refused_before_anything_starts(cfg: RunConfig, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        resolve_run(cfg)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_a_bus_the_hardware_lacks_is_refused_by_the_plan(tmp_path: Path) -> None:
    plan = tmp_path / "can9.yaml"
    plan.write_text("buses:\n  can9: {drop_reply_prob: 0.1}\n")
    with pytest.raises(ConfigError, match=r"buses \['can9'\] are not in the hardware config \(buses: can0, can1, can2, can3, imu\)"):
        resolve_run(RunConfig(hardware="sim-can", faults=str(plan)))


@pytest.fixture
def hardware_loads(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """How often each hardware config file is loaded and validated (`hw.jointmap.load_robot_config` loads every one, of
    any kind, through `hardware_config_path`)."""
    counts: dict[str, int] = {}
    real_path = hw.jointmap.hardware_config_path

    def counting(name_or_path: str) -> Path:
        path = real_path(name_or_path)
        counts[path.name] = counts.get(path.name, 0) + 1
        return path

    monkeypatch.setattr(hw.jointmap, "hardware_config_path", counting)
    return counts


@pytest.mark.slow  # two short runs through simulated buses, in this process
def test_the_hardware_config_is_loaded_once_per_run(
    tmp_path: Path, hardware_loads: dict[str, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MUJOCO_GL", "egl")  # `g1ctl run` would choose headless OpenGL in the environment: kept to this test
    report = tmp_path / "sim.json"
    assert main(["sim", "--hardware", "sim-can", "--duration", "0.3", "--faults", "lossy-can", "--report", str(report)]) == 0
    assert hardware_loads == {"sim-can.yaml": 1} and json.loads(report.read_text())["hw"]["frames_received"] > 0
    hardware_loads.clear()
    args = ["run", "--hardware", "sim-mixed", "--duration", "0.3", "--input", "scripted", "--no-planner", "--headless"]
    assert main(args) == 0
    assert hardware_loads == {"sim-mixed.yaml": 1}
    hardware_loads.clear()
    resolve_run(RunConfig(hardware="g1-dds", input="unitree-remote"))  # a real robot's input reads the config's domain
    assert hardware_loads == {"g1-dds.yaml": 1}


# -- a simulator run and a robot run: one driver ----------------------------------------------------------------------

FAULT_TICK = 25  # 0.5 s into the run, at the tracker's 50 Hz


@pytest.fixture
def fault_mid_run(monkeypatch: pytest.MonkeyPatch) -> Callable[[BaseException], None]:
    """Make the run's 26th tick raise `exc`, as a robot side that fails mid-run raises out of a read or a write."""

    def inject(exc: BaseException) -> None:
        real_tick = Session.tick

        def tick(self: Session) -> bool:
            if self.ticks == FAULT_TICK:
                raise exc
            return real_tick(self)

        monkeypatch.setattr(Session, "tick", tick)

    return inject


def assert_ended_damped_by(report: dict[str, Any], reason: str, report_path: Path) -> None:
    """The run's report, written, says it ended damped by `reason` at the fault's tick, and its plot was drawn."""
    written = json.loads(report_path.read_text())
    assert written.keys() == report.keys() and written["damp_reason"] == report["damp_reason"]
    assert report["final_mode"] == "damp" and report["damp_reason"] == f"fault: {reason}" and "error" not in report
    assert report["damp_time"] >= FAULT_TICK / 50 - 0.01 and report["run_seconds"] == pytest.approx(report["damp_time"], abs=0.05)
    assert not report["interrupted"] and report["plot"] == str(report_path.with_suffix(".png"))
    assert report_path.with_suffix(".png").stat().st_size > 10_000


@pytest.mark.parametrize("exc", [HardwareFault("injected: bus can0 went silent"), MotorNotFoundError("injected: no reply from id 4")])
def test_a_fault_mid_run_on_the_simulator_ends_damped_with_its_cause(
    tmp_path: Path, fault_mid_run: Callable[[BaseException], None], exc: Exception
) -> None:
    fault_mid_run(exc)
    report_path = tmp_path / "sim.json"
    report = run(RunConfig(duration=2.0, report=report_path))
    assert_ended_damped_by(report, str(exc), report_path)
    assert report["damp_time"] == pytest.approx(FAULT_TICK / 50, abs=0.01) and report["backend"] == "simulator"


def test_ctrl_c_and_an_error_mid_run_are_reported_alike(tmp_path: Path, fault_mid_run: Callable[[BaseException], None]) -> None:
    fault_mid_run(KeyboardInterrupt())
    interrupted = run(RunConfig(duration=2.0, report=tmp_path / "interrupted.json"))
    assert interrupted["interrupted"] and interrupted["final_mode"] == "run" and interrupted["run_seconds"] == pytest.approx(0.5, abs=0.01)
    fault_mid_run(RuntimeError("injected: the controller broke"))
    with pytest.raises(RunAborted, match=r"^run aborted after 0\.5 s: injected: the controller broke; report: "):
        run(RunConfig(duration=2.0, report=tmp_path / "error.json"))
    error = json.loads((tmp_path / "error.json").read_text())
    assert error["error"] == "RuntimeError: injected: the controller broke" and (tmp_path / "error.png").is_file()


class StandInRobot:
    """A stand-in G1 (`g1ctl robot --dds`) answering on a domain of its own, hanging in its gantry."""

    def __init__(self, domain: int) -> None:
        self.domain = domain
        self.process = subprocess.Popen(
            [sys.executable, "-m", "controller.cli", "robot", "--dds", "--domain", str(domain), "--duration", "60", "--gantry"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip

    def stop(self) -> dict[str, Any]:
        """SIGTERM, and what the robot counted."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        out, err = self.process.communicate(timeout=20)
        assert self.process.returncode == 0, err
        return dict(json.loads(out.strip().splitlines()[-1]))


@pytest.fixture
def stand_in_robot(claim_dds_domain: Callable[[], int]) -> Iterator[StandInRobot]:
    if importlib.util.find_spec("cyclonedds") is None:
        pytest.skip("the g1 extra (cyclonedds) is not installed")
    robot = StandInRobot(claim_dds_domain())
    try:
        yield robot
    finally:
        if robot.process.poll() is None:
            robot.process.kill()
            robot.process.wait()


@pytest.mark.slow  # a robot process on DDS
def test_a_fault_mid_run_on_a_robot_ends_damped_with_its_cause_as_on_the_simulator(
    tmp_path: Path, fault_mid_run: Callable[[BaseException], None], stand_in_robot: StandInRobot, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    """The same fault, the same driver: `g1ctl run` on the simulator and on a robot end damped, say why in one line, exit 1,
    and write the report and its plot."""
    monkeypatch.setenv("MUJOCO_GL", "egl")  # `g1ctl run` would choose headless OpenGL in the environment: kept to this test
    fault_mid_run(HardwareFault("injected: bus can0 went silent"))
    config = a_robot_config(tmp_path, stand_in_robot.domain)
    reports = {"sim": tmp_path / "sim.json", "robot": tmp_path / "robot.json"}
    common = ["--duration", "3", "--input", "scripted", "--no-planner", "--headless"]
    for name, hardware in (("sim", []), ("robot", ["--hardware", str(config)])):
        assert main(["run", *hardware, *common, "--report", str(reports[name])]) == 1
        err = capsys.readouterr().err
        assert "g1ctl: run ended damped at " in err and err.strip().endswith("s: fault: injected: bus can0 went silent"), err
    counters = stand_in_robot.stop()
    sim, robot = (json.loads(reports[name].read_text()) for name in ("sim", "robot"))
    for name, report in (("sim", sim), ("robot", robot)):
        assert_ended_damped_by(report, "injected: bus can0 went silent", reports[name])
    assert (sim["backend"], robot["backend"]) == ("simulator", "real-dds") and robot["hardware"] == str(config)
    assert "real_time_factor" in sim and "real_time_factor" not in robot and "final_base_position" not in robot
    assert robot["hw"]["faults"] == 0  # the robot itself was sound: the host damped it for the fault it was told of
    assert counters["damping_commands"] >= 1 and counters["commands"] > 0  # and the robot took the damping


@pytest.mark.slow  # the simulated G1 in its own process
def test_the_robots_remote_is_read_on_the_domain_the_simulated_robot_took(tmp_path: Path, sim_dds_config: Callable[[], Path]) -> None:
    """The config's domain is held (here by this test session, as by another run on the machine), so the simulated G1 runs on
    a spare one: its remote, playing the scenario, is read there, not on the config's domain, where nothing answers."""
    if importlib.util.find_spec("cyclonedds") is None:
        pytest.skip("the g1 extra (cyclonedds) is not installed")
    config = sim_dds_config()
    configured = choose_backend(str(config)).hardware
    assert isinstance(configured, DdsHardwareConfig)
    report_path = tmp_path / "remote.json"
    result = g1ctl("sim", "--hardware", str(config), "--input", "unitree-remote", "--duration", "3", "--report", str(report_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(report_path.read_text())
    assert report["hw"]["domain"] != configured.dds.domain and report["input"] == "unitree-remote"
    assert report["input_losses"] == 0 and report["damp_reason"] == "", report["damp_reason"]


def test_a_planner_on_the_wall_clock_plans_in_a_process_on_a_cpu_of_its_own(monkeypatch: pytest.MonkeyPatch) -> None:
    cpus: list[int | None] = []

    class Recorded(planner_process.PlannerProcess):
        def __init__(self, cpu: int | None = None) -> None:
            cpus.append(cpu)
            super().__init__(cpu=cpu)

    monkeypatch.setattr(planner_process, "PlannerProcess", Recorded)
    intervals: list[float] = []
    real_tick = Session.tick

    def tick(self: Session) -> bool:
        intervals.append(sys.getswitchinterval())
        return real_tick(self)

    monkeypatch.setattr(Session, "tick", tick)
    before = sys.getswitchinterval()
    report = run(RunConfig(planner=True, realtime=True, duration=1.0))
    assert report["replans"] >= 8 and report["planner_failures"] == 0 and report["late_plans"] == 0
    assert cpus == [planner_process.planner_cpu(os.sched_getaffinity(0), None)]
    # replies get the interpreter lock within 1 ms while the run lasts; the setting ends with it
    assert set(intervals) == {planner_process.REPLY_SWITCH_INTERVAL_S} and sys.getswitchinterval() == before
