"""onnxruntime sessions for the policies and the planner, set up one way: CPU, sequential, quiet."""

from __future__ import annotations

from pathlib import Path

import onnxruntime as ort

from hw.errors import G1Error


def open_session(path: Path, error: type[G1Error], what: str, threads: int = 1) -> ort.InferenceSession:
    """A CPU session on `threads` intra-op threads; a missing or broken file raises `error` naming `what`."""
    if not path.is_file():
        raise error(f"{what} not found: {path}")
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    options.log_severity_level = 3  # errors only: warnings about unused initializers are noise to users
    try:
        return ort.InferenceSession(str(path), sess_options=options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own untyped Fail/InvalidGraph errors
        raise error(f"cannot load {what} {path}: {exc}".splitlines()[0]) from exc
