"""What every ONNX policy tracker reads the same way: its metadata, joint names, gains and I/O.

holosoma exports describe themselves: joint names (`dof_names`), `kp`, `kd` and more are
JSON values in the ONNX metadata. A YAML config may override gains per joint. The control
rate is the YAML's (`rate_hz`): most exports do not carry it, and one that does (in its
training config) must agree. Every mismatch is a `PolicyError` naming the file and what to fix.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import onnxruntime as ort

from hw.errors import ConfigError, PolicyError
from hw.types import FloatArray, read_only


def read_metadata(session: ort.InferenceSession) -> dict[str, object]:
    """The ONNX metadata, each value parsed as JSON where it is JSON (holosoma stores lists and numbers so)."""
    return {k: _json_or_text(v) for k, v in session.get_modelmeta().custom_metadata_map.items()}


def metadata_joint_names(meta: Mapping[str, object], path: Path) -> tuple[str, ...]:
    names = meta.get("dof_names") or meta.get("joint_names")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or not names:
        raise PolicyError(f"{path.name}: metadata has no joint name list ('dof_names'); export the policy with its joint names")
    if len(set(names)) != len(names):
        raise PolicyError(f"{path.name}: metadata joint names repeat")
    return tuple(names)


def joint_gains(
    key: str, meta: Mapping[str, object], override: Mapping[str, float] | None, joint_names: tuple[str, ...], path: Path, source: str
) -> FloatArray:
    """Gains `key` ("kp", "kd") per joint from the metadata, with the config's per-joint overrides applied."""
    values = meta.get(key)
    if values is None:
        if override is None or set(override) != set(joint_names):
            raise PolicyError(f"{path.name}: no '{key}' in metadata; give all {len(joint_names)} joints under '{key}' in {source}")
        return np.array([override[j] for j in joint_names])
    gains = np.asarray(values, float)
    if gains.shape != (len(joint_names),):
        raise PolicyError(f"{path.name}: metadata '{key}' has {gains.size} values for {len(joint_names)} joints")
    for joint, value in (override or {}).items():
        if joint not in joint_names:
            raise ConfigError(f"{source}: '{key}' override names unknown joint '{joint}'")
        gains[joint_names.index(joint)] = value
    return gains


def trained_rate_hz(meta: Mapping[str, object]) -> float | None:
    """The control rate (Hz) an export was trained at, where its metadata holds holosoma's training config
    (`experiment_config`: the simulator's fps over its control decimation); None where it does not."""
    config = meta.get("experiment_config")
    for key in ("simulator", "config", "sim"):
        config = config.get(key) if isinstance(config, dict) else None
    if not isinstance(config, dict):
        return None
    fps, decimation = config.get("fps"), config.get("control_decimation")
    if not all(isinstance(v, int | float) and not isinstance(v, bool) and v > 0 for v in (fps, decimation)):
        return None
    return float(fps) / float(decimation)  # type: ignore[arg-type]


def check_rate(meta: Mapping[str, object], rate_hz: float, path: Path, source: str) -> None:
    """The config's control rate is the one the export was trained at, where the export says."""
    trained = trained_rate_hz(meta)
    if trained is not None and not math.isclose(trained, rate_hz):
        raise ConfigError(
            f"{source}: rate_hz {rate_hz:g} is not the rate {path.name} was trained at ({trained:g} Hz: its metadata's "
            f"experiment_config, simulator fps / control_decimation); set rate_hz: {trained:g}"
        )


def check_io(
    session: ort.InferenceSession, path: Path, input_name: str, output_name: str, obs_size: int, joints: int
) -> dict[str, list[object]]:
    """Check the named input takes `obs_size` values and the named output gives one per joint; returns the input shapes."""
    inputs = {i.name: i.shape for i in session.get_inputs()}
    outputs = {o.name: o.shape for o in session.get_outputs()}
    name = path.name
    if input_name not in inputs:
        raise PolicyError(f"{name}: no input '{input_name}' (inputs: {', '.join(inputs)}); fix 'input_name' in the policy config")
    if output_name not in outputs:
        raise PolicyError(f"{name}: no output '{output_name}' (outputs: {', '.join(outputs)}); fix 'output_name' in the policy config")
    in_dim = inputs[input_name][-1]
    if isinstance(in_dim, int) and in_dim != obs_size:
        raise PolicyError(f"{name}: input '{input_name}' takes {in_dim} values but the observation layout makes {obs_size}")
    out_dim = outputs[output_name][-1]
    if isinstance(out_dim, int) and out_dim != joints:
        raise PolicyError(f"{name}: output '{output_name}' has {out_dim} values but the metadata names {joints} joints")
    return inputs


def _json_or_text(text: str) -> object:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


class ActionFilter:
    """Policy outputs to PD targets: clipped, scaled around the default pose.

    A non-finite output holds the last safe target; `limit` of them in a row latch a
    fault (`latched_fault`), after which the tracker damps. Every one is counted.
    """

    def __init__(self, scale: FloatArray, default_pos: FloatArray, clip: float, limit: int) -> None:
        self.scale = scale
        self.default_pos = default_pos
        self.clip = clip
        self.limit = limit
        self.nonfinite_events = 0
        self.reset()

    def reset(self) -> None:
        self.last_action = np.zeros(len(self.default_pos))
        self.last_target: FloatArray = self.default_pos
        self.latched_fault: str | None = None
        self._consecutive_bad = 0

    def target(self, action: FloatArray) -> FloatArray | None:
        """The target for this tick's `action`; None once a fault is latched (damp)."""
        if self.latched_fault is not None:
            return None
        if not math.isfinite(float(action.sum())):  # one reduction catches any NaN or inf
            self.nonfinite_events += 1
            self._consecutive_bad += 1
            if self._consecutive_bad >= self.limit:
                self.latched_fault = f"policy produced non-finite actions {self._consecutive_bad} ticks in a row"
                return None
            return self.last_target
        self._consecutive_bad = 0
        self.last_action = np.minimum(np.maximum(action, -self.clip), self.clip)
        self.last_target = read_only(self.last_action * self.scale + self.default_pos)
        return self.last_target
