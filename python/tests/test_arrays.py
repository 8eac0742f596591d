"""The arrays a state, its measurements and a report hold: shapes, types and units as
docs/python.md gives them; a result file read back into the same objects."""

import sys

import grainstat
import numpy as np
import pytest

CRYSTAL = "examples/crystal-biaxial.toml"


@pytest.fixture(scope="module")
def isotropic(root, tmp_path_factory):
    """The crystal after its isotropic stage to 10 bar, written every increment."""
    path = tmp_path_factory.mktemp("iso") / "crystal.h5"
    sim = grainstat.Simulation(root / CRYSTAL, output=path, every=1)
    reports = [sim.step() for _ in range(5)]
    return sim, reports, path


def test_grain_arrays_have_one_row_per_grain_in_metres(isotropic):
    sim, _, _ = isotropic
    g = sim.state.grains
    n = 635
    assert g.position.shape == (n, 2) and g.position.dtype == np.float64
    assert g.displacement.shape == g.origin.shape == (n, 2)
    assert g.radius.shape == g.rotation.shape == g.taken_out.shape == (n,)
    assert np.all(g.radius == 1e-4)  # the crystal's radius, in metres
    assert np.allclose(g.position - g.origin, g.displacement, rtol=0, atol=1e-18)
    assert g.taken_out.dtype == np.bool_ and not g.taken_out.any()
    # Handed over from Rust without a copy: numpy does not own the memory, and the same
    # array comes back each time it is read.
    assert not g.position.flags.owndata and g.position is g.position


def test_contact_arrays_give_pairs_forces_in_newtons_and_states(isotropic):
    sim, _, _ = isotropic
    c = sim.state.contacts
    m = len(c.normal_force)
    assert c.pairs.shape == (m, 2) and c.pairs.dtype == np.int64
    assert c.shear_force.shape == c.overlap.shape == c.state.shape == (m,)
    assert c.state.dtype == np.uint8 and set(np.unique(c.state)) <= {0, 1, 2, 3}
    grain_grain = c.pairs[:, 0] >= 0
    assert np.all(c.state[grain_grain] == 2)  # the crystal's grains are cemented
    walls = c.pairs[:, 0] < 0
    assert np.all(c.pairs[:, 1] >= 0) and np.all(-c.pairs[walls, 0] - 1 < 4)
    # The top wall's contact forces [N] add up to its force, 10 bar on its length of 3 mm
    # times the depth (the scene's default, one grain diameter: 0.2 mm).
    top = sim.wall_names.index("top")
    force = c.normal_force[c.pairs[:, 0] == -(top + 1)].sum()
    assert force == pytest.approx(sim.measure().wall_normal_force[top], rel=1e-12)
    assert force == pytest.approx(1e6 * 3.0e-3 * 2e-4, rel=1e-6)
    assert c.broken_pairs.shape == (0, 2) and c.broken_mode.shape == (0,)


def test_wall_arrays_and_measurements_in_pascals(isotropic):
    sim, reports, _ = isotropic
    w = sim.state.walls
    assert w.names == ["bottom", "right", "top", "left"]
    assert w.control == ["displacement", "stress", "stress", "displacement"]
    assert w.position.shape == w.slide.shape == w.turn.shape == (4,)
    assert np.isnan(w.applied_stress[0]) and w.applied_stress[2] == pytest.approx(1e6)
    m = sim.measure()
    assert m.wall_stress.shape == m.wall_normal_force.shape == (4,)
    assert m.wall_stress[2] == pytest.approx(1e6, rel=1e-6)
    assert m.macro_stress.shape == (2, 2)
    # Pascals: 10 bar, as the lattice's own volume counts it (appendix 9).
    assert np.allclose(np.diag(m.macro_stress), 1e6, rtol=0.1)
    assert m.macro_stress[0, 1] == pytest.approx(m.macro_stress[1, 0], abs=1e-3)
    assert m.region_stress.shape == (0, 2, 2) and m.region_rotation.shape == (0,)
    assert sim.state.membrane_pressure.shape == (0,)


def test_a_report_holds_the_energy_balance_in_joules(isotropic):
    _, reports, _ = isotropic
    r = reports[0]
    assert r.increment == 1 and r.stage == 0 and r.iterations >= 1
    e = r.energy
    assert e.work > 0 and e.stored == pytest.approx(e.stored_change)
    assert abs(e.imbalance) < 1e-6
    assert r.measurements.macro_stress.shape == (2, 2)


def test_a_result_file_reads_back_into_the_same_objects(isotropic):
    sim, reports, path = isotropic
    results = grainstat.Results(path)
    assert results.increments == [0, 1, 2, 3, 4, 5]
    assert results.scene.name == "crystal-biaxial" and results.wall_names == sim.wall_names
    read, live = results.state(5), sim.state
    assert isinstance(read, grainstat.State)
    for name in ("position", "radius", "rotation", "displacement"):
        assert np.array_equal(getattr(read.grains, name), getattr(live.grains, name))
    assert np.array_equal(read.contacts.pairs, live.contacts.pairs)
    assert np.array_equal(read.contacts.normal_force, live.contacts.normal_force)
    assert np.array_equal(read.walls.position, live.walls.position)
    for r, back in zip(reports, results.reports()[1:]):
        assert (back.increment, back.stage, back.iterations) == (r.increment, r.stage, r.iterations)
        assert back.residual == r.residual and back.energy.work == r.energy.work
        for name in ("wall_stress", "wall_normal_force", "macro_stress"):
            assert np.array_equal(getattr(back.measurements, name), getattr(r.measurements, name))
    history = results.history
    assert history["wall_stress"].shape == (6, 4) and history["increment"].tolist() == [0, 1, 2, 3, 4, 5]
    with pytest.raises(KeyError):
        results.state(7)


def test_progress_uses_tqdm_when_it_is_installed_and_not_otherwise(root, capsys, monkeypatch):
    sim = grainstat.Simulation(root / CRYSTAL, output=False)
    sim.step()
    sim.run(progress=True)
    assert "55/55" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "tqdm", None)  # as if it were not installed
    sim = grainstat.Simulation(root / CRYSTAL, output=False)
    with pytest.raises(ImportError):
        sim.run(progress=True)
    sim.run()
    assert sim.finished and "increment" not in capsys.readouterr().err


def test_help_shows_the_docstrings():
    import pydoc

    page = pydoc.render_doc(grainstat.Simulation, renderer=pydoc.plaintext)
    assert "set_wall_stress" in page and "Load wall `wall`" in page
    assert "Solve the next increment" in grainstat.Simulation.step.__doc__
    assert "(N, 2)" in grainstat.Grains.position.__doc__
