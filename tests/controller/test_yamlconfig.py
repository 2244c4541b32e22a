"""Config validation: unknown keys, wrong shapes and missing keys name the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from controller.inputs.scripted import Scenario
from controller.tracking.velocity_policy import PolicyConfig
from controller.tracking.whole_body import WholeBodyConfig
from hw.errors import ConfigError
from hw.shipped import config_dir
from hw.yamlconfig import load_config

POLICY_DIR = config_dir("policies")


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    return path


def test_shipped_policy_configs_load() -> None:
    """Locomotion presets (100 observation values) and whole-body tracking presets (wbt_*, 154)."""
    paths = sorted(POLICY_DIR.glob("*.yaml"))
    whole_body = [p for p in paths if p.name.startswith("wbt_")]
    assert whole_body and len(whole_body) < len(paths)
    for path in paths:
        if path in whole_body:
            assert load_config(WholeBodyConfig, path).observation.size == 154
        else:
            assert load_config(PolicyConfig, path).observation.size == 100


def test_unknown_key_names_file_and_dotted_key(tmp_path: Path) -> None:
    text = (POLICY_DIR / "fastsac.yaml").read_text().replace("gait:\n  period: 1.0", "gait:\n  period: 1.0\n  perod: 2.0")
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match=r"cfg.yaml: unknown key 'gait.perod' \(valid keys: period, stand_threshold\)"):
        load_config(PolicyConfig, path)


def test_wrong_shape_names_key(tmp_path: Path) -> None:
    path = write(tmp_path, "duration: 10\nsteps:\n  - {t: 0.0, vx: [1, 2]}\n")
    with pytest.raises(ConfigError, match=r"cfg.yaml: steps\[0\].vx: expected a number"):
        load_config(Scenario, path)


def test_missing_required_key(tmp_path: Path) -> None:
    path = write(tmp_path, "steps:\n  - {t: 0.0}\n")
    with pytest.raises(ConfigError, match="missing required key 'duration'"):
        load_config(Scenario, path)


def test_value_check_in_post_init_is_config_error(tmp_path: Path) -> None:
    path = write(tmp_path, "duration: 10\nsteps:\n  - {t: 1.0}\n  - {t: 0.5}\n")
    with pytest.raises(ConfigError, match="must start at t: 0"):
        load_config(Scenario, path)


def test_yaml_syntax_error_is_config_error(tmp_path: Path) -> None:
    path = write(tmp_path, "duration: [10\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        load_config(Scenario, path)


def test_bool_is_not_a_number(tmp_path: Path) -> None:
    path = write(tmp_path, "duration: true\nsteps:\n  - {t: 0.0}\n")
    with pytest.raises(ConfigError, match="duration: expected a number"):
        load_config(Scenario, path)
