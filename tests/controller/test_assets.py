"""Asset fetching and verification: checksums, local copies, offline failure."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from controller import assets as assets_mod
from controller.assets import ENV_ASSETS_DIR, ensure_assets, load_manifest, problems
from hw.errors import AssetError


def copy_assets(src: Path, dest: Path) -> Path:
    shutil.copytree(src, dest)
    return dest


def test_cache_verifies(assets) -> None:
    assert problems(assets.root, load_manifest()) == []
    assert assets.g1_mjcf.is_file()
    assert {"fastsac_g1_29dof.onnx", "ppo_g1_29dof.onnx"} <= {p.name for p in (assets.root / "policies").iterdir()}


def test_local_copies_via_environment(assets, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    local = copy_assets(assets.root, tmp_path / "local")
    monkeypatch.setenv(ENV_ASSETS_DIR, str(local))
    assert ensure_assets().root == local


def test_corrupt_local_asset_is_named(assets, tmp_path: Path) -> None:
    local = copy_assets(assets.root, tmp_path / "local")
    (local / "policies" / "ppo_g1_29dof.onnx").write_bytes(b"corrupt")
    with pytest.raises(AssetError, match="checksum mismatch for policies/ppo_g1_29dof.onnx"):
        ensure_assets(local)


@pytest.mark.slow
def test_corrupt_cache_is_repaired_from_the_wheel(assets, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = copy_assets(assets.root, tmp_path / "cache" / "g1ctl" / "assets")
    (cache / "policies" / "ppo_g1_29dof.onnx").write_bytes(b"corrupt")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv(ENV_ASSETS_DIR, raising=False)
    downloaded: list[str] = []
    real_download = assets_mod._download_wheel

    def spy(package: str, version: str, dest: Path) -> Path:
        downloaded.append(package)
        return real_download(package, version, dest)

    monkeypatch.setattr(assets_mod, "_download_wheel", spy)
    assert ensure_assets(quiet=True).root == cache
    assert downloaded == ["holosoma-inference"]  # only the wheel with the broken file
    assert problems(cache, load_manifest()) == []
    downloaded.clear()
    ensure_assets(quiet=True)
    assert downloaded == []  # second run does no work


def test_offline_fetch_fails_with_one_clear_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "empty-cache"))
    monkeypatch.delenv(ENV_ASSETS_DIR, raising=False)
    monkeypatch.setenv("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
    monkeypatch.setenv("PIP_NO_INDEX", "1")
    monkeypatch.setenv("PIP_FIND_LINKS", "")
    monkeypatch.setenv("PIP_CONFIG_FILE", "/dev/null")
    with pytest.raises(AssetError) as info:
        ensure_assets(quiet=True)
    message = str(info.value)
    assert "cannot download holosoma" in message and ENV_ASSETS_DIR in message and "--assets-dir" in message
    assert "\n" not in message
