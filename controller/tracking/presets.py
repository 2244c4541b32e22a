"""Policy presets by name: `configs/policies/NAME.yaml`, or a path to such a file."""

from __future__ import annotations

from pathlib import Path

from controller.assets import Assets
from controller.tracking.velocity_policy import PolicyConfig, VelocityPolicy
from hw.shipped import config_dir
from hw.yamlconfig import load_config, preset_names, resolve_preset


def available_policies() -> list[str]:
    return preset_names(config_dir("policies"))


def policy_config_path(name_or_path: str) -> Path:
    return resolve_preset(name_or_path, config_dir("policies"), "policy")


def load_policy(name_or_path: str, assets: Assets, robot_joint_names: tuple[str, ...]) -> VelocityPolicy:
    """Load a policy preset and its ONNX file, checked against the robot's joints."""
    cfg_path = policy_config_path(name_or_path)
    cfg = load_config(PolicyConfig, cfg_path)
    onnx_path = assets.policy(cfg.onnx)
    if not Path(cfg.onnx).is_absolute() and (cfg_path.parent / cfg.onnx).is_file():
        onnx_path = cfg_path.parent / cfg.onnx
    return VelocityPolicy(onnx_path, cfg, robot_joint_names, source=str(cfg_path))
