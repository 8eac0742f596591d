"""Type hints of grainstat's native module. Units are SI (m, rad, N, Pa, J), compression
positive; N grains, C contacts, K bonds broken, W walls, M membranes, R regions, n rows."""

import os
from typing import Any, Callable, Optional, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]
SceneLike = Union["Scene", PathLike, dict[str, Any]]
SolverLike = Union[None, PathLike, dict[str, Any]]
F64 = npt.NDArray[np.float64]

class GrainstatError(Exception):
    """Every error grainstat raises; its message is the one the command line prints."""

class InputError(GrainstatError):
    """Bad input: `file`, `line` and `key` say where, `message` what is wrong."""

    file: str
    line: Optional[int]
    key: Optional[str]
    message: str

class NumericError(GrainstatError):
    """The solver failed; the last converged state has been written."""

class FileError(GrainstatError):
    """Reading or writing a file failed."""

class Scene:
    """A scene (the TOML file `grainstat run` and `grainstat generate` read), checked."""

    @staticmethod
    def from_file(path: PathLike) -> Scene:
        """The scene file at `path`; the files it names are relative to its folder."""
    @staticmethod
    def from_toml(text: str, base_dir: PathLike = ".", name: str = "<string>") -> Scene:
        """A scene given as TOML text; `name` is what errors call it."""
    @staticmethod
    def from_dict(scene: dict[str, Any], base_dir: PathLike = ".", name: str = "<dict>") -> Scene:
        """A scene given as a dict of the TOML file's tables and keys."""
    def to_dict(self) -> dict[str, Any]:
        """The scene as a dict of its tables and keys."""
    @property
    def name(self) -> str: ...
    @property
    def toml(self) -> str:
        """The TOML text the scene was read from (stored with the results)."""
    @property
    def file(self) -> str:
        """The file problems are reported against."""
    @property
    def base_dir(self) -> str:
        """The folder the files the scene names are relative to."""
    @property
    def is_sample(self) -> bool:
        """Whether the scene prepares a sample (`generate`) rather than running a load program."""
    @property
    def stages(self) -> list[tuple[str, int]]:
        """The load program's stages as (name, increments)."""
    @property
    def total_increments(self) -> int: ...

class Grains:
    """The grains of a state; row i of every array is grain i."""

    position: F64
    """Centres (N, 2) [m]."""
    radius: F64
    """Radii (N,) [m]."""
    rotation: F64
    """Rotations since the start (N,) [rad, anticlockwise]."""
    displacement: F64
    """Displacements since the start (N, 2) [m]."""
    origin: F64
    """Centres at the start (N, 2) [m]."""
    taken_out: npt.NDArray[np.bool_]
    """Whether each grain was taken out in a breakout (N,)."""

class Contacts:
    """The contacts of a state; row c of every array is contact c."""

    pairs: npt.NDArray[np.int64]
    """Sides (a, b) (C, 2): b a grain; a a grain, or -(w + 1) for wall w."""
    normal_force: F64
    """Normal force (C,) [N], compression positive."""
    shear_force: F64
    """Shear force (C,) [N], along the contact's tangent."""
    overlap: F64
    """Overlap (C,) [m]."""
    state: npt.NDArray[np.uint8]
    """0 elastic, 1 sliding, 2 bonded, 3 bond broken and touching (C,)."""
    broken_pairs: npt.NDArray[np.int64]
    """Pairs of the bonds broken so far (K, 2), coded as `pairs`."""
    broken_increment: npt.NDArray[np.int64]
    """The increment each broke in (K,)."""
    broken_mode: npt.NDArray[np.uint8]
    """How each broke (K,): 0 tension, 1 shear."""

class Walls:
    """The walls of a state, in scene order."""

    names: list[str]
    control: list[str]
    """"displacement" or "stress" for each wall."""
    position: F64
    """Normal move into the sample since the start (W,) [m]."""
    slide: F64
    """Move along the wall since the start (W,) [m]."""
    turn: F64
    """Turn about its pivot (W,) [rad]."""
    applied_stress: F64
    """Stress a stress-controlled wall is loaded by (W,) [Pa]; NaN under displacement control."""

class State:
    """A copy of a run's state after an increment."""

    increment: int
    stage: int
    stage_increment: int
    grains: Grains
    contacts: Contacts
    walls: Walls
    membrane_names: list[str]
    membrane_pressure: F64
    """Each membrane's pressure (M,) [Pa]."""

class Measurements:
    """Measurements of a state."""

    wall_normal_force: F64
    """(W,) [N]."""
    wall_shear_force: F64
    """(W,) [N]."""
    wall_stress: F64
    """Normal stress of the grains on each wall (W,) [Pa]."""
    wall_shear_stress: F64
    """(W,) [Pa]."""
    macro_stress: F64
    """Macro stress sigma_ij (2, 2) [Pa] (eq. A.41)."""
    volume: float
    """[m^3]; NaN where the walls do not close."""
    grain_contacts: int
    wall_contacts: int
    contacts_per_grain: float
    bonds: int
    broken_bonds: int
    mean_rotation: float
    """[rad]."""
    mean_absolute_rotation: float
    """[rad]."""
    region_stress: F64
    """(R, 2, 2) [Pa] (eq. A.40)."""
    region_rotation: F64
    """(R,) [rad]."""

class Energy:
    """An increment's energy balance [J]."""

    work: float
    stored: float
    stored_change: float
    """NaN when read from a result file."""
    dissipated: float
    bonds_released: float
    taken_out: float
    imbalance: float
    """Relative to the largest term."""

class Report:
    """What one converged increment reports."""

    increment: int
    stage: int
    residual: float
    iterations: int
    passes: int
    cuts: int
    contacts_made: int
    contacts_lost: int
    bonds_broken: int
    negative_pivots: Optional[int]
    energy: Energy
    measurements: Measurements

class Simulation:
    """A run of a scene's load program, as `grainstat run` makes it."""

    def __init__(
        self,
        scene: SceneLike,
        solver: SolverLike = None,
        output: Union[None, bool, PathLike] = None,
        every: Optional[int] = None,
        threads: int = 1,
    ) -> None: ...
    @staticmethod
    def resume(
        path: PathLike,
        scene: Optional[SceneLike] = None,
        solver: SolverLike = None,
        every: Optional[int] = None,
        threads: int = 1,
    ) -> Simulation:
        """Take up the run in a result file at its last complete increment."""
    def step(self) -> Optional[Report]:
        """Solve the next increment; None where it found the sample's failure."""
    def run(
        self,
        progress: Optional[bool] = None,
        on_increment: Optional[Callable[[Report], object]] = None,
        log: bool = False,
    ) -> Optional[str]:
        """Solve the rest of the load program; returns the failure it ended with, if any."""
    def set_wall_stress(self, wall: str, stress: float) -> None:
        """Load a stress-controlled wall to `stress` [Pa] in the next increment and hold it."""
    def measure(self) -> Measurements: ...
    def summary(self) -> str: ...
    def close(self) -> None: ...
    def __enter__(self) -> Simulation: ...
    def __exit__(self, *args: object) -> None: ...
    @property
    def state(self) -> State:
        """A copy of the state as it stands."""
    @property
    def name(self) -> str: ...
    @property
    def increment(self) -> int: ...
    @property
    def stage(self) -> int: ...
    @property
    def stage_name(self) -> Optional[str]: ...
    @property
    def total_increments(self) -> int: ...
    @property
    def finished(self) -> bool: ...
    @property
    def failure(self) -> Optional[str]: ...
    @property
    def output(self) -> Optional[str]: ...
    @property
    def wall_names(self) -> list[str]: ...

class Sample:
    """A sample prepared by `generate`."""

    path: str
    state: State
    measurements: Measurements
    growth_steps: int
    residual: float
    grains: int

class Results:
    """A result file read back."""

    def __init__(self, path: PathLike) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def increments(self) -> list[int]: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def solver_toml(self) -> str: ...
    @property
    def wall_names(self) -> list[str]: ...
    @property
    def membrane_names(self) -> list[str]: ...
    @property
    def region_names(self) -> list[str]: ...
    @property
    def failure(self) -> Optional[str]: ...
    @property
    def history(self) -> dict[str, F64]:
        """The /history table as numpy columns."""
    def state(self, increment: Optional[int] = None) -> State: ...
    def report(self, increment: Optional[int] = None) -> Report: ...
    def reports(self) -> list[Report]: ...
    def plot(self, output_dir: Optional[PathLike] = None, increment: Optional[int] = None) -> list[str]: ...

def default_solver() -> dict[str, Any]:
    """The default solver settings: the keys a `solver` dict may set."""

def generate(
    scene: SceneLike,
    output: PathLike,
    solver: SolverLike = None,
    csv: Optional[PathLike] = None,
    threads: int = 1,
    progress: Optional[bool] = None,
) -> Sample:
    """Prepare a sample as the scene's [sample] section says and write it to `output`."""
