//! A state, its measurements and an increment's report as numpy arrays, in SI units
//! (metres, radians, newtons, pascals, joules), compression positive. A state is a copy of
//! the simulation's as it stood when it was asked for: its arrays do not change when the
//! simulation steps on. Arrays held as one block in Rust (grain positions, radii, rotations)
//! are handed to numpy without a further copy; those gathered from the contacts and walls are
//! new arrays.

use crate::convert::{array1, array2, tensor, tensors};
use grainstat::geometry::{Side, WallControl};
use grainstat::output::hdf5_file::{control_name, side_code, History};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// The state of a run after an increment: grains, contacts, walls, membranes.
#[pyclass(frozen, module = "grainstat")]
pub struct State {
    /// Load increments completed.
    #[pyo3(get)]
    increment: usize,
    /// The current stage's index in the load program (its number of stages when done).
    #[pyo3(get)]
    stage: usize,
    /// Increments completed in the current stage.
    #[pyo3(get)]
    stage_increment: usize,
    /// The grains.
    #[pyo3(get)]
    grains: Py<Grains>,
    /// The contacts, grain-grain and grain-wall.
    #[pyo3(get)]
    contacts: Py<Contacts>,
    /// The walls, in scene order.
    #[pyo3(get)]
    walls: Py<Walls>,
    /// Membrane names.
    #[pyo3(get)]
    membrane_names: Vec<String>,
    /// Each membrane's pressure (M,) [Pa].
    #[pyo3(get)]
    membrane_pressure: Py<PyArray1<f64>>,
}

/// The grains of a state; row `i` of every array is grain `i`.
#[pyclass(frozen, module = "grainstat")]
pub struct Grains {
    /// Centres (N, 2) [m].
    #[pyo3(get)]
    position: Py<PyArray2<f64>>,
    /// Radii (N,) [m].
    #[pyo3(get)]
    radius: Py<PyArray1<f64>>,
    /// Rotations since the start (N,) [rad, anticlockwise].
    #[pyo3(get)]
    rotation: Py<PyArray1<f64>>,
    /// Displacements since the start (N, 2) [m]: `position - origin`.
    #[pyo3(get)]
    displacement: Py<PyArray2<f64>>,
    /// Centres at the start (N, 2) [m].
    #[pyo3(get)]
    origin: Py<PyArray2<f64>>,
    /// Whether each grain has been taken out of the sample in a breakout (N,).
    #[pyo3(get)]
    taken_out: Py<PyArray1<bool>>,
}

/// The contacts of a state; row `c` of every array is contact `c`.
#[pyclass(frozen, module = "grainstat")]
pub struct Contacts {
    /// The two sides `(a, b)` (C, 2) int64: `b` a grain; `a` a grain, or `-(w + 1)` for wall
    /// `w` (the result file's coding).
    #[pyo3(get)]
    pairs: Py<PyArray2<i64>>,
    /// Normal force (C,) [N], compression positive (negative: a bond in tension).
    #[pyo3(get)]
    normal_force: Py<PyArray1<f64>>,
    /// Shear force (C,) [N], along the contact's tangent (the normal from `a` to `b`
    /// turned 90 degrees anticlockwise).
    #[pyo3(get)]
    shear_force: Py<PyArray1<f64>>,
    /// Overlap (C,) [m] (negative: apart, a bond holding them).
    #[pyo3(get)]
    overlap: Py<PyArray1<f64>>,
    /// State (C,) uint8: 0 elastic, 1 sliding, 2 bonded, 3 bond broken, still touching.
    #[pyo3(get)]
    state: Py<PyArray1<u8>>,
    /// Bonds broken so far: their pairs (K, 2), coded as `pairs`.
    #[pyo3(get)]
    broken_pairs: Py<PyArray2<i64>>,
    /// The increment each broke in (K,).
    #[pyo3(get)]
    broken_increment: Py<PyArray1<i64>>,
    /// How each broke (K,) uint8: 0 in tension, 1 in shear.
    #[pyo3(get)]
    broken_mode: Py<PyArray1<u8>>,
}

/// The walls of a state, in scene order; row `w` of every array is wall `w`.
#[pyclass(frozen, module = "grainstat")]
pub struct Walls {
    /// Names.
    #[pyo3(get)]
    names: Vec<String>,
    /// `"displacement"` (prescribed) or `"stress"` (loaded by a stress).
    #[pyo3(get)]
    control: Vec<String>,
    /// Normal move into the sample since the start (W,) [m].
    #[pyo3(get)]
    position: Py<PyArray1<f64>>,
    /// Move along the wall since the start (W,) [m].
    #[pyo3(get)]
    slide: Py<PyArray1<f64>>,
    /// Turn about its pivot since the start (W,) [rad, anticlockwise].
    #[pyo3(get)]
    turn: Py<PyArray1<f64>>,
    /// The stress a wall under stress control is loaded by (W,) [Pa]; NaN for a wall under
    /// displacement control. The stress the grains put on each wall is in the measurements.
    #[pyo3(get)]
    applied_stress: Py<PyArray1<f64>>,
}

impl State {
    /// The Python state of `state` (taken over, not copied again).
    pub fn of(py: Python<'_>, state: grainstat::state::State) -> PyResult<State> {
        let g = state.grains.into_inner();
        let grains = Grains {
            position: array2(py, g.position).unbind(),
            radius: array1(py, g.radius).unbind(),
            rotation: array1(py, g.rotation).unbind(),
            displacement: array2(py, g.displacement).unbind(),
            origin: array2(py, g.origin).unbind(),
            taken_out: array1(py, g.taken_out).unbind(),
        };
        let cs = &state.contacts.contacts;
        let broken = &state.contacts.broken_bonds;
        let pair = |a: Side, b: usize| [side_code(a), b as i64];
        let contacts = Contacts {
            pairs: array2(py, cs.iter().map(|c| pair(c.pair.a, c.pair.b)).collect()).unbind(),
            normal_force: array1(py, cs.iter().map(|c| c.response.normal_force).collect()).unbind(),
            shear_force: array1(py, cs.iter().map(|c| c.response.shear_force).collect()).unbind(),
            overlap: array1(py, cs.iter().map(|c| c.overlap).collect()).unbind(),
            state: array1(py, cs.iter().map(|c| c.state() as u8).collect()).unbind(),
            broken_pairs: array2(
                py,
                broken.iter().map(|b| pair(b.pair.a, b.pair.b)).collect(),
            )
            .unbind(),
            broken_increment: array1(py, broken.iter().map(|b| b.increment as i64).collect())
                .unbind(),
            broken_mode: array1(py, broken.iter().map(|b| b.mode as u8).collect()).unbind(),
        };
        let ws = &state.walls.walls;
        let walls = Walls {
            names: ws.iter().map(|w| w.name.clone()).collect(),
            control: ws.iter().map(|w| control_name(w.control).into()).collect(),
            position: array1(py, ws.iter().map(|w| w.position).collect()).unbind(),
            slide: array1(py, ws.iter().map(|w| w.slide).collect()).unbind(),
            turn: array1(py, ws.iter().map(|w| w.turn).collect()).unbind(),
            applied_stress: array1(
                py,
                ws.iter()
                    .map(|w| match w.control {
                        WallControl::Stress => w.stress,
                        WallControl::Displacement => f64::NAN,
                    })
                    .collect(),
            )
            .unbind(),
        };
        let ms = &state.membranes;
        Ok(State {
            increment: state.increment,
            stage: state.stage,
            stage_increment: state.stage_increment,
            grains: Py::new(py, grains)?,
            contacts: Py::new(py, contacts)?,
            walls: Py::new(py, walls)?,
            membrane_names: ms.iter().map(|m| m.name.clone()).collect(),
            membrane_pressure: array1(py, ms.iter().map(|m| m.pressure).collect()).unbind(),
        })
    }
}

#[pymethods]
impl State {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "State(increment={}, stage={}, {} grains, {} contacts, {} walls)",
            self.increment,
            self.stage,
            self.grains.get().radius.bind(py).len(),
            self.contacts.get().state.bind(py).len(),
            self.walls.get().names.len()
        )
    }
}

/// Measurements of a state: the forces and stresses on the walls, the macro stress
/// (eq. A.41), contact counts, rotations, the stress in each region (eq. A.40).
#[pyclass(frozen, module = "grainstat")]
pub struct Measurements {
    /// Normal force of the grains on each wall (W,) [N] (per depth `D` of the scene).
    #[pyo3(get)]
    wall_normal_force: Py<PyArray1<f64>>,
    /// Shear force of the grains on each wall, along its tangent (W,) [N].
    #[pyo3(get)]
    wall_shear_force: Py<PyArray1<f64>>,
    /// Normal stress of the grains on each wall (W,) [Pa]: force over loaded length times
    /// depth.
    #[pyo3(get)]
    wall_stress: Py<PyArray1<f64>>,
    /// Shear stress of the grains on each wall (W,) [Pa].
    #[pyo3(get)]
    wall_shear_stress: Py<PyArray1<f64>>,
    /// Macro stress `sigma_ij` (2, 2) [Pa], compression positive (eq. A.41).
    #[pyo3(get)]
    macro_stress: Py<PyArray2<f64>>,
    /// Volume enclosed by the walls and membranes times the depth [m^3]; NaN where they do
    /// not close.
    #[pyo3(get)]
    volume: f64,
    /// Grain-grain contacts.
    #[pyo3(get)]
    grain_contacts: usize,
    /// Grain-wall contacts.
    #[pyo3(get)]
    wall_contacts: usize,
    /// Grain-grain contacts per grain in the sample.
    #[pyo3(get)]
    contacts_per_grain: f64,
    /// Bonds intact.
    #[pyo3(get)]
    bonds: usize,
    /// Bonds broken so far.
    #[pyo3(get)]
    broken_bonds: usize,
    /// Mean grain rotation since the start [rad, anticlockwise].
    #[pyo3(get)]
    mean_rotation: f64,
    /// Mean of the grains' absolute rotations [rad].
    #[pyo3(get)]
    mean_absolute_rotation: f64,
    /// Stress in each region (R, 2, 2) [Pa], compression positive (eq. A.40).
    #[pyo3(get)]
    region_stress: Py<PyArray3<f64>>,
    /// Mean grain rotation in each region (R,) [rad].
    #[pyo3(get)]
    region_rotation: Py<PyArray1<f64>>,
}

impl Measurements {
    /// The Python measurements of `m` (taken over).
    pub fn of(py: Python<'_>, m: grainstat::measure::Measurements) -> Measurements {
        Measurements {
            wall_normal_force: array1(py, m.wall_normal_force).unbind(),
            wall_shear_force: array1(py, m.wall_shear_force).unbind(),
            wall_stress: array1(py, m.wall_stress).unbind(),
            wall_shear_stress: array1(py, m.wall_shear_stress).unbind(),
            macro_stress: tensor(py, m.macro_stress).unbind(),
            volume: m.volume,
            grain_contacts: m.grain_contacts,
            wall_contacts: m.wall_contacts,
            contacts_per_grain: m.contacts_per_grain,
            bonds: m.bonds,
            broken_bonds: m.broken_bonds,
            mean_rotation: m.mean_rotation,
            mean_absolute_rotation: m.mean_absolute_rotation,
            region_stress: tensors(py, m.region_stress).unbind(),
            region_rotation: array1(py, m.region_rotation).unbind(),
        }
    }
}

#[pymethods]
impl Measurements {
    fn __repr__(&self, py: Python<'_>) -> String {
        let s = self.macro_stress.bind(py).to_vec().unwrap_or_default();
        format!(
            "Measurements(macro_stress=[[{:.4e}, {:.4e}], [{:.4e}, {:.4e}]] Pa, {} contacts)",
            s[0],
            s[1],
            s[2],
            s[3],
            self.grain_contacts + self.wall_contacts
        )
    }
}

/// An increment's energy balance [J]: the work of the walls and membranes on the grains
/// against the change of the energy stored in the contacts, the energy friction dissipated,
/// the energy the broken bonds held and the energy carried away by grains taken out.
#[pyclass(frozen, module = "grainstat")]
pub struct Energy {
    /// Work of the walls and membranes on the grains [J].
    #[pyo3(get)]
    work: f64,
    /// Energy stored in the contacts at the end of the increment [J].
    #[pyo3(get)]
    stored: f64,
    /// Change of the stored energy over the increment [J]; NaN when read from a result
    /// file, which does not hold it.
    #[pyo3(get)]
    stored_change: f64,
    /// Energy dissipated by sliding [J].
    #[pyo3(get)]
    dissipated: f64,
    /// Energy the bonds that broke held [J].
    #[pyo3(get)]
    bonds_released: f64,
    /// Energy the contacts of grains taken out stored [J].
    #[pyo3(get)]
    taken_out: f64,
    /// `work - stored_change - dissipated - bonds_released - taken_out`, relative to the
    /// largest term.
    #[pyo3(get)]
    imbalance: f64,
}

#[pymethods]
impl Energy {
    fn __repr__(&self) -> String {
        format!(
            "Energy(work={:.4e} J, stored={:.4e} J, dissipated={:.4e} J, imbalance={:.1e})",
            self.work, self.stored, self.dissipated, self.imbalance
        )
    }
}

/// What one converged increment reports: how the solver did, its energy balance and the
/// measurements of the state it reached.
#[pyclass(frozen, module = "grainstat")]
pub struct Report {
    /// The increment (1-based; 0 for the state before loading).
    #[pyo3(get)]
    increment: usize,
    /// The stage it belongs to.
    #[pyo3(get)]
    stage: usize,
    /// Final relative residual `|R|_inf / F_ref`.
    #[pyo3(get)]
    residual: f64,
    /// Newton iterations of the minimisation (sweeps of the relaxation).
    #[pyo3(get)]
    iterations: usize,
    /// Passes of the minimisation.
    #[pyo3(get)]
    passes: usize,
    /// Times the increment was halved.
    #[pyo3(get)]
    cuts: u32,
    /// Contacts made in the increment.
    #[pyo3(get)]
    contacts_made: usize,
    /// Contacts lost in the increment.
    #[pyo3(get)]
    contacts_lost: usize,
    /// Bonds broken in the increment.
    #[pyo3(get)]
    bonds_broken: usize,
    /// The stability indicator: negative pivots of the tangent at the converged state
    /// (None: not counted).
    #[pyo3(get)]
    negative_pivots: Option<usize>,
    /// The energy balance.
    #[pyo3(get)]
    energy: Py<Energy>,
    /// The measurements of the state reached.
    #[pyo3(get)]
    measurements: Py<Measurements>,
}

impl Report {
    /// The Python report of `r` (taken over).
    pub fn of(py: Python<'_>, r: grainstat::state::IncrementReport) -> PyResult<Report> {
        let e = r.energy;
        let energy = Energy {
            work: e.work,
            stored: e.stored,
            stored_change: e.stored_change,
            dissipated: e.dissipated,
            bonds_released: e.bonds_released,
            taken_out: e.taken_out,
            imbalance: e.imbalance(),
        };
        Ok(Report {
            increment: r.increment,
            stage: r.stage,
            residual: r.residual,
            iterations: r.newton_iterations,
            passes: r.topology_passes,
            cuts: r.cuts,
            contacts_made: r.contacts_made,
            contacts_lost: r.contacts_lost,
            bonds_broken: r.bonds_broken,
            negative_pivots: r.negative_pivots,
            energy: Py::new(py, energy)?,
            measurements: Py::new(py, Measurements::of(py, r.measurements))?,
        })
    }

    /// The report of row `row` of a result file's `/history`.
    pub fn of_history(py: Python<'_>, h: &History, row: usize) -> PyResult<Report> {
        let int = |name: &str| h.int(name).get(row).copied().unwrap_or(0);
        let count = |name: &str| int(name).max(0) as usize;
        let float = |name: &str| h.float(name).get(row).copied().unwrap_or(f64::NAN);
        let wall = |name: &str| h.wall(name).get(row).cloned().unwrap_or_default();
        let region = |name: &str| h.region(name).get(row).cloned().unwrap_or_default();
        let (xx, yy, xy, yx) = (
            region("region_stress_xx"),
            region("region_stress_yy"),
            region("region_stress_xy"),
            region("region_stress_yx"),
        );
        let region_stress = (0..xx.len())
            .map(|k| [[xx[k], xy[k]], [yx[k], yy[k]]])
            .collect();
        let m = grainstat::measure::Measurements {
            wall_normal_force: wall("wall_normal_force"),
            wall_shear_force: wall("wall_shear_force"),
            wall_stress: wall("wall_stress"),
            wall_shear_stress: wall("wall_shear_stress"),
            macro_stress: [
                [float("macro_stress_xx"), float("macro_stress_xy")],
                [float("macro_stress_yx"), float("macro_stress_yy")],
            ],
            volume: float("volume"),
            grain_contacts: count("grain_contacts"),
            wall_contacts: count("wall_contacts"),
            contacts_per_grain: float("contacts_per_grain"),
            bonds: count("bonds"),
            broken_bonds: count("broken_bonds"),
            mean_rotation: float("mean_rotation"),
            mean_absolute_rotation: float("mean_absolute_rotation"),
            region_stress,
            region_rotation: region("region_rotation"),
        };
        let energy = Energy {
            work: float("energy_work"),
            stored: float("energy_stored"),
            stored_change: f64::NAN,
            dissipated: float("energy_dissipated"),
            bonds_released: float("energy_bonds_released"),
            taken_out: float("energy_taken_out"),
            imbalance: float("energy_imbalance"),
        };
        let pivots = h.int("negative_pivots").get(row).copied().unwrap_or(-1);
        // The row holds the state's place in the load program: an increment that ended its
        // stage belongs to the stage before.
        let ended_stage = count("increment") > 0 && count("stage_increment") == 0;
        Ok(Report {
            increment: count("increment"),
            stage: count("stage") - usize::from(ended_stage),
            residual: float("residual"),
            iterations: count("newton_iterations"),
            passes: count("topology_passes"),
            cuts: count("cuts") as u32,
            contacts_made: count("contacts_made"),
            contacts_lost: count("contacts_lost"),
            bonds_broken: count("bonds_broken"),
            negative_pivots: usize::try_from(pivots).ok(),
            energy: Py::new(py, energy)?,
            measurements: Py::new(py, Measurements::of(py, m))?,
        })
    }
}

#[pymethods]
impl Report {
    fn __repr__(&self) -> String {
        format!(
            "Report(increment={}, stage={}, iterations={}, residual={:.1e}, cuts={})",
            self.increment, self.stage, self.iterations, self.residual, self.cuts
        )
    }
}
