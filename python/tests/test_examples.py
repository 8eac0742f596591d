"""The three examples of examples/python, run at a small size: each ends and writes its
figure or table."""

import subprocess
import sys

import pandas as pd
import pytest

SMALL = ["--grains", "150", "--increments", "20"]


def run(root, name, out):
    done = subprocess.run(
        [sys.executable, root / "examples" / "python" / name, *SMALL, "--out", out],
        capture_output=True,
        text=True,
        cwd=root,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize(
    "name, figure",
    [("biaxial.py", "biaxial-stress-strain.png"), ("load_path.py", "load-path.png")],
)
def test_an_example_draws_its_figure(root, tmp_path, name, figure):
    printed = run(root, name, tmp_path)
    path = tmp_path / figure
    assert str(path) in printed
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 10_000


def test_the_sweep_tabulates_each_lateral_stress(root, tmp_path):
    run(root, "sweep_lateral.py", tmp_path)
    table = pd.read_csv(tmp_path / "sweep-lateral.csv", index_col="lateral_bar")
    assert table.index.tolist() == [1.0, 2.0, 3.0, 4.0]
    # The peak deviator grows with the lateral stress; sigma_3 is the one applied.
    assert table["deviator"].is_monotonic_increasing
    assert (table["sigma_3"] / 1e5).round(3).tolist() == [1.0, 2.0, 3.0, 4.0]
    assert table["phi_deg"].between(5, 45).all()
