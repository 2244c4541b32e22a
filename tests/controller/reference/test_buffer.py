"""The plan buffer (controller/reference/buffer.py) on motions with known answers, read at the tracker's 50 Hz."""

from __future__ import annotations

import numpy as np
import pytest

from controller.planner.request import FPS
from controller.reference.buffer import ReferenceBuffer, ReferenceBufferError
from hw import g1, quat
from hw.errors import G1Error

SPEED, YAW_RATE = 0.5, 0.3  # m/s along the heading, rad/s: a walk on a circle of radius SPEED / YAW_RATE
JOINT_AMPLITUDE, JOINT_OMEGA = 0.3, 2 * np.pi * 0.5  # rad, rad/s
PHASES = 0.2 * np.arange(g1.NUM_JOINTS)
DEFAULT_JOINTS = np.asarray(g1.standing_qpos())[g1.QPOS_JOINTS]
TRACKER_DT = 1.0 / 50


def walk(t: np.ndarray | float, heading0: float = 0.2) -> np.ndarray:
    """G1 frames [len(t), 36] of a constant-velocity walk: root at SPEED along its heading, heading turning at YAW_RATE."""
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    heading = heading0 + YAW_RATE * t
    radius = SPEED / YAW_RATE
    frames = np.zeros((len(t), g1.QPOS_SIZE))
    frames[:, 0] = radius * (np.sin(heading) - np.sin(heading0))
    frames[:, 1] = -radius * (np.cos(heading) - np.cos(heading0))
    frames[:, 2] = g1.STANDING_PELVIS_HEIGHT
    frames[:, g1.QPOS_ROOT_QUAT] = quat.from_yaw(heading)
    frames[:, g1.QPOS_JOINTS] = DEFAULT_JOINTS + JOINT_AMPLITUDE * np.sin(JOINT_OMEGA * t[:, None] + PHASES)
    return frames


def walk_velocity(t: float, heading0: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """World root velocity [3] and joint velocities [29] of `walk` at t."""
    heading = heading0 + YAW_RATE * t
    root = SPEED * np.array([np.cos(heading), np.sin(heading), 0.0])
    return root, JOINT_AMPLITUDE * JOINT_OMEGA * np.cos(JOINT_OMEGA * t + PHASES)


def plan_times(start: float, n: int = 64) -> np.ndarray:
    return start + np.arange(n) / FPS


def test_a_spliced_walk_reads_back_at_50_hz() -> None:
    buffer = ReferenceBuffer()
    buffer.splice(walk(plan_times(0.0)), 0.0)
    second = 1.01  # off the first plan's 30 fps grid, as a look-ahead after a 50 Hz tick is
    buffer.splice(walk(plan_times(second)), second, crossfade_frames=3)  # the same motion: the cross-fade must not show
    assert buffer.start_time == 0.0
    assert buffer.end_time == pytest.approx(second + 63 / FPS)

    # In the fade (one period around it for the differences) the old plan is read between its frames: its chords, up to
    # A w^2 h^2 / 8 = 4e-4 rad off the sine, enter the blended frames, and the difference over one period h sees them / h.
    fade = (second - 1 / FPS, second + 4 / FPS)
    for t in np.arange(0.1, buffer.end_time - 0.1, TRACKER_DT):
        sample = buffer.sample(t)
        truth = walk(t)[0]
        root_velocity, joint_velocity = walk_velocity(t)
        in_fade = fade[0] <= t <= fade[1]
        assert not sample.held
        assert sample.time == t
        # Chord of the circle between frames (sagitta R * (1 - cos(w h / 2)) = 2e-5 m), sine between frames (A w^2 h^2 / 8 = 4e-4 rad).
        np.testing.assert_allclose(sample.qpos[g1.QPOS_ROOT_POS], truth[g1.QPOS_ROOT_POS], atol=3e-5)
        np.testing.assert_allclose(sample.qpos[g1.QPOS_JOINTS], truth[g1.QPOS_JOINTS], atol=1e-3 if in_fade else 5e-4)
        assert quat.angle(sample.qpos[g1.QPOS_ROOT_QUAT], truth[g1.QPOS_ROOT_QUAT]) < 1e-9  # slerp about z is exact in heading
        assert np.linalg.norm(sample.qpos[g1.QPOS_ROOT_QUAT]) == pytest.approx(1.0)
        # Centred differences of the interpolated frames: second order in h (the sine: A w^3 h^2 / 6 = 1.7e-3 rad/s).
        np.testing.assert_allclose(sample.root_velocity, root_velocity, atol=1e-3 if in_fade else 2e-5)
        assert sample.yaw_rate == pytest.approx(YAW_RATE, abs=1e-9)
        np.testing.assert_allclose(sample.joint_velocity, joint_velocity, atol=1.5e-2 if in_fade else 2e-3)
        assert sample.qpos.shape == (g1.QPOS_SIZE,) and sample.joint_velocity.shape == (g1.NUM_JOINTS,)


def test_slerp_at_the_midpoint_takes_the_short_way() -> None:
    q0 = quat.from_axis_angle([1.0, 2.0, 3.0], 0.2)
    q1 = quat.from_axis_angle([-1.0, 0.5, 2.0], 1.0)
    frames = np.zeros((2, g1.QPOS_SIZE))
    frames[0, g1.QPOS_ROOT_POS], frames[1, g1.QPOS_ROOT_POS] = (0.0, 0.0, 0.78), (0.1, -0.2, 0.8)
    frames[0, g1.QPOS_ROOT_QUAT], frames[1, g1.QPOS_ROOT_QUAT] = q0, -q1  # the same rotation as q1, other sign
    frames[1, g1.QPOS_JOINTS] = 0.4
    buffer = ReferenceBuffer()
    buffer.splice(frames, 2.0)

    for alpha in (0.5, 0.25):
        sample = buffer.sample(2.0 + alpha / FPS)
        np.testing.assert_allclose(sample.qpos[g1.QPOS_ROOT_POS], (1 - alpha) * frames[0, :3] + alpha * frames[1, :3], atol=1e-12)
        np.testing.assert_allclose(sample.qpos[g1.QPOS_JOINTS], 0.4 * alpha, atol=1e-12)
        assert quat.angle(sample.qpos[g1.QPOS_ROOT_QUAT], quat.slerp(q0, q1, alpha)) < 1e-9
        assert quat.angle(q0, sample.qpos[g1.QPOS_ROOT_QUAT]) == pytest.approx(alpha * quat.angle(q0, q1), abs=1e-9)


def test_reading_before_and_after_the_ends() -> None:
    frames = walk(plan_times(1.0, 24))
    buffer = ReferenceBuffer()
    buffer.splice(frames, 1.0)
    end = 1.0 + 23 / FPS
    assert buffer.end_time == pytest.approx(end)
    assert len(buffer) == 24

    before = buffer.sample(0.5)
    np.testing.assert_allclose(before.qpos, frames[0], atol=1e-12)
    assert not before.held
    assert not before.root_velocity.any() and before.yaw_rate == 0.0 and not before.joint_velocity.any()

    after = buffer.sample(end + 0.5)
    np.testing.assert_allclose(after.qpos, frames[-1], atol=1e-12)
    assert after.held
    assert not after.root_velocity.any() and after.yaw_rate == 0.0 and not after.joint_velocity.any()

    at_end = buffer.sample(end)  # the last frame itself is still planned: a one-sided difference, not held
    assert not at_end.held
    assert at_end.root_velocity[:2] == pytest.approx(walk_velocity(end)[0][:2], abs=5e-3)
    assert buffer.remaining(end - 0.25) == pytest.approx(0.25)
    assert buffer.remaining(end + 1.0) == 0.0


def test_reset_holds_one_pose_with_zero_velocity() -> None:
    buffer = ReferenceBuffer()
    with pytest.raises(ReferenceBufferError, match="empty"):
        buffer.sample(0.0)
    pose = np.asarray(g1.standing_qpos())
    buffer.reset(pose, 3.0)
    assert (buffer.start_time, buffer.end_time, len(buffer)) == (3.0, 3.0, 1)
    for t in (3.0, 3.02, 100.0):
        sample = buffer.sample(t)
        np.testing.assert_allclose(sample.qpos, pose)
        assert not sample.root_velocity.any() and sample.yaw_rate == 0.0 and not sample.joint_velocity.any()
        assert sample.held == (t > 3.0)
    # A plan may start up to one frame after the held pose; the cross-fade starts from it.
    plan = walk(plan_times(3.02))
    buffer.splice(plan, 3.02)
    np.testing.assert_allclose(buffer.sample(3.02).qpos, pose, atol=1e-12)
    np.testing.assert_allclose(buffer.sample(3.02 + 3 / FPS).qpos, plan[3], atol=1e-12)


def test_a_splice_half_way_cross_fades_without_a_jump() -> None:
    offset_position, offset_heading, offset_joints = np.array([0.15, -0.1, 0.0]), 0.4, 0.3

    def other(times: np.ndarray) -> np.ndarray:
        frames = walk(times, heading0=0.2 + offset_heading)
        frames[:, g1.QPOS_ROOT_POS] += offset_position
        frames[:, g1.QPOS_JOINTS] += offset_joints
        return frames

    splice_at = 32 / FPS + 0.013  # half way through the first plan, between two of its frames
    # What the stored frames may change by from one frame to the next: the motion itself plus the offset spread over the fade.
    per_frame = {
        "root": SPEED / FPS + float(np.linalg.norm(offset_position)) / 3,
        "heading": YAW_RATE / FPS + offset_heading / 3,
        "joints": JOINT_AMPLITUDE * JOINT_OMEGA / FPS + offset_joints / 3,
    }
    dt = 0.001
    times = np.arange(splice_at - 0.2, splice_at + 0.4, dt)

    def largest_steps(crossfade_frames: int) -> dict[str, float]:
        buffer = ReferenceBuffer()
        buffer.splice(walk(plan_times(0.0)), 0.0)
        buffer.splice(other(plan_times(splice_at)), splice_at, crossfade_frames)
        qpos = np.array([buffer.sample(t).qpos for t in times])
        early, late = times < splice_at, times >= splice_at + crossfade_frames / FPS
        np.testing.assert_allclose(qpos[early][:, :3], walk(times[early])[:, :3], atol=1e-4)  # the old plan until the splice
        np.testing.assert_allclose(qpos[late][:, :3], other(times[late])[:, :3], atol=1e-4)  # the new plan once faded in
        steps = np.diff(qpos, axis=0)
        return {
            "root": float(np.linalg.norm(steps[:, g1.QPOS_ROOT_POS], axis=1).max()),
            "heading": float(np.abs(quat.wrap_angle(np.diff(quat.heading(qpos[:, g1.QPOS_ROOT_QUAT])))).max()),
            "joints": float(np.abs(steps[:, g1.QPOS_JOINTS]).max()),
        }

    faded = largest_steps(3)
    for name, bound in per_frame.items():
        assert faded[name] <= bound * dt * FPS * 1.01, name  # continuous: no step bigger than a frame's change spread over dt
    cut = largest_steps(0)  # without a fade the same splice jumps: the check above can see a jump
    jump = other(np.array([splice_at]))[0] - walk(splice_at)[0]
    assert cut["root"] > 0.9 * np.linalg.norm(jump[g1.QPOS_ROOT_POS]) > 20 * faded["root"]
    assert cut["joints"] > 0.9 * offset_joints > 20 * faded["joints"]


def test_a_late_splice_before_the_newest_plan_replaces_it() -> None:
    buffer = ReferenceBuffer()
    buffer.splice(walk(plan_times(0.0)), 0.0)
    buffer.splice(walk(plan_times(1.0)) + 0.5, 1.0, crossfade_frames=0)
    buffer.splice(walk(plan_times(0.5)), 0.5, crossfade_frames=0)  # starts before the previous plan: that plan is gone
    assert buffer.end_time == pytest.approx(0.5 + 63 / FPS)
    assert len(buffer) == 15 + 64  # frames 0 .. 14 of the first plan lie before 0.5 s
    np.testing.assert_allclose(buffer.sample(1.5).qpos[g1.QPOS_JOINTS], walk(1.5)[0, g1.QPOS_JOINTS], atol=5e-4)


def test_context_returns_frames_ending_at_t() -> None:
    frames = walk(plan_times(0.0))
    frames[1::2, g1.QPOS_ROOT_QUAT] *= -1.0  # the same rotations, every other one with the other sign
    buffer = ReferenceBuffer()
    buffer.splice(frames, 0.0)
    t = 1.234
    context = buffer.context(t)
    assert context.shape == (4, g1.QPOS_SIZE)
    expected_times = t - np.arange(3, -1, -1) / FPS
    np.testing.assert_allclose(context[:, :3], walk(expected_times)[:, :3], atol=1e-4)
    np.testing.assert_allclose(context[-1], buffer.sample(t).qpos, atol=1e-12)
    for row, time in zip(context, expected_times, strict=True):
        assert quat.angle(row[g1.QPOS_ROOT_QUAT], walk(time)[0, g1.QPOS_ROOT_QUAT]) < 1e-9
    quats = context[:, g1.QPOS_ROOT_QUAT]
    assert (np.sum(quats[1:] * quats[:-1], axis=1) > 0).all()  # sign-continuous, as the planner expects
    assert buffer.context(t, frames=6).shape == (6, g1.QPOS_SIZE)
    np.testing.assert_allclose(buffer.context(-1.0), np.tile(buffer.sample(0.0).qpos, (4, 1)), atol=1e-12)


def test_bad_input_raises_an_error_naming_it() -> None:
    buffer = ReferenceBuffer()
    buffer.splice(walk(plan_times(0.0, 24)), 0.0)
    end = buffer.end_time

    nan = walk(plan_times(0.5, 24))
    nan[5, 10] = np.nan
    with pytest.raises(ReferenceBufferError, match=r"NaN or infinite values in frame\(s\) \[5\]"):
        buffer.splice(nan, 0.5)
    infinite = walk(plan_times(0.5, 24))
    infinite[2, 0] = np.inf
    with pytest.raises(ReferenceBufferError, match="NaN or infinite"):
        buffer.splice(infinite, 0.5)
    with pytest.raises(ReferenceBufferError, match=r"shape \[N, 36\].*got \[24, 35\]"):
        buffer.splice(walk(plan_times(0.5, 24))[:, :35], 0.5)
    with pytest.raises(ReferenceBufferError, match=r"got \[36\]"):
        buffer.splice(walk(0.5)[0], 0.5)
    zero_quat = walk(plan_times(0.5, 24))
    zero_quat[3, g1.QPOS_ROOT_QUAT] = 0.0
    with pytest.raises(ReferenceBufferError, match="zero root quaternion"):
        buffer.splice(zero_quat, 0.5)
    with pytest.raises(ReferenceBufferError, match=r"start time -0.1000 s is before the buffer's first frame at 0.0000 s") as raised:
        buffer.splice(walk(plan_times(-0.1, 24)), -0.1)
    assert isinstance(raised.value, ValueError) and isinstance(raised.value, G1Error)
    with pytest.raises(ReferenceBufferError, match="finite"):
        buffer.splice(walk(plan_times(0.5, 24)), float("nan"))
    with pytest.raises(ReferenceBufferError, match="crossfade_frames"):
        buffer.splice(walk(plan_times(0.5, 24)), 0.5, crossfade_frames=-1)
    with pytest.raises(ReferenceBufferError, match=r"reset pose must have shape \[36\]"):
        buffer.reset(np.zeros(35), 0.0)
    with pytest.raises(ReferenceBufferError, match="finite time"):
        buffer.sample(float("nan"))
    assert buffer.end_time == end  # nothing rejected went in
    buffer.splice(walk(plan_times(end + 1 / FPS, 24)), end + 1 / FPS)  # one period after the end is still on time


@pytest.mark.slow
def test_memory_stays_bounded_over_10000_splices() -> None:
    buffer = ReferenceBuffer()
    plan_length, replan_period, look_ahead = 44, 0.1, 0.05
    buffer.reset(walk(look_ahead)[0], look_ahead)
    start = 0.0
    for k in range(10_000):
        start = k * replan_period + look_ahead
        buffer.splice(walk(plan_times(start, plan_length)), start)
    assert len(buffer) <= round((buffer.history_s + replan_period) * FPS) + plan_length + 1
    assert buffer.start_time >= start - buffer.history_s - 1 / FPS
    t = start + 0.5  # a run of 1000 s still reads the walk back
    np.testing.assert_allclose(buffer.sample(t).qpos[:3], walk(t)[0, :3], atol=1e-4)
    np.testing.assert_allclose(buffer.context(start - 1.0)[:, :3], walk(start - 1.0 - np.arange(3, -1, -1) / FPS)[:, :3], atol=1e-4)


def test_a_plan_after_the_buffer_ran_out_follows_the_held_pose() -> None:
    """The first plan after a reset (or after failed plans) starts later than one frame past the end."""
    buffer = ReferenceBuffer()
    pose = walk(0.0)[0]
    buffer.reset(pose, 0.0)
    start = 0.25  # 7.5 frame periods after the held pose
    plan = walk(plan_times(start, 24))
    buffer.splice(plan, start, crossfade_frames=0)
    np.testing.assert_allclose(buffer.sample(0.1).qpos, pose, atol=1e-12)  # the gap holds the pose read there before
    np.testing.assert_allclose(buffer.sample(start + 5 / FPS).qpos, plan[5], atol=1e-9)
    assert not buffer.sample(start + 5 / FPS).held


def test_move_applies_to_everything_held_and_keeps_it_continuous() -> None:
    buffer = ReferenceBuffer()
    buffer.splice(walk(plan_times(0.0, 24)), 0.0)
    buffer.splice(walk(plan_times(0.5, 24)), 0.5)
    before = [buffer.sample(t).qpos for t in np.arange(0.0, 1.2, 0.02)]

    def lift(frames: np.ndarray) -> np.ndarray:
        frames[:, 0] += 1.0
        return frames

    buffer.move(lift)
    after = [buffer.sample(t).qpos for t in np.arange(0.0, 1.2, 0.02)]
    for a, b in zip(before, after, strict=True):
        np.testing.assert_allclose(b[0], a[0] + 1.0, atol=1e-12)
        np.testing.assert_allclose(b[1:], a[1:], atol=1e-12)
