"""Runs from Python against `grainstat run`: the same result file, bit for bit; stepping
against running to the end; resuming; the load path set between increments."""

import shutil
import subprocess

import grainstat
import numpy as np
import pytest
from hdf5_compare import differences

CRYSTAL = "examples/crystal-biaxial.toml"


def test_a_crystal_run_from_python_writes_the_same_file_as_the_command_line(root, cli, tmp_path):
    by_cli, by_python = tmp_path / "cli.h5", tmp_path / "python.h5"
    subprocess.run(
        [cli, "run", CRYSTAL, "-o", by_cli, "--quiet", "--no-plot"], cwd=root, check=True
    )
    with grainstat.Simulation(root / CRYSTAL, output=by_python) as sim:
        assert sim.run(progress=False) is None
        assert sim.finished and sim.increment == 55
    assert differences(by_cli, by_python) == []


def test_stepping_one_increment_at_a_time_equals_a_run_to_the_end(root, tmp_path):
    scene = grainstat.Scene.from_file(root / CRYSTAL)
    stepped, whole = tmp_path / "stepped.h5", tmp_path / "whole.h5"
    sim = grainstat.Simulation(scene, output=stepped)
    reports = []
    while not sim.finished:
        reports.append(sim.step())
    sim.close()
    seen = []
    with grainstat.Simulation(scene, output=whole) as sim:
        sim.run(progress=False, on_increment=seen.append)
        end = sim.state
    assert differences(stepped, whole) == []
    assert [r.increment for r in reports] == list(range(1, 56))
    assert [r.residual for r in reports] == [r.residual for r in seen]
    assert np.array_equal(end.grains.position, grainstat.Results(stepped).state().grains.position)


def test_a_run_resumed_from_its_file_ends_as_the_uninterrupted_one(root, cli, tmp_path):
    whole, by_python, by_cli = tmp_path / "whole.h5", tmp_path / "python.h5", tmp_path / "cli.h5"
    subprocess.run(
        [cli, "run", CRYSTAL, "-o", whole, "--quiet", "--no-plot"], cwd=root, check=True
    )
    with grainstat.Simulation(root / CRYSTAL, output=by_python) as sim:
        for _ in range(23):
            sim.step()
    shutil.copyfile(by_python, by_cli)
    # Increment 20 is the last written (every = 5): the run takes up there.
    with grainstat.Simulation.resume(by_python, scene=root / CRYSTAL) as sim:
        assert sim.increment == 20
        sim.run(progress=False)
    subprocess.run(
        [cli, "run", CRYSTAL, "--resume", by_cli, "--quiet", "--no-plot"], cwd=root, check=True
    )
    assert differences(by_cli, by_python) == []
    # `/summary` counts the work of the run that wrote it last: the resumed part alone.
    assert differences(whole, by_python, summary=False) == []


def test_resuming_with_another_scene_is_refused(root, tmp_path):
    path = tmp_path / "run.h5"
    with grainstat.Simulation(root / CRYSTAL, output=path) as sim:
        sim.step()
    other = grainstat.Scene.from_file(root / CRYSTAL).to_dict()
    other["stages"][1]["increments"] = 10
    with pytest.raises(grainstat.InputError, match="differs from the one"):
        grainstat.Simulation.resume(path, scene=other)


def test_a_wall_stress_set_between_increments_is_reached_and_held(root):
    sim = grainstat.Simulation(root / CRYSTAL, output=False)
    for _ in range(5):  # the isotropic stage to 10 bar
        sim.step()
    top = sim.wall_names.index("top")
    sim.set_wall_stress("top", 2.5e6)
    sim.step()
    assert sim.state.walls.applied_stress[top] == pytest.approx(2.5e6, rel=1e-14)
    # In equilibrium the grains carry it (solver tolerance).
    assert sim.measure().wall_stress[top] == pytest.approx(2.5e6, rel=1e-6)
    sim.step()
    assert sim.state.walls.applied_stress[top] == pytest.approx(2.5e6, rel=1e-14)
    with pytest.raises(grainstat.InputError, match="not under stress control"):
        sim.set_wall_stress("bottom", 1e6)
    with pytest.raises(grainstat.InputError, match="no wall is named `roof`"):
        sim.set_wall_stress("roof", 1e6)


def test_a_run_without_a_file_gives_the_same_states(root, tmp_path):
    with grainstat.Simulation(root / CRYSTAL, output=tmp_path / "a.h5") as with_file:
        with_file.run(progress=False)
        a = with_file.state
    without = grainstat.Simulation(root / CRYSTAL, output=False)
    without.run(progress=False)
    assert without.output is None
    assert np.array_equal(a.contacts.normal_force, without.state.contacts.normal_force)


def test_solver_settings_from_a_dict_replace_the_defaults(root, tmp_path):
    path = tmp_path / "tight.h5"
    with grainstat.Simulation(root / CRYSTAL, solver={"tolerance": 1e-11}, output=path) as sim:
        report = sim.step()
    assert report.residual <= 1e-11
    assert "tolerance = 0.00000000001" in grainstat.Results(path).solver_toml


def test_the_gil_is_released_while_an_increment_is_solved(root, sand_sample):
    import threading
    import time

    scene = grainstat.Scene.from_file(root / "examples" / "biaxial-sand-steps.toml").to_dict()
    scene["grains"]["sample"] = str(sand_sample)
    sim = grainstat.Simulation(scene, output=False)
    done = threading.Event()
    ticks = 0

    def solve():
        while not done.is_set() and not sim.finished:
            sim.step()
        done.set()

    worker = threading.Thread(target=solve)
    start = time.perf_counter()
    worker.start()
    while time.perf_counter() - start < 0.5 and not done.is_set():
        ticks += 1
    done.set()
    worker.join()
    assert sim.increment > 0
    # Held through an increment, the GIL would leave this thread a few hundred ticks.
    assert ticks > 100_000
