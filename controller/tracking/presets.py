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


def policy_rate_hz(name_or_path: str) -> float:
    """The control rate (Hz) of a policy preset, without loading its ONNX file: what runs on paper tick at."""
    return load_config(PolicyConfig, policy_config_path(name_or_path)).rate_hz


def load_policy(name_or_path: str, assets: Assets, robot_joint_names: tuple[str, ...]) -> VelocityPolicy:
    """Load a policy preset and its ONNX file, checked against the robot's joints."""
    cfg_path = policy_config_path(name_or_path)
    cfg = load_config(PolicyConfig, cfg_path)
    return VelocityPolicy(onnx_file(cfg.onnx, cfg_path, assets), cfg, robot_joint_names, source=str(cfg_path))


def onnx_file(name: str, cfg_path: Path, assets: Assets) -> Path:
    """A preset's ONNX file: beside its YAML when it is there, else in the asset cache (or a path)."""
    if not Path(name).is_absolute() and (cfg_path.parent / name).is_file():
        return cfg_path.parent / name
    return assets.policy(name)
