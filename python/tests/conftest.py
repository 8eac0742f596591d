"""Shared fixtures: the checkout, the `grainstat` program built beside the module, and a
small sand sample prepared once."""

import os
import pathlib

import grainstat
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture(scope="session")
def cli() -> pathlib.Path:
    """The command line built from the same checkout (`cargo build --release`)."""
    path = pathlib.Path(os.environ.get("GRAINSTAT_BIN", ROOT / "target" / "release" / "grainstat"))
    if not path.exists():
        pytest.fail(f"{path} is missing: build it with `cargo build --release`")
    return path


@pytest.fixture(scope="session")
def sand_sample(tmp_path_factory) -> pathlib.Path:
    """A 200-grain dense sand sample at 1 bar (examples/sample-sand.toml, smaller)."""
    scene = grainstat.Scene.from_file(ROOT / "examples" / "sample-sand.toml").to_dict()
    scene["sample"]["grains"] = 200
    path = tmp_path_factory.mktemp("samples") / "sand-200.h5"
    grainstat.generate(scene, path, progress=False)
    return path
