//! What a run concluded, in `/summary` and `/failure`: the solver's timers and counts, and
//! the mechanism of a failure that found no equilibrium near.

use super::*;

/// The timers of `/summary`, by name. Files from before settling was removed have
/// `time_settling` too, which is not read.
pub(super) fn timers_mut(t: &mut StageTimers) -> [(&'static str, &mut f64); 8] {
    [
        ("detection", &mut t.detection),
        ("return_map", &mut t.return_map),
        ("assembly", &mut t.assembly),
        ("symbolic", &mut t.symbolic),
        ("factorisation", &mut t.factorisation),
        ("solve", &mut t.solve),
        ("topology", &mut t.topology),
        ("output", &mut t.output),
    ]
}

/// The counters of `/summary`, by name. Files from before the Newton solver was removed have
/// `factorisations_reused` and `settling_steps` too, which are not read.
pub(super) fn counters_mut(c: &mut Counters) -> [(&'static str, &mut usize); 11] {
    [
        ("increments", &mut c.increments),
        ("newton_iterations", &mut c.newton_iterations),
        ("symbolic_factorisations", &mut c.symbolic_factorisations),
        ("numeric_factorisations", &mut c.numeric_factorisations),
        ("solves", &mut c.solves),
        ("topology_passes", &mut c.topology_passes),
        ("friends_rebuilds", &mut c.friends_rebuilds),
        ("contacts_made", &mut c.contacts_made),
        ("contacts_lost", &mut c.contacts_lost),
        ("bonds_broken", &mut c.bonds_broken),
        ("cuts", &mut c.cuts),
    ]
}

/// The failure that found no equilibrium near: where the descent carried the grains, from
/// the last state in equilibrium, and which of them it carried on. Not an increment: the
/// state it shows is not in equilibrium, and the run's last increment is the one before.
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// The increment (1-based) that found no equilibrium near.
    pub increment: usize,
    /// What the run said of it.
    pub description: String,
    /// The grains the descent carried on, in increasing order.
    pub grains: Vec<usize>,
    /// Each grain's centre where the descent started: the highest load found in equilibrium,
    /// past the last increment on file where halves of the failing one converged (m).
    pub position: Vec<[f64; 2]>,
    /// Each grain's displacement in the descent (m).
    pub displacement: Vec<[f64; 2]>,
    /// Each membrane's pressure there (Pa).
    pub membrane_pressure: Vec<f64>,
    /// Each wall's stress there (Pa).
    pub wall_stress: Vec<f64>,
    /// The part of the failing increment found in equilibrium with the highest macro
    /// deviator: a displacement-controlled test's peak, where its last half step before the
    /// failure holds it.
    pub peak: Option<PeakState>,
    /// Every breakout up to the failure: those of the failing increment, which is not on
    /// file, after those of the increments before it.
    pub breakouts: Vec<Breakout>,
}

pub(super) fn write_mechanism_group(file: &File, m: &Mechanism) -> R<()> {
    if file.link_exists("failure") {
        file.unlink("failure")?;
    }
    let g = file.create_group("failure")?;
    set_attr(&g, "increment", &(m.increment as i64))?;
    set_str_attr(&g, "description", &m.description)?;
    let grains: Array1<i64> = m.grains.iter().map(|&i| i as i64).collect();
    put_plain(&g, "grains", grains.view())?;
    for (name, rows) in [("position", &m.position), ("displacement", &m.displacement)] {
        let flat = rows.iter().flatten().copied().collect();
        put_plain(
            &g,
            name,
            Array2::from_shape_vec((rows.len(), 2), flat)?.view(),
        )?;
    }
    put_plain(
        &g,
        "membrane_pressure",
        ArrayView1::from(&m.membrane_pressure),
    )?;
    put_plain(&g, "wall_stress", ArrayView1::from(&m.wall_stress))?;
    let (membranes, walls) = (m.membrane_pressure.len(), m.wall_stress.len());
    write_breakouts(&g, &m.breakouts, membranes, walls)?;
    if let Some(peak) = &m.peak {
        let stress: Vec<f64> = peak.macro_stress.iter().flatten().copied().collect();
        put_plain(
            &g,
            "peak_macro_stress",
            Array2::from_shape_vec((2, 2), stress)?.view(),
        )?;
        put_plain(
            &g,
            "peak_wall_position",
            ArrayView1::from(&peak.wall_position),
        )?;
        put_plain(&g, "peak_wall_stress", ArrayView1::from(&peak.wall_stress))?;
    }
    Ok(())
}

pub(super) fn read_mechanism_group(file: &File) -> R<Option<Mechanism>> {
    if !file.link_exists("failure") {
        return Ok(None);
    }
    let g = file.group("failure")?;
    let position = read_rows::<f64, 2>(&g, "position", None)?;
    let displacement = read_rows::<f64, 2>(&g, "displacement", Some(position.len()))?;
    let grains = (read_vec::<i64>(&g, "grains", None)?.into_iter())
        .map(|i| match usize::try_from(i) {
            Ok(i) if i < displacement.len() => Ok(i),
            _ => Err(Fail(format!("failure/grains names grain {i}"))),
        })
        .collect::<R<Vec<usize>>>()?;
    let membrane_pressure = read_vec::<f64>(&g, "membrane_pressure", None)?;
    let wall_stress = read_vec::<f64>(&g, "wall_stress", None)?;
    let mut taken_out = vec![false; position.len()];
    let (membranes, walls) = (membrane_pressure.len(), wall_stress.len());
    let breakouts = read_breakouts(&g, &mut taken_out, membranes, walls)?;
    Ok(Some(Mechanism {
        increment: get_count(&g, "increment")?,
        description: get_str_attr(&g, "description")?,
        grains,
        position,
        displacement,
        membrane_pressure,
        wall_stress,
        breakouts,
        peak: match g.link_exists("peak_macro_stress") {
            true => {
                let [xx, xy, yx, yy] =
                    read_rows::<f64, 2>(&g, "peak_macro_stress", Some(2))?.concat()[..]
                else {
                    return Err(Fail("failure/peak_macro_stress is not 2 x 2".into()));
                };
                Some(PeakState {
                    wall_position: read_vec::<f64>(&g, "peak_wall_position", None)?,
                    wall_stress: read_vec::<f64>(&g, "peak_wall_stress", None)?,
                    macro_stress: [[xx, xy], [yx, yy]],
                })
            }
            false => None,
        },
    }))
}

pub(super) fn write_summary_group(file: &File, stats: &SolverStats) -> R<()> {
    let g = if file.link_exists("summary") {
        file.group("summary")?
    } else {
        file.create_group("summary")?
    };
    let mut stats = *stats;
    for (name, v) in timers_mut(&mut stats.timers) {
        set_attr(&g, &format!("time_{name}"), &*v)?;
    }
    for (name, v) in counters_mut(&mut stats.counters) {
        set_attr(&g, name, &(*v as i64))?;
    }
    Ok(())
}

pub(super) fn read_summary_group(file: &File) -> R<Option<SolverStats>> {
    if !file.link_exists("summary") {
        return Ok(None);
    }
    let g = file.group("summary")?;
    let mut stats = SolverStats::default();
    for (name, v) in timers_mut(&mut stats.timers) {
        *v = get_attr::<f64>(&g, &format!("time_{name}"))?;
    }
    for (name, v) in counters_mut(&mut stats.counters) {
        *v = get_count(&g, name)?;
    }
    Ok(Some(stats))
}
