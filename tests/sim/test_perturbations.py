"""Perturbations: seeded, applied where they belong, and they move the run the way they should."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from controller.runtime.driver import run
from controller.runtime.run_config import RunConfig
from hw import g1
from hw.errors import ConfigError
from hw.types import JointCommand
from sim.perturbations import Perturbations, PerturbedRobot, Pushes, apply_to_model, load_perturbations, push_schedule
from sim.robot import SimRobot
from sim.world import build_model


def test_pushes_are_scheduled_from_the_seed() -> None:
    pushes = Pushes(force_n=100.0, duration_s=0.2, interval_s=3.0, start_s=1.0)
    first = push_schedule(pushes, 10.0, np.random.default_rng(4))
    assert [p.start for p in first] == [1.0, 4.0, 7.0] and all(p.end == pytest.approx(p.start + 0.2) for p in first)
    assert first == push_schedule(pushes, 10.0, np.random.default_rng(4)) != push_schedule(pushes, 10.0, np.random.default_rng(5))
    assert all(np.hypot(p.force[0], p.force[1]) == pytest.approx(100.0) for p in first) and pushes.impulse_ns == pytest.approx(20.0)
    fixed = push_schedule(Pushes(force_n=50.0, direction_deg=90.0), 7.0, np.random.default_rng(0))
    assert fixed[0].force == pytest.approx((0.0, 50.0, 0.0), abs=1e-9)


def test_friction_payload_and_motor_strength_change_the_model(assets: object) -> None:
    model = build_model(assets.g1_mjcf)  # type: ignore[attr-defined]
    friction, mass = model.geom_friction[:, 0].copy(), model.body_mass[model.body(g1.TORSO_BODY).id]
    pairs, limits = model.pair_friction.copy(), model.actuator_forcerange.copy()
    apply_to_model(model, Perturbations(friction_scale=0.5, payload_kg=4.0, torque_scale=0.8))
    assert np.allclose(model.geom_friction[:, 0], 0.5 * friction)
    assert model.npair > 0 and np.allclose(model.pair_friction[:, :2], 0.5 * pairs[:, :2])  # the feet's pairs with the floor
    assert np.allclose(model.pair_friction[:, 2:], pairs[:, 2:])  # torsional and rolling friction as they were
    assert model.body_mass[model.body(g1.TORSO_BODY).id] == pytest.approx(mass + 4.0)
    assert np.allclose(model.actuator_forcerange, 0.8 * limits)


def _feet_slide(mjcf: Path, friction_scale: float) -> float:
    """How far (m) the feet of a G1 held standing slide under 60 N pulling each foot sideways for 0.3 s."""
    model = build_model(mjcf)
    apply_to_model(model, Perturbations(friction_scale=friction_scale))
    sim = SimRobot(model)
    n, feet = g1.NUM_JOINTS, [model.body(body).id for body in g1.ANKLE_BODIES]
    q = np.array(g1.default_joint_vector())
    sim.write(JointCommand(q=q, dq=np.zeros(n), kp=np.full(n, 150.0), kd=np.full(n, 5.0), tau_ff=np.zeros(n)))
    sim.step(int(0.5 / sim.timestep))
    before = sim.data.xpos[feet, :2].copy()
    sim.data.xfrc_applied[feet, 0] = 60.0  # 120 N in all: below the floor's grip (0.8 x 35 kg x g), far above a quarter of it
    sim.step(int(0.3 / sim.timestep))
    slide = float(np.max(np.linalg.norm(sim.data.xpos[feet, :2] - before, axis=1)))
    sim.close()
    return slide


def test_a_low_friction_makes_the_feet_slide(assets: object) -> None:
    """The foot-floor contacts are explicit pairs in the G1 MJCF: the scale must reach their friction."""
    mjcf = assets.g1_mjcf  # type: ignore[attr-defined]
    assert _feet_slide(mjcf, 1.0) < 0.005
    assert _feet_slide(mjcf, 0.25) > 0.1


def test_latency_gains_noise_and_drops_sit_between_robot_and_controller(assets: object) -> None:
    sim = SimRobot(build_model(assets.g1_mjcf))  # type: ignore[attr-defined]
    p = Perturbations(latency_ticks=1, gain_scale=0.5, joint_noise_rad=0.01, drop_rate=0.5)
    robot = PerturbedRobot(sim, p, np.random.default_rng(0))
    n = g1.NUM_JOINTS
    first = JointCommand(q=np.full(n, 0.1), dq=np.zeros(n), kp=np.full(n, 40.0), kd=np.full(n, 2.0), tau_ff=np.zeros(n))
    second = JointCommand(q=np.full(n, 0.2), dq=np.zeros(n), kp=np.full(n, 40.0), kd=np.full(n, 2.0), tau_ff=np.zeros(n))
    before = sim.data.ctrl.copy()
    robot.write(first)
    assert np.array_equal(sim.data.ctrl, before)  # one tick late: nothing yet
    robot.write(second)
    assert np.allclose(sim.data.ctrl, 20.0 * 0.1)  # the first command arrives, its gains halved (kp q* = 20 * 0.1)
    readings = [robot.read() for _ in range(40)]
    repeated = sum(a is b for a, b in itertools.pairwise(readings))
    assert 8 <= repeated <= 32  # about half the readings are the previous one again
    truth = sim.read().joint_pos
    assert 0.002 < float(np.std(readings[-1].joint_pos - truth)) < 0.03
    robot.close()
    sim.close()


def test_a_hard_push_topples_the_robot_and_the_same_seed_gives_the_same_run(tmp_path: Path) -> None:
    hard = Perturbations(pushes=Pushes(force_n=900.0, duration_s=0.1, interval_s=2.0, start_s=1.5))
    gentle = Perturbations(pushes=Pushes(force_n=60.0, duration_s=0.1, interval_s=2.0, start_s=1.5))
    falls = run(RunConfig(duration=4.0, perturbations=hard))
    calm = run(RunConfig(duration=4.0, perturbations=gentle, seed=3))
    again = run(RunConfig(duration=4.0, perturbations=gentle, seed=3))
    assert falls["falls"] >= 1 and calm["falls"] == 0
    assert calm["pushes"] == again["pushes"] and calm["final_base_position"] == again["final_base_position"]
    assert calm["push_impulse_ns"] == pytest.approx(6.0) and calm["perturbations"]["pushes"]["force_n"] == 60.0


def test_shipped_sets_load_and_mistakes_are_one_line(tmp_path: Path) -> None:
    assert load_perturbations("push").pushes == Pushes(force_n=150.0, duration_s=0.1, interval_s=4.0, start_s=2.0)
    assert load_perturbations("rough").senses
    bad = tmp_path / "bad.yaml"
    bad.write_text("drop_rate: 1.5\n")
    with pytest.raises(ConfigError, match="drop_rate"):
        load_perturbations(str(bad))


def test_ranges_are_drawn_from_the_seed_whole_numbers_for_whole_number_fields() -> None:
    from sim.perturbations import draw_perturbations, has_ranges

    values = {"friction_scale": [0.4, 1.0], "latency_ticks": [0, 3], "pushes": {"force_n": [100, 400]}, "payload_kg": 5.0}
    assert has_ranges(values) and not has_ranges({"pushes": {"force_n": 100.0}})
    draws = [draw_perturbations(values, seed, "test") for seed in range(40)]
    assert draws[7] == draw_perturbations(values, 7, "test") and len({d.friction_scale for d in draws}) == 40
    assert all(0.4 <= d.friction_scale <= 1.0 and 100 <= d.pushes.force_n <= 400 and d.payload_kg == 5.0 for d in draws)  # type: ignore[union-attr]
    assert {d.latency_ticks for d in draws} == {0, 1, 2, 3} and all(isinstance(d.latency_ticks, int) for d in draws)
    with pytest.raises(ConfigError, match=r"test: pushes.force_n: a range is \[low, high\] with low <= high"):
        draw_perturbations({"pushes": {"force_n": [400, 100]}}, 0, "test")
    with pytest.raises(ConfigError, match="drop_rate"):
        draw_perturbations({"drop_rate": [1.2, 1.5]}, 3, "test")  # a draw out of range is refused like a value


def test_a_suite_condition_with_ranges_draws_per_episode_and_stays_off_the_push_curve() -> None:
    from controller.eval.suite import SuiteConfig, episodes

    suite = SuiteConfig(
        name="r", duration_s=1.0, perturbations={"fixed": {"friction_scale": 0.5}, "random": {"friction_scale": [0.3, 1.0]}}
    )
    every = episodes(suite)
    fixed = [e for e in every if e.condition == "fixed"]
    drawn = [e for e in every if e.condition == "random"]
    assert {e.perturbations.friction_scale for e in fixed} == {0.5} and not any(e.randomized for e in fixed)
    assert len({e.perturbations.friction_scale for e in drawn}) == 3 and all(e.randomized for e in drawn)
    assert [e.perturbations for e in drawn] == [e.perturbations for e in episodes(suite) if e.condition == "random"]


@pytest.mark.slow  # a run through the simulated CAN buses
def test_perturbations_reach_a_run_through_simulated_hardware() -> None:
    shove = Perturbations(pushes=Pushes(force_n=900.0, duration_s=0.1, interval_s=2.0, start_s=1.0), latency_ticks=1, joint_noise_rad=0.005)
    report = run(RunConfig(duration=3.0, hardware="sim-can", perturbations=shove))
    assert report["falls"] == 1 and report["pushes"][0]["start"] == 1.0  # on hardware a fall ends the run
    assert report["hw"]["faults"] == 0 and report["perturbations"]["latency_ticks"] == 1


def test_uneven_ground_is_seeded_flat_at_the_start_and_is_the_floor(assets: object) -> None:
    import mujoco

    from sim.world import TERRAIN_CELLS, SceneConfig, terrain_heights

    heights = terrain_heights(0.1, seed=2)
    assert heights.shape == (TERRAIN_CELLS, TERRAIN_CELLS) and heights.min() >= 0.0 and heights.max() <= 1.0
    assert heights[TERRAIN_CELLS // 2, TERRAIN_CELLS // 2] == 0.0 and heights.std() > 0.05  # flat where the robot starts
    assert np.array_equal(heights, terrain_heights(0.1, seed=2)) and not np.array_equal(heights, terrain_heights(0.1, seed=3))
    model = build_model(assets.g1_mjcf, SceneConfig(terrain_height=0.1, terrain_seed=2))  # type: ignore[attr-defined]
    floor = model.geom("floor")
    assert floor.type[0] == mujoco.mjtGeom.mjGEOM_HFIELD and model.hfield_size[0][2] == pytest.approx(0.1)
    with pytest.raises(ConfigError, match="terrain_height_m"):
        Perturbations(terrain_height_m=0.5)
