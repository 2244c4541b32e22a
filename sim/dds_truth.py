"""The simulated robot's ground truth on a side topic, for the metrics of a run against a robot in another process.

The robot's own topics carry what a real G1 reports (joints, IMU), not where the robot is:
a run's velocity error and fall detection need the simulator's state. The simulated robot
publishes its `qpos`/`qvel` on `sim/truth` (simulation only, never on a real robot's domain)
and the host mirrors them into its own copy of the model (`SimRobot`) for the metrics and
the video. No `from __future__ import annotations` here: cyclonedds reads the annotations.
"""

from dataclasses import dataclass

from hw.dds import EXTRA_HINT
from hw.errors import ConfigError
from hw.g1 import QPOS_SIZE, QVEL_SIZE

try:
    from cyclonedds.idl import IdlStruct, types
    from cyclonedds.idl import annotations as annotate
except ImportError as exc:  # one line naming the extra
    raise ConfigError(EXTRA_HINT) from exc

TRUTH_TOPIC = "sim/truth"


@dataclass
@annotate.final
class SimTruth_(IdlStruct, typename="g1ctl.sim.SimTruth_"):
    time: types.float64  # simulated seconds since the physics started
    qpos: types.array[types.float64, QPOS_SIZE]
    qvel: types.array[types.float64, QVEL_SIZE]
