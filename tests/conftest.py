"""Shared fixtures: the real G1 assets and model, and tiny ONNX policies built in-process."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from controller.assets import Assets, ensure_assets
from hw.g1 import JOINT_NAMES


@pytest.fixture(scope="session")
def assets() -> Assets:
    return ensure_assets(quiet=True)


@pytest.fixture(scope="session")
def g1_model(assets: Assets):  # type: ignore[no-untyped-def]
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
