"""Root springs: closed forms checked against integrating the spring ODE, real step-response numbers, curving walks, go-to-pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.planner.request import FPS
from controller.reference.root_spring import (
    RootState,
    RootTrajectoryError,
    SpringConfig,
    no_overshoot_gain,
    root_state_from_frames,
    root_trajectory,
    settle_trajectory,
    waypoint_command,
)
from hw import g1, quat
from hw.errors import ConfigError

HALFLIFE = 0.3
Y = 2 * math.log(2) / HALFLIFE  # Spring-It-On damping / 2 for the default halflife
REST = RootState(position=(1.0, -2.0), velocity=(0.0, 0.0), heading=0.4, yaw_rate=0.0)


def integrate(state: RootState, cmd: VelocityCommand, seconds: float, cfg: SpringConfig, substeps: int = 40) -> dict[str, np.ndarray]:
    """RK4 on the spring ODEs with the goal rotated continuously by the heading, sampled at every 30 fps frame."""
    y = 2 * math.log(2) / cfg.velocity_halflife
    yy = 2 * math.log(2) / cfg.heading_halflife

    def f(s: np.ndarray) -> np.ndarray:
        _, _, vx, vy, ax, ay, h, w, al = s
        gx = math.cos(h) * cmd.vx - math.sin(h) * cmd.vy
        gy = math.sin(h) * cmd.vx + math.cos(h) * cmd.vy
        return np.array(
            [
                vx,
                vy,
                ax,
                ay,
                -2 * y * ax - y * y * (vx - gx),
                -2 * y * ay - y * y * (vy - gy),
                w,
                al,
                -2 * yy * al - yy * yy * (w - cmd.yaw_rate),
            ]
        )

    s = np.array([*state.position, *state.velocity, *state.acceleration, state.heading, state.yaw_rate, state.yaw_acceleration])
    h = 1.0 / FPS / substeps
    out = []
    for _ in range(round(seconds * FPS)):
        for _ in range(substeps):
            k1 = f(s)
            k2 = f(s + h / 2 * k1)
            k3 = f(s + h / 2 * k2)
            k4 = f(s + h * k3)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(s)
    a = np.array(out)
    return {"positions": a[:, 0:2], "velocities": a[:, 2:4], "headings": a[:, 6], "yaw_rates": a[:, 7]}


def test_standing_still_with_a_zero_command_stays_put() -> None:
    traj = root_trajectory(REST, VelocityCommand(), 44)
    assert traj.length == 44
    assert np.allclose(traj.times, np.arange(1, 45) / 30.0)
    assert np.array_equal(traj.positions, np.tile([1.0, -2.0], (44, 1)))
    assert np.array_equal(traj.velocities, np.zeros((44, 2)))
    assert np.array_equal(traj.headings, np.full(44, 0.4))
    assert np.array_equal(traj.yaw_rates, np.zeros(44))


def test_forward_step_from_rest_has_the_spring_timing() -> None:
    # From rest, v(t) = v_g (1 - exp(-y t) (1 + y t)): 40.3 % after one halflife, half after 1.21, 97.4 % after four.
    traj = root_trajectory(REST, VelocityCommand(vx=0.5), 60)  # 2 s = 6.7 halflives
    speed = np.array([traj.local_velocity(k)[0] for k in range(traj.length)])
    assert speed[8] == pytest.approx(0.5 * (1 - 0.25 * (1 + 2 * math.log(2))), abs=1e-12)  # frame 8: t = 0.3 s
    assert speed[8] / 0.5 == pytest.approx(0.403, abs=1e-3)
    half = np.interp(0.25, speed, traj.times)  # speed rises monotonically
    assert half / HALFLIFE == pytest.approx(1.2105, abs=2e-3)  # "about one halflife"
    four = np.interp(4 * HALFLIFE, traj.times, speed)
    assert four / 0.5 > 0.95 and four / 0.5 == pytest.approx(0.974, abs=1e-3)
    assert np.all(np.diff(speed) > 0) and speed[-1] < 0.5
    assert np.allclose([traj.local_velocity(k)[1] for k in range(60)], 0.0, atol=1e-12)  # straight ahead, no sidestep
    d = traj.positions - [1.0, -2.0]
    assert np.allclose(d[:, 0] * math.sin(0.4) - d[:, 1] * math.cos(0.4), 0.0, atol=1e-12)  # along the heading


def test_closed_forms_match_a_fine_step_integration_of_the_spring_odes() -> None:
    cfg = SpringConfig(velocity_halflife=0.25, heading_halflife=0.4)
    state = RootState(position=(0.3, 0.1), velocity=(0.2, -0.1), acceleration=(0.8, 0.5), heading=0.0, yaw_rate=0.0)
    cmd = VelocityCommand(vx=0.6, vy=-0.2)  # heading stays 0: the goal is constant, the closed form exact
    traj = root_trajectory(state, cmd, 64, cfg)
    ref = integrate(state, cmd, 64 / FPS, cfg)
    assert np.abs(traj.velocities - ref["velocities"]).max() < 1e-6
    assert np.abs(traj.positions - ref["positions"]).max() < 1e-6
    turning = RootState(position=(0, 0), velocity=(0, 0), heading=3.0, yaw_rate=-0.4, yaw_acceleration=2.0)
    cmd = VelocityCommand(yaw_rate=0.7)
    traj = root_trajectory(turning, cmd, 64, cfg)
    ref = integrate(turning, cmd, 64 / FPS, cfg)
    assert np.abs(traj.yaw_rates - ref["yaw_rates"]).max() < 1e-6
    assert np.abs(traj.headings - ref["headings"]).max() < 1e-6
    assert traj.headings[-1] > math.pi  # unwrapped: continuous from 3.0 rad, not wrapped to -pi


def test_a_turning_walk_follows_the_continuously_rotating_goal_closely() -> None:
    # Frame-by-frame goals (heading at each frame's middle) against the ODE whose goal turns continuously.
    state = RootState(position=(0, 0), velocity=(0.3, 0.0), heading=0.0, yaw_rate=0.2)
    cmd = VelocityCommand(vx=0.8, vy=0.1, yaw_rate=1.0)
    traj = root_trajectory(state, cmd, 64)
    ref = integrate(state, cmd, 64 / FPS, SpringConfig())
    assert np.abs(traj.headings - ref["headings"]).max() < 1e-6
    assert np.abs(traj.velocities - ref["velocities"]).max() < 1e-4
    assert np.abs(traj.positions - ref["positions"]).max() < 5e-5  # 0.04 mm over a 2.1 s plan


def test_constant_yaw_rate_walks_a_circle_of_radius_v_over_w() -> None:
    v, w = 0.5, 0.5
    traj = root_trajectory(REST, VelocityCommand(vx=v, yaw_rate=w), 300)  # 10 s; settled after about 2 s
    settled = slice(150, None)
    p = traj.positions[settled]
    # Algebraic circle fit: x^2 + y^2 + D x + E y + F = 0.
    A = np.column_stack((p[:, 0], p[:, 1], np.ones(len(p))))
    d, e, f = np.linalg.lstsq(A, -(p**2).sum(axis=1), rcond=None)[0]
    centre = np.array([-d / 2, -e / 2])
    radius = math.sqrt(centre @ centre - f)
    assert np.abs(np.linalg.norm(p - centre, axis=1) - radius).max() < 1e-5  # on a circle
    assert radius == pytest.approx(v / w, rel=0.02)
    # Exactly: a spring chasing a goal that turns at w settles at y^2 / (y + i w)^2 of it.
    gain = Y**2 / complex(Y, w) ** 2
    assert radius == pytest.approx(v * abs(gain) / w, rel=1e-4)
    assert radius == pytest.approx(0.9884, abs=1e-3)
    vx, vy = traj.local_velocity(299)
    assert complex(vx, vy) == pytest.approx(v * gain, abs=1e-4)  # 1.2 % slower, 12 degrees behind the heading
    assert math.degrees(math.atan2(vy, vx)) == pytest.approx(-12.4, abs=0.1)
    assert traj.yaw_rates[-1] == pytest.approx(w, abs=1e-9)
    assert centre == pytest.approx(
        traj.positions[-1] + radius * np.array([-math.sin(traj.headings[-1] - 0.2162), math.cos(traj.headings[-1] - 0.2162)]), abs=1e-3
    )


def test_the_trajectory_continues_the_state_one_frame_period_later() -> None:
    dt = 1 / FPS
    # Heading held: the goal is constant, and the first frame is the state's Taylor series one frame on,
    # with the spring's own higher derivatives (jerk = -2y a0 - y^2 (v0 - goal), snap = -2y jerk - y^2 a0).
    still = RootState(position=(2.0, 1.0), velocity=(0.4, -0.3), acceleration=(1.0, 0.5), heading=-1.0, yaw_rate=0.0)
    traj = root_trajectory(still, VelocityCommand(vx=-0.2, vy=0.3), 24)
    assert traj.times[0] == pytest.approx(dt)
    p0, v0, a0 = (np.array(x) for x in (still.position, still.velocity, still.acceleration))
    goal = np.array([math.cos(-1.0) * -0.2 - math.sin(-1.0) * 0.3, math.sin(-1.0) * -0.2 + math.cos(-1.0) * 0.3])
    jerk = -2 * Y * a0 - Y**2 * (v0 - goal)
    snap = -2 * Y * jerk - Y**2 * a0
    assert np.abs(traj.positions[0] - (p0 + v0 * dt + a0 * dt**2 / 2 + jerk * dt**3 / 6 + snap * dt**4 / 24)).max() < 1e-6
    assert np.abs(traj.velocities[0] - (v0 + a0 * dt + jerk * dt**2 / 2 + snap * dt**3 / 6)).max() < 2e-4
    assert np.abs(traj.positions[0] - (p0 + v0 * dt)).max() < 1e-3  # no jump: within the acceleration term
    # Turning: the heading continues with its rate and acceleration.
    state = RootState(position=(2.0, 1.0), velocity=(0.4, -0.3), acceleration=(1.0, 0.5), heading=-1.0, yaw_rate=0.6, yaw_acceleration=-0.5)
    traj = root_trajectory(state, VelocityCommand(vx=-0.2, vy=0.3, yaw_rate=-0.5), 24)
    yaw_jerk = -2 * Y * -0.5 - Y**2 * (0.6 - -0.5)
    yaw_snap = -2 * Y * yaw_jerk - Y**2 * -0.5
    assert traj.headings[0] == pytest.approx(-1.0 + 0.6 * dt - 0.5 * dt**2 / 2 + yaw_jerk * dt**3 / 6 + yaw_snap * dt**4 / 24, abs=1e-6)
    assert traj.yaw_rates[0] == pytest.approx(0.6 - 0.5 * dt + yaw_jerk * dt**2 / 2 + yaw_snap * dt**3 / 6, abs=2e-4)
    # A finer sampling of the same motion is the same curve.
    fine = root_trajectory(state, VelocityCommand(vx=-0.2, vy=0.3, yaw_rate=-0.5), 240, fps=300.0)
    assert np.abs(fine.positions[9::10] - traj.positions).max() < 1e-4
    assert np.abs(fine.headings[9::10] - traj.headings).max() < 1e-12


def test_settling_stops_v0_halflife_over_ln2_further_on() -> None:
    state = RootState(position=(0, 0), velocity=(0.5, 0.0), heading=0.0, yaw_rate=0.8)
    traj = settle_trajectory(state, 120)
    assert traj.positions[-1] == pytest.approx([0.5 * HALFLIFE / math.log(2), 0.0], abs=1e-5)  # 0.216 m
    assert traj.positions[-1][0] == pytest.approx(0.2164, abs=1e-4)
    assert np.abs(traj.velocities[-1]).max() < 1e-4 and abs(traj.yaw_rates[-1]) < 1e-4
    assert traj.headings[-1] == pytest.approx(0.8 * HALFLIFE / math.log(2), abs=1e-5)


def test_end_of_plan_becomes_a_root_keyframe() -> None:
    traj = root_trajectory(REST, VelocityCommand(vx=0.5, yaw_rate=0.3), 44)
    (last,) = traj.root_keyframes()
    assert last.frame == 43 and last.root and not last.root_height and not last.joints.any()
    assert last.qpos[:2] == pytest.approx(traj.positions[43])
    assert float(quat.heading(last.qpos[3:7])) == pytest.approx(traj.headings[43])
    assert [k.frame for k in traj.root_keyframes([11, 43])] == [11, 43]
    with pytest.raises(RootTrajectoryError, match="44"):
        traj.root_keyframes([44])


@pytest.mark.parametrize("field", ["velocity_halflife", "heading_halflife"])
@pytest.mark.parametrize("value", [0.0, -0.1, math.nan, "0.3"])
def test_halflife_must_be_positive_and_the_error_names_it(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        SpringConfig(**{field: value})  # type: ignore[arg-type]


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(RootTrajectoryError, match="frames"):
        root_trajectory(REST, VelocityCommand(), 0)
    with pytest.raises(RootTrajectoryError, match="velocity"):
        RootState(position=(0, 0), velocity=(math.nan, 0), heading=0, yaw_rate=0)
    with pytest.raises(RootTrajectoryError, match="finite"):
        root_trajectory(REST, VelocityCommand(vx=math.inf), 10)
    with pytest.raises(RootTrajectoryError, match="36"):
        root_state_from_frames(np.zeros((4, 35)))


def _frames(
    t: np.ndarray, p0: tuple[float, float], v: tuple[float, float], a: tuple[float, float], h0: float, w: float, al: float
) -> np.ndarray:
    q = np.zeros((len(t), g1.QPOS_SIZE))
    q[:, 0] = p0[0] + v[0] * t + 0.5 * a[0] * t**2
    q[:, 1] = p0[1] + v[1] * t + 0.5 * a[1] * t**2
    q[:, 2] = 0.78
    q[:, 3:7] = quat.from_yaw(h0 + w * t + 0.5 * al * t**2)
    return q


def test_state_from_frames_recovers_velocity_and_yaw_rate_of_a_known_motion() -> None:
    t = np.arange(-3, 1) / FPS  # the last of four frames is now
    # Constant acceleration, and a heading that crosses +-pi between the frames.
    frames = _frames(t, (1.0, 2.0), (0.5, -0.2), (0.3, 0.6), math.pi - 0.05, 1.2, -0.9)
    s = root_state_from_frames(frames)
    assert s.position == pytest.approx((1.0, 2.0), abs=1e-12)
    assert s.velocity == pytest.approx((0.5, -0.2), abs=1e-9)
    assert s.acceleration == pytest.approx((0.3, 0.6), abs=1e-6)
    assert s.yaw_rate == pytest.approx(1.2, abs=1e-9)
    assert s.yaw_acceleration == pytest.approx(-0.9, abs=1e-6)
    assert float(quat.wrap_angle(s.heading - (math.pi - 0.05))) == pytest.approx(0.0, abs=1e-12)
    # Without acceleration: a line fit over the window, exact for constant velocity.
    const = root_state_from_frames(_frames(t, (0, 0), (0.4, 0.1), (0, 0), 0.2, -0.5, 0.0), with_acceleration=False)
    assert const.velocity == pytest.approx((0.4, 0.1), abs=1e-9) and const.acceleration == (0.0, 0.0)
    assert const.yaw_rate == pytest.approx(-0.5, abs=1e-9)
    two = root_state_from_frames(frames[-2:])
    assert two.velocity == pytest.approx(((frames[-1, 0] - frames[-2, 0]) * FPS, (frames[-1, 1] - frames[-2, 1]) * FPS))
    one = root_state_from_frames(frames[-1:])
    assert one.velocity == (0.0, 0.0) and one.yaw_rate == 0.0
    # A state read from a trajectory's own frames continues it: from a settled circle, the next plan is the same circle.
    traj = root_trajectory(REST, VelocityCommand(vx=0.5, yaw_rate=0.5), 150)
    window = np.zeros((4, g1.QPOS_SIZE))
    window[:, :2] = traj.positions[-4:]
    window[:, 3:7] = quat.from_yaw(traj.headings[-4:])
    s = root_state_from_frames(window)
    assert s.velocity == pytest.approx(tuple(traj.velocities[-1]), abs=2e-4)
    assert s.yaw_rate == pytest.approx(0.5, abs=1e-6)


def test_waypoint_command_heads_for_the_target_and_slows_near_it() -> None:
    here = RootState(position=(0.0, 0.0), velocity=(0.0, 0.0), heading=math.pi / 2, yaw_rate=0.0)  # facing +y
    far = waypoint_command(here, (3.0, 3.0, 0.0), max_speed=0.6, max_yaw_rate=1.0)
    # The target is 45 degrees to the right of the heading: forward and rightwards, full speed, turning right.
    assert far.vx == pytest.approx(0.6 / math.sqrt(2)) and far.vy == pytest.approx(-0.6 / math.sqrt(2))
    assert far.yaw_rate == -1.0  # 45 degrees off, clamped at max_yaw_rate
    ahead = waypoint_command(here, (0.0, 3.0, 0.0), max_speed=0.6, max_yaw_rate=1.0)
    assert (ahead.vx, ahead.vy, ahead.yaw_rate) == pytest.approx((0.6, 0.0, 0.0))
    near = waypoint_command(here, (0.0, 0.2, math.pi / 2), max_speed=0.6, max_yaw_rate=1.0, slow_radius=0.5)
    assert (near.vx, near.vy, near.yaw_rate) == pytest.approx((0.6 * 0.2 / 0.5, 0.0, 0.0))
    behind = waypoint_command(here, (0.0, -0.1, math.pi / 2), max_speed=0.6, max_yaw_rate=1.0)
    assert (behind.vx, behind.vy) == pytest.approx((-0.12, 0.0))  # steps back rather than turning round for 10 cm


def test_waypoint_command_turns_to_the_target_heading_when_on_it() -> None:
    here = RootState(position=(1.0, 1.0), velocity=(0.0, 0.0), heading=0.0, yaw_rate=0.0)
    on = waypoint_command(here, (1.0, 1.0, 0.2), max_speed=0.6, max_yaw_rate=1.0)
    assert (on.vx, on.vy) == (0.0, 0.0) and on.yaw_rate == pytest.approx(0.2 / 0.5)
    on = waypoint_command(here, (1.0, 1.0, -3.0), max_speed=0.6, max_yaw_rate=1.0)
    assert on.yaw_rate == -1.0  # clamped, the short way round
    on = waypoint_command(here, (1.0, 1.0, 3.0), max_speed=0.6, max_yaw_rate=1.0)
    assert on.yaw_rate == 1.0
    assert waypoint_command(here, (1.0, 1.0, 0.0), 0.6, 1.0).is_zero(1e-12)
    # Halfway between slow_radius and twice it, the facing goal is halfway between the bearing and the target heading.
    mid = waypoint_command(here, (1.75, 1.0, 1.0), max_speed=0.6, max_yaw_rate=1.0, slow_angle=10.0)
    assert mid.yaw_rate == pytest.approx(0.5 / 10.0)


def _approach(max_speed: float, max_yaw_rate: float, **kwargs: float) -> tuple[RootState, float, float]:
    """Replan every 0.1 s from the trajectory's own state towards (2, 1, -pi/2): final state and overshoots (m, rad)."""
    state = RootState(position=(0.0, 0.0), velocity=(0.0, 0.0), heading=0.0, yaw_rate=0.0)
    target = (2.0, 1.0, -math.pi / 2)
    approach = np.array(target[:2]) / math.hypot(*target[:2])
    past, turned_past = 0.0, 0.0
    for _ in range(150):  # 15 s
        cmd = waypoint_command(state, target, max_speed, max_yaw_rate, **kwargs)
        state = root_trajectory(state, cmd, 3).state_at(2)
        past = max(past, float((np.array(state.position) - target[:2]) @ approach))
        turned_past = max(turned_past, -float(quat.wrap_angle(state.heading - target[2])))  # it turns right, clockwise
    return state, past, turned_past


def test_waypoint_command_closes_the_loop_through_the_spring() -> None:
    state, past, turned_past = _approach(0.6, 1.0)
    assert state.position == pytest.approx((2.0, 1.0), abs=1e-4)
    assert float(quat.wrap_angle(state.heading + math.pi / 2)) == pytest.approx(0.0, abs=1e-4)
    # The defaults are faster than the spring: 5 cm and 10 degrees past the target before settling.
    assert past == pytest.approx(0.052, abs=0.002)
    assert math.degrees(turned_past) == pytest.approx(10.1, abs=0.2)
    assert _approach(1.0, 1.0)[1] == pytest.approx(0.176, abs=0.003)  # 18 cm at 1 m/s
    # With the gains at the spring's no-overshoot bound, it stops on the target (0.1 s replans leave 0.1 mm).
    k = no_overshoot_gain(HALFLIFE)
    assert k == pytest.approx(4 * Y / 27) and 1 / k == pytest.approx(1.46, abs=0.005)
    state, past, turned_past = _approach(1.0, 1.0, slow_radius=1.0 / k, slow_angle=1.0 / k)
    assert state.position == pytest.approx((2.0, 1.0), abs=1e-4)
    assert past < 3e-4 and turned_past < 3e-4


def test_a_trajectory_continues_from_any_of_its_frames() -> None:
    state = RootState(position=(0.5, 0.5), velocity=(0.2, 0.1), acceleration=(-0.3, 0.4), heading=2.0, yaw_rate=-0.3)
    cmd = VelocityCommand(vx=0.7, vy=-0.1, yaw_rate=0.6)
    traj = root_trajectory(state, cmd, 64)
    rest = root_trajectory(traj.state_at(19), cmd, 44)
    assert np.abs(rest.positions - traj.positions[20:]).max() < 1e-12
    assert np.abs(rest.velocities - traj.velocities[20:]).max() < 1e-12
    assert np.abs(rest.headings - traj.headings[20:]).max() < 1e-12


@pytest.mark.parametrize("field", ["max_speed", "slow_radius"])
def test_waypoint_settings_are_checked(field: str) -> None:
    kwargs = {"max_speed": 0.5, "max_yaw_rate": 1.0, "slow_radius": 0.5, field: -1.0}
    with pytest.raises(ConfigError, match=field):
        waypoint_command(REST, (0, 0, 0), **kwargs)
