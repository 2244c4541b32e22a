"""Config validation: unknown keys, wrong shapes and missing keys name the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from controller.inputs.scripted import Scenario
from controller.tracking.velocity_policy import PolicyConfig
from controller.tracking.whole_body import WholeBodyConfig
from hw.errors import ConfigError
from hw.g1 import CONTROL_CYCLE_HZ
from hw.shipped import config_dir
from hw.yamlconfig import load_config

POLICY_DIR = config_dir("policies")


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    return path


def test_shipped_policy_configs_load() -> None:
    """Locomotion presets (100 observation values) and whole-body tracking presets (wbt_*, 154), each with its rate."""
    paths = sorted(POLICY_DIR.glob("*.yaml"))
    whole_body = [p for p in paths if p.name.startswith("wbt_")]
    assert whole_body and len(whole_body) < len(paths)
    for path in paths:
        cfg = load_config(WholeBodyConfig, path) if path in whole_body else load_config(PolicyConfig, path)
        assert cfg.observation.size == (154 if path in whole_body else 100)
        assert (CONTROL_CYCLE_HZ / cfg.rate_hz).is_integer(), path  # a tick is a whole number of hardware cycles (physics steps)


@pytest.mark.parametrize(
    ("edit", "message"), [("rate_hz: 50", "missing required key 'rate_hz'"), ("rate_hz: 0", "rate_hz must be positive")]
)
def test_the_policy_states_a_positive_rate(tmp_path: Path, edit: str, message: str) -> None:
    text = (POLICY_DIR / "fastsac.yaml").read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("rate_hz:"))
    path = write(tmp_path, text.replace(line, "" if edit == "rate_hz: 50" else edit))
    with pytest.raises(ConfigError, match=message):
        load_config(PolicyConfig, path)


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
