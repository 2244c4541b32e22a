"""Fault drills: plans strike at their time, the wire audit sees what the motors decoded, and the judge
says whether the stack did what the plan expects."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hw import g1
from hw.dds.domains import claim_domain
from hw.emulation import drill
from hw.emulation.drill import judge_drill
from hw.emulation.faults import FaultFile, FaultSpec, available_fault_plans, check_plan_fits, load_fault_file
from hw.emulation.g1_lowlevel import G1LowLevel, LowLevelConfig
from hw.emulation.plant import StaticPlant
from hw.emulation.wire_audit import WireAudit, WireLimits
from hw.errors import ConfigError
from hw.jointmap import HardwareConfig, load_hardware_config, load_robot_config
from hw.protocols import unitree_hg as hg

KNEE = g1.JOINT_NAMES.index("left_knee_joint")


def limits() -> WireLimits:
    return WireLimits.of(g1.JOINT_NAMES, load_hardware_config("sim-can").joints)


def test_outside_limits_allows_one_quantization_step_and_ignores_positions_without_stiffness() -> None:
    joint = load_hardware_config("sim-can").joints["left_knee_joint"]
    i = np.array([KNEE] * 5)
    hi = joint.position_limits[1]
    q = np.array([hi + 5e-4, hi + 0.01, hi + 0.01, 0.5, np.nan])
    kp = np.array([40.0, 40.0, 0.0, 40.0, 40.0])  # the third is a damping command: its position means nothing
    tau = np.array([0.0, 0.0, 0.0, 1.5 * joint.torque_limit, 0.0])
    wire = limits()
    assert wire.outside(i, q, np.zeros(5), kp, tau).tolist() == [False, True, False, True, True]
    rng = np.random.default_rng(0)  # one command at a time (a motor's control step) is judged by the same rule
    index = rng.integers(0, g1.NUM_JOINTS, 2000)
    q, dq, kp, tau = rng.uniform(-4, 4, 2000), rng.uniform(-40, 40, 2000), rng.choice([0.0, 40.0], 2000), rng.uniform(-150, 150, 2000)
    one = [wire.outside_one(int(j), float(a), float(b), float(c), float(d)) for j, a, b, c, d in zip(index, q, dq, kp, tau, strict=True)]
    assert one == wire.outside(index, q, dq, kp, tau).tolist() and 0 < sum(one) < 2000


def test_the_audit_counts_what_left_the_limits_and_when_every_motor_became_safe() -> None:
    audit = WireAudit(g1.JOINT_NAMES, limits())
    for t in (0.0, 0.002):
        for name in g1.JOINT_NAMES:
            audit.motor_step(name, t, "active", (0.1, 0.0, 40.0, 0.0))
    audit.motor_step("left_knee_joint", 0.004, "active", (5.0, 0.0, 40.0, 0.0))  # past the knee's 2.88 rad
    assert audit.safe_since() is None
    for i, name in enumerate(g1.JOINT_NAMES):
        audit.motor_step(name, 0.006 + 0.002 * (i == KNEE), "limp" if i == KNEE else "damping", None)
    report = audit.report()
    assert report["outside_limits"] == 1 and report["outside_examples"][0]["joint"] == "left_knee_joint"
    assert report["safe_since"] == 0.008 and report["limp_joints"] == ["left_knee_joint"] and report["observed_until"] == 0.008
    audit.motor_step("left_knee_joint", 0.01, "active", None)  # back to holding: not safe any more
    assert audit.safe_since() is None


def test_a_plan_holds_its_faults_back_until_their_time() -> None:
    plan = FaultSpec(over_temperature=(4,), drop_reply_prob=1.0, start_s=2.0, seed=7).plan()
    assert plan.over_temperature == set() and not plan.drop()
    plan.update(1.999)
    assert plan.over_temperature == set()
    plan.update(2.0)
    assert plan.over_temperature == {4} and plan.drop() and plan.pending is None
    assert not FaultSpec(seed=3).starts_fault and FaultSpec(bus_off=True, start_s=1.0).starts_fault


def test_every_shipped_plan_loads_fits_its_hardware_and_strikes_at_a_stated_time() -> None:
    for name in available_fault_plans():
        plan = load_fault_file(name)
        hardware = load_robot_config(plan.hardware)
        check_plan_fits(plan, name, dds=not isinstance(hardware, HardwareConfig))
        if isinstance(hardware, HardwareConfig):
            assert set(plan.buses) <= set(hardware.buses), name
        assert plan.expect.outcome == "ride-through" or plan.start_s in (0.0, 3.0), name  # at bring-up, or walking
    with pytest.raises(ConfigError, match="'robot:' faults are for a simulated G1 over DDS"):
        check_plan_fits(load_fault_file("dds-stale"), "dds-stale", dds=False)
    with pytest.raises(ConfigError, match="robot fault 'melt@3' must be KIND@SECONDS"):
        FaultFile(robot=("melt@3",))
    with pytest.raises(ConfigError, match="unknown fault plan 'nope'"):
        load_fault_file("nope")


def wire(safe_since: float | None, outside: int = 0, until: float = 5.0) -> dict[str, object]:
    return {"outside_limits": outside, "safe_since": safe_since, "observed_until": until, "limp_joints": []}


def test_the_judge_names_every_way_a_drill_fails() -> None:
    plan = load_fault_file("overheat-left-knee")
    hw = {"wire": wire(3.004), "fault_reasons": ["left_knee_joint: over-temperature 119 C"]}
    verdict = judge_drill(plan, "p", hw, fell=True)
    assert verdict["passed"] and verdict["damping_latency_s"] == 0.004
    late = judge_drill(plan, "p", hw | {"wire": wire(3.05, outside=2)}, fell=False)
    assert late["failures"] == [
        "2 commands outside the joint limits reached the motors",
        "every motor safe 50 ms after the fault, more than the 20 ms stated",
    ]
    assert judge_drill(plan, "p", hw | {"wire": wire(None)}, fell=False)["failures"] == ["not every motor ended damped or limp"]
    assert "already safe" in judge_drill(plan, "p", hw | {"wire": wire(2.5)}, fell=False)["failures"][0]
    assert "no latched fault names 'left_knee_joint'" in judge_drill(plan, "p", {"wire": wire(3.004)}, fell=False)["failures"][0]
    assert "run it longer" in judge_drill(plan, "p", hw | {"wire": wire(1.0, until=1.0)}, fell=False)["failures"][0]
    assert judge_drill(plan, "p", {}, fell=False)["failures"][0] == "no audit of the frames the motors decoded"
    lossy = load_fault_file("lossy-can")
    assert judge_drill(lossy, "l", {"wire": wire(None)}, fell=False)["passed"]
    assert judge_drill(lossy, "l", {"wire": wire(None), "fault_reasons": ["x"]}, fell=True)["failures"] == [
        "a fault latched: x",
        "the robot fell",
    ]
    wild = load_fault_file("wild-command")
    assert judge_drill(wild, "w", {"wire": wire(None), "clamped_values": 0}, fell=True)["failures"] == ["the safety layer clamped nothing"]


def test_the_g1_main_board_audits_every_command_it_takes() -> None:
    plant = StaticPlant(dict.fromkeys(g1.JOINT_NAMES, 0.0))
    cfg = load_robot_config("sim-dds")
    audit = WireAudit(g1.JOINT_NAMES, WireLimits.of(g1.JOINT_NAMES, cfg.joints))
    lowlevel = G1LowLevel(plant, LowLevelConfig(mode_machine=5), audit)
    record = hg.new_low_cmd(mode_machine=5)
    for i in range(g1.NUM_JOINTS):
        record["motor_cmd"][i]["mode"], record["motor_cmd"][i]["kp"], record["motor_cmd"][i]["kd"] = 1, 40.0, 1.0
    record["motor_cmd"][KNEE]["q"] = 3.5  # past the knee
    lowlevel.receive(hg.with_crc(record), 0.0)
    lowlevel.tick(0.0)
    assert audit.outside == 1 and audit.safe_since() is None
    damping = hg.new_low_cmd(mode_machine=5)
    for i in range(g1.NUM_JOINTS):
        damping["motor_cmd"][i]["mode"], damping["motor_cmd"][i]["kd"], damping["motor_cmd"][i]["q"] = 1, 2.0, 9.0  # q ignored
    lowlevel.receive(hg.with_crc(damping), 0.002)
    lowlevel.tick(0.002)
    assert audit.outside == 1 and audit.safe_since() == 0.002 and set(audit.state) == {"damping"}


def test_simulated_dds_runs_claim_domains_of_their_own(tmp_path: Path) -> None:
    first = claim_domain(7, tmp_path)
    second = claim_domain(7, tmp_path)
    assert (first.domain, second.domain) == (7, 100)
    first.release()
    third = claim_domain(7, tmp_path)
    assert third.domain == 7
    second.release()
    third.release()


def test_a_drill_criterion_joins_the_list_and_reads_the_runs_report(monkeypatch: pytest.MonkeyPatch) -> None:
    """How a criterion on another block of the report (the estimator's fault line) joins the IMU-bias drill's judging."""

    def estimator_quiet(plan: FaultFile, run: drill.JudgedRun) -> list[str]:
        fault = run.report.get("estimator", {}).get("fault")
        return [f"the estimator named a fault: {fault}"] if fault else []

    plan = load_fault_file("imu-bias")
    hw = {"wire": wire(None)}
    assert judge_drill(plan, "p", hw, fell=False)["passed"]
    assert judge_drill(plan, "p", hw, fell=True)["failures"] == ["the robot fell"]
    monkeypatch.setattr(drill, "CRITERIA", (*drill.CRITERIA, estimator_quiet))
    assert judge_drill(plan, "p", hw, fell=False, report={"estimator": {"fault": None}})["passed"]
    verdict = judge_drill(plan, "p", hw, fell=True, report={"estimator": {"fault": "diverged"}})
    assert verdict["failures"] == ["the robot fell", "the estimator named a fault: diverged"]
