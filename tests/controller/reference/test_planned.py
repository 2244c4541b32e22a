"""The planned reference keeps the plan on the robot: a drifted plan is moved rigidly towards the measured root, gradually."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.commands.velocity import VelocityCommand
from controller.planner.request import Plan, PlanRequest
from controller.reference.buffer import ReferenceBuffer
from controller.reference.locomotion import SmartLocomotion
from controller.reference.planned import PlannedReference, pull_within, shift_frames
from controller.reference.scheduler import ReplanScheduler, SchedulerConfig
from controller.reference.spikes import VelocitySpikes
from hw import g1, quat
from tests.conftest import planar_state


def test_shift_frames_puts_the_source_pose_on_the_target_rigidly() -> None:
    frames = np.tile(np.array(g1.standing_qpos()), (3, 1))
    frames[:, 0] = [0.0, 0.1, 0.2]  # walking along +x
    moved = shift_frames(frames, np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, math.pi / 2]))
    np.testing.assert_allclose(moved[:, :2], [[1.0, 2.0], [1.0, 2.1], [1.0, 2.2]], atol=1e-12)  # now along +y
    np.testing.assert_allclose(quat.heading(moved[:, g1.QPOS_ROOT_QUAT]), math.pi / 2, atol=1e-12)
    np.testing.assert_array_equal(moved[:, g1.QPOS_JOINTS], frames[:, g1.QPOS_JOINTS])


def test_the_spring_continues_across_requests_whatever_the_plan_did() -> None:
    """The next target comes from the previous root path's rates, not from the plan's own speed (no feedback)."""
    locomotion = SmartLocomotion()
    locomotion.command = VelocityCommand(vx=0.5)
    standing = np.tile(np.array(g1.standing_qpos()), (4, 1))
    first = locomotion.request(standing, 0.0)
    racing = standing.copy()
    racing[:, 0] = [0.0, 0.1, 0.2, 0.3]  # a plan that ran at 3 m/s
    second = locomotion.request(racing, 0.1)
    path = locomotion.path
    assert path is not None
    # The spring's speed at the second request continues the first path (about 0.2 m/s after 0.1 s), not 3 m/s.
    assert 0.02 < path.velocities[0, 0] < 0.5
    assert second.keyframes[-1].qpos[0] - racing[-1, 0] == pytest.approx(first.keyframes[-1].qpos[0], abs=0.25)


def test_velocity_spikes_are_steps_of_the_reference_faster_than_the_command() -> None:
    spikes = VelocitySpikes()
    walk = VelocityCommand(vx=0.5)
    frame = np.array(g1.standing_qpos())
    for k in range(10):  # 0.9 m/s: within 0.5 m/s of the command
        frame[0] = 0.018 * k
        assert not spikes.record(0.02 * k, frame, walk)
    frame[0] += 0.1  # a re-anchoring's jump: 5 m/s for one tick
    assert spikes.record(0.2, frame, walk)
    frame[g1.QPOS_ROOT_QUAT] = quat.from_yaw(0.05)  # 2.5 rad/s of yaw under a command of none
    assert spikes.record(0.22, frame, walk)
    assert spikes.record(0.24, frame, VelocityCommand(vx=0.5, yaw_rate=-0.4)) is False  # standing still
    assert (spikes.ticks, spikes.spikes) == (12, 2) and spikes.share == pytest.approx(2 / 12)
    spikes.restart()  # a new start: the jump across it is not a step of the reference
    frame[0] = 5.0
    assert not spikes.record(0.26, frame, walk) and spikes.ticks == 12


def hold_pose(request: PlanRequest) -> Plan:
    """A planner that stands where the context ends."""
    n = request.lengths[0]
    return Plan(np.repeat(request.context[-1:], n, axis=0), np.ones((n, 2), dtype=bool), 0.0)


def test_a_plan_in_flight_moves_with_the_buffer_so_its_splice_does_not_jump() -> None:
    buffer = ReferenceBuffer()
    buffer.reset(np.array(g1.standing_qpos()), 0.0)
    scheduler = ReplanScheduler(hold_pose, SmartLocomotion().request, buffer, SchedulerConfig(), simulated_clock=True)
    try:
        scheduler.update(0.0)  # asks for a plan from the context at x = 0, spliced 0.1 s later
        scheduler.move(lambda frames: shift_frames(frames, np.zeros(3), np.array([0.1, 0.0, 0.0])))
        for k in range(1, 15):
            scheduler.update(k / 50)
        assert scheduler.counters.replans >= 1
        xs = [buffer.sample(k / 50).qpos[0] for k in range(15)]
        np.testing.assert_allclose(xs, 0.1, atol=1e-9)  # unmoved, the plan would have pulled it back to 0 over its crossfade
    finally:
        scheduler.close()


def test_a_drifted_plan_is_reanchored_on_the_robot_within_the_spike_margins() -> None:
    """0.5 m behind the robot and 0.3 rad off: moved towards it as fast as the spike margins allow, then left alone."""
    ref = PlannedReference(hold_pose)
    spikes = VelocitySpikes()
    walk = VelocityCommand(vx=0.3)
    try:
        ref.start(planar_state(0.0, 0.0, 0.0))
        xs = []
        for k in range(100):  # 2 s at 50 Hz, the robot 0.5 m ahead and turned by 0.3 rad
            window = ref.window(planar_state(k / 50, 0.5, 0.0, math.degrees(0.3)), walk)
            assert window.plan is not None
            spikes.record(k / 50, window.plan.qpos, walk)
            xs.append(window.plan.qpos[0])
        plan = ref.buffer.sample(2.0).qpos
        assert math.hypot(plan[0] - 0.5, plan[1]) <= 0.02 and abs(quat.heading(plan[g1.QPOS_ROOT_QUAT]) - 0.3) <= 0.02
        assert ref.report()["plan_resyncs"] == 1 and spikes.spikes == 0
    finally:
        ref.close()
    # The plan stands still: the pull may reach the command's speed plus the margin, less the reserve (0.65 m/s).
    assert np.diff(xs).max() * 50 == pytest.approx(0.3 + 0.5 - 0.15)


def test_the_pull_is_the_largest_that_keeps_the_reference_under_the_limit() -> None:
    forward = np.array([1.0, 0.0])
    assert pull_within(np.zeros(2), forward, 0.65, 1.0) == pytest.approx(0.65)
    assert pull_within(np.array([0.6, 0.0]), forward, 0.8, 1.0) == pytest.approx(0.2)  # speeding up: to the limit only
    assert pull_within(np.array([-0.6, 0.0]), forward, 0.8, 1.0) == pytest.approx(1.0)  # slowing down: as far as allowed
    assert pull_within(np.array([0.0, 0.6]), forward, 0.8, 1.0) == pytest.approx(math.sqrt(0.8**2 - 0.6**2))
    assert pull_within(np.array([-1.2, 0.0]), forward, 0.8, 0.3) == pytest.approx(0.3)  # over the limit: slowed as much as allowed
    assert pull_within(np.array([1.2, 0.0]), forward, 0.8, 1.0) == 0.0  # over the limit ahead: not pushed further
