"""grainstat from Python: exact quasi-static discrete element analysis of granular materials
in 2D (S. van Baars, *Discrete Element Analysis of Granular Materials*, TU Delft, 1996).

The module drives the grainstat library itself, not the command line:

- ``Scene.from_file(path)``, ``Scene.from_toml(text)``, ``Scene.from_dict(d)``: a scene,
  checked; a problem raises ``InputError`` naming the file, the key and the line;
- ``generate(scene, output)``: prepare a sample, as ``grainstat generate`` does;
- ``Simulation(scene, solver=..., output=...)``: a run as ``grainstat run`` begins it, with the
  same HDF5 result file; ``step()`` one increment, ``run()`` the rest, ``set_wall_stress()``
  between increments; ``Simulation.resume(path)`` takes a run up from its file;
- ``sim.state`` (grains, contacts, walls as numpy arrays), ``sim.measure()`` and each
  increment's ``Report`` (measurements and energy balance);
- ``Results(path)``: a result file read back into the same objects.

Units are SI (m, rad, N, Pa, J), compression positive, rotations anticlockwise. Runs release
the GIL while an increment is solved, and show a tqdm progress bar when tqdm is installed.
See docs/python.md for every array's shape and unit.
"""

from ._grainstat import (
    Contacts,
    Energy,
    FileError,
    GrainstatError,
    Grains,
    InputError,
    Measurements,
    NumericError,
    Report,
    Results,
    Sample,
    Scene,
    Simulation,
    State,
    Walls,
    __version__,
    default_solver,
    generate,
)

__all__ = [
    "Contacts",
    "Energy",
    "FileError",
    "GrainstatError",
    "Grains",
    "InputError",
    "Measurements",
    "NumericError",
    "Report",
    "Results",
    "Sample",
    "Scene",
    "Simulation",
    "State",
    "Walls",
    "__version__",
    "default_solver",
    "generate",
]
