//! One increment's group: the whole state, written after the increment and read back to
//! resume.

use super::*;

/// `measured[w]` when the report has one value per wall, NaN otherwise (a report without
/// measurements must not stop the run from being written).
pub(super) fn per_wall(values: &[f64], walls: usize) -> Vec<f64> {
    if values.len() == walls {
        values.to_vec()
    } else {
        vec![f64::NAN; walls]
    }
}

pub(super) fn write_group_state(g: &Group, state: &State, report: &IncrementReport) -> R<()> {
    let grains = g.create_group("grains")?;
    put_plain(
        &grains,
        "position",
        ArrayView2::from(&state.grains.position[..]),
    )?;
    // Origin and displacement too: the solver forms contact geometry from them, and
    // `position = origin + displacement` cannot be split again exactly.
    put_plain(
        &grains,
        "origin",
        ArrayView2::from(&state.grains.origin[..]),
    )?;
    put_plain(
        &grains,
        "displacement",
        ArrayView2::from(&state.grains.displacement[..]),
    )?;
    put_plain(
        &grains,
        "rotation",
        ArrayView1::from(&state.grains.rotation[..]),
    )?;

    let cs = &state.contacts.contacts;
    let contacts = g.create_group("contacts")?;
    let pair: Vec<[i64; 2]> = cs
        .iter()
        .map(|c| [side_code(c.pair.a), c.pair.b as i64])
        .collect();
    put_plain(&contacts, "pair", ArrayView2::from(&pair[..]))?;
    // The contact as a line between grain centres for XDMF; a wall contact's wall end is
    // its grain (a line of zero length).
    let nodes: Vec<[i64; 2]> = pair
        .iter()
        .map(|&[a, b]| [if a < 0 { b } else { a }, b])
        .collect();
    put_plain(&contacts, "nodes", ArrayView2::from(&nodes[..]))?;
    let column = |f: fn(&Contact) -> f64| -> Array1<f64> { cs.iter().map(f).collect() };
    put_plain(
        &contacts,
        "normal_force",
        column(|c| c.response.normal_force).view(),
    )?;
    put_plain(
        &contacts,
        "shear_force",
        column(|c| c.response.shear_force).view(),
    )?;
    put_plain(
        &contacts,
        "shear_displacement",
        column(|c| c.shear_displacement0).view(),
    )?;
    put_plain(&contacts, "overlap", column(|c| c.overlap).view())?;
    let state_code: Array1<u8> = cs.iter().map(|c| c.state() as u8).collect();
    put_plain(&contacts, "state", state_code.view())?;
    let sliding: Array1<u8> = cs.iter().map(|c| u8::from(c.response.sliding)).collect();
    put_plain(&contacts, "sliding", sliding.view())?;
    let params: Vec<[f64; 4]> = cs
        .iter()
        .map(|c| {
            let p = &c.params;
            [p.stiffness, p.kappa, p.friction, p.strength]
        })
        .collect();
    put_plain(&contacts, "params", ArrayView2::from(&params[..]))?;
    let tangent: Vec<[f64; 3]> = cs
        .iter()
        .map(|c| {
            let r = &c.response;
            [r.dfn_dn, r.dfs_dn, r.dfs_ds]
        })
        .collect();
    put_plain(&contacts, "tangent", ArrayView2::from(&tangent[..]))?;

    let nw = state.walls.len();
    let m = &report.measurements;
    let walls = g.create_group("walls")?;
    let wall_column =
        |f: fn(&Wall) -> f64| -> Array1<f64> { state.walls.walls.iter().map(f).collect() };
    put_plain(&walls, "position", wall_column(|w| w.position).view())?;
    put_plain(&walls, "slide", wall_column(|w| w.slide).view())?;
    put_plain(&walls, "turn", wall_column(|w| w.turn).view())?;
    put_plain(&walls, "stress", wall_column(|w| w.stress).view())?;
    let normal_force = per_wall(&m.wall_normal_force, nw);
    put_plain(&walls, "normal_force", ArrayView1::from(&normal_force[..]))?;
    let shear_force = per_wall(&m.wall_shear_force, nw);
    put_plain(&walls, "shear_force", ArrayView1::from(&shear_force[..]))?;
    let measured = per_wall(&m.wall_stress, nw);
    put_plain(&walls, "measured_stress", ArrayView1::from(&measured[..]))?;
    let membranes = g.create_group("membranes")?;
    let pressure: Vec<f64> = state.membranes.iter().map(|m| m.pressure).collect();
    put_plain(&membranes, "pressure", ArrayView1::from(&pressure[..]))?;

    put_plain(g, "macro_stress", ArrayView2::from(&m.macro_stress[..]))?;

    let broken: Vec<[i64; 4]> = state
        .contacts
        .broken_bonds
        .iter()
        .map(|b| {
            [
                side_code(b.pair.a),
                b.pair.b as i64,
                b.increment as i64,
                b.mode as u8 as i64,
            ]
        })
        .collect();
    put_plain(g, "broken_bonds", ArrayView2::from(&broken[..]))?;

    let friends = g.create_group("friends")?;
    put_plain(
        &friends,
        "reference",
        ArrayView2::from(&state.friends_reference[..]),
    )?;
    put_plain(
        &friends,
        "wall_reference",
        ArrayView2::from(&state.friends_wall_reference[..]),
    )?;
    put_plain(g, "last_step", ArrayView1::from(&state.last_step[..]))?;
    write_breakouts(
        g,
        &state.breakouts,
        state.membranes.len(),
        state.walls.len(),
    )?;

    let count = |v: usize| v as i64;
    set_attr(g, "increment", &count(state.increment))?;
    set_attr(g, "stage", &count(state.stage))?;
    set_attr(g, "stage_increment", &count(state.stage_increment))?;
    set_attr(g, "residual", &report.residual)?;
    set_attr(g, "newton_iterations", &count(report.newton_iterations))?;
    set_attr(g, "topology_passes", &count(report.topology_passes))?;
    set_attr(g, "cuts", &i64::from(report.cuts))?;
    set_attr(g, "contacts_made", &count(report.contacts_made))?;
    set_attr(g, "contacts_lost", &count(report.contacts_lost))?;
    set_attr(g, "bonds_broken", &count(report.bonds_broken))?;
    set_attr(g, "contacts_per_grain", &m.contacts_per_grain)?;
    set_attr(g, "grain_contacts", &count(m.grain_contacts))?;
    set_attr(g, "wall_contacts", &count(m.wall_contacts))?;
    set_attr(g, "bonds", &count(m.bonds))?;
    set_attr(g, "volume", &m.volume)?;
    Ok(())
}

pub(super) fn read_group_state(g: &Group, h: &RunHeader) -> R<State> {
    let n = h.radius.len();
    let nw = h.walls.len();
    let grains = g.group("grains")?;
    let mut grains = GrainSet {
        position: read_rows::<f64, 2>(&grains, "position", Some(n))?,
        origin: read_rows::<f64, 2>(&grains, "origin", Some(n))?,
        displacement: read_rows::<f64, 2>(&grains, "displacement", Some(n))?,
        rotation: read_vec::<f64>(&grains, "rotation", Some(n))?,
        radius: h.radius.clone(),
        taken_out: vec![false; n],
    };

    let walls = g.group("walls")?;
    let wall_position = read_vec::<f64>(&walls, "position", Some(nw))?;
    let slide = read_vec::<f64>(&walls, "slide", Some(nw))?;
    // No turns in a file written before walls turned.
    let turn = match walls.link_exists("turn") {
        true => read_vec::<f64>(&walls, "turn", Some(nw))?,
        false => vec![0.0; nw],
    };
    let stress = read_vec::<f64>(&walls, "stress", Some(nw))?;
    let walls = h
        .walls
        .iter()
        .enumerate()
        .map(|(k, w)| w.wall([wall_position[k], slide[k], turn[k]], stress[k]))
        .collect();

    let c = g.group("contacts")?;
    let pair = read_rows::<i64, 2>(&c, "pair", None)?;
    let m = Some(pair.len());
    let normal_force = read_vec::<f64>(&c, "normal_force", m)?;
    let shear_force = read_vec::<f64>(&c, "shear_force", m)?;
    let shear_displacement = read_vec::<f64>(&c, "shear_displacement", m)?;
    let overlap = read_vec::<f64>(&c, "overlap", m)?;
    let state_code = read_vec::<u8>(&c, "state", m)?;
    let sliding = read_vec::<u8>(&c, "sliding", m)?;
    let params = read_rows::<f64, 4>(&c, "params", m)?;
    let tangent = read_rows::<f64, 3>(&c, "tangent", m)?;
    let mut contacts = Vec::with_capacity(pair.len());
    for k in 0..pair.len() {
        let (bonded, broken) = match state_code[k] {
            0 | 1 => (false, false),
            2 => (true, false),
            3 => (false, true),
            s => return Err(Fail(format!("contact {k} has state {s}"))),
        };
        let committed = CommittedContact {
            pair: decode_pair(pair[k][0], pair[k][1], n, nw)?,
            params: ContactParams {
                stiffness: params[k][0],
                kappa: params[k][1],
                friction: params[k][2],
                strength: params[k][3],
            },
            bonded,
            broken,
            shear_displacement: shear_displacement[k],
            overlap: overlap[k],
            response: Response {
                normal_force: normal_force[k],
                shear_force: shear_force[k],
                sliding: sliding[k] != 0,
                dfn_dn: tangent[k][0],
                dfs_dn: tangent[k][1],
                dfs_ds: tangent[k][2],
            },
        };
        contacts.push(committed.contact());
    }

    let broken_bonds = read_rows::<i64, 4>(g, "broken_bonds", None)?
        .into_iter()
        .map(|[a, b, increment, mode]| {
            Ok(BrokenBond {
                pair: decode_pair(a, b, n, nw)?,
                increment: usize::try_from(increment)
                    .map_err(|_| Fail(format!("broken bond at increment {increment}")))?,
                mode: match mode {
                    0 => BreakMode::Tension,
                    1 => BreakMode::Shear,
                    _ => return Err(Fail(format!("broken bond mode {mode}"))),
                },
            })
        })
        .collect::<R<Vec<_>>>()?;

    let pressure = read_vec::<f64>(&g.group("membranes")?, "pressure", Some(h.membranes.len()))?;
    let membranes = h
        .membranes
        .iter()
        .zip(&pressure)
        .map(|(m, p)| Membrane {
            pressure: *p,
            ..m.clone()
        })
        .collect();
    let friends = g.group("friends")?;
    let breakouts = read_breakouts(g, &mut grains.taken_out, h.membranes.len(), nw)?;
    Ok(State {
        increment: get_count(g, "increment")?,
        stage: get_count(g, "stage")?,
        stage_increment: get_count(g, "stage_increment")?,
        grains: grains.into(),
        walls: WallSet { walls },
        contacts: ContactSet {
            contacts,
            broken_bonds,
        }
        .into(),
        friends_reference: read_rows::<f64, 2>(&friends, "reference", None)?,
        friends_wall_reference: read_rows::<f64, 2>(&friends, "wall_reference", None)?,
        last_step: if g.link_exists("last_step") {
            read_vec::<f64>(g, "last_step", None)?
        } else {
            Vec::new()
        },
        breakouts,
        membranes,
    })
}

/// The breakouts `list`, as group `breakouts`: their increments, grain counts and bonds
/// broken, their grains one breakout after another, and the loads carried (`membranes` and
/// `walls` wide).
pub(super) fn write_breakouts(
    g: &Group,
    list: &[Breakout],
    membranes: usize,
    walls: usize,
) -> R<()> {
    let group = g.create_group("breakouts")?;
    let column =
        |f: fn(&Breakout) -> usize| -> Array1<i64> { list.iter().map(|b| f(b) as i64).collect() };
    put_plain(&group, "increment", column(|b| b.increment).view())?;
    put_plain(&group, "grain_count", column(|b| b.grains.len()).view())?;
    put_plain(&group, "bonds_broken", column(|b| b.bonds_broken).view())?;
    put_plain(&group, "debris", column(|b| usize::from(b.debris)).view())?;
    let grains: Array1<i64> = (list.iter().flat_map(|b| &b.grains))
        .map(|&i| i as i64)
        .collect();
    put_plain(&group, "grains", grains.view())?;
    let table = |width: usize, row: &dyn Fn(&Breakout) -> Vec<f64>| -> R<Array2<f64>> {
        let values = list.iter().flat_map(row).collect();
        Ok(Array2::from_shape_vec((list.len(), width), values)?)
    };
    let pressure = table(membranes, &|b| b.pressure.clone())?;
    put_plain(&group, "membrane_pressure", pressure.view())?;
    let stress = table(walls, &|b| {
        b.stress.iter().map(|s| s.unwrap_or(f64::NAN)).collect()
    })?;
    put_plain(&group, "wall_stress", stress.view())
}

/// The breakouts of a group (none in files from before grains were taken out), their grains
/// marked in `taken_out`; `membranes` and `walls` wide.
pub(super) fn read_breakouts(
    g: &Group,
    taken_out: &mut [bool],
    membranes: usize,
    walls: usize,
) -> R<Vec<Breakout>> {
    if !g.link_exists("breakouts") {
        return Ok(Vec::new());
    }
    let group = g.group("breakouts")?;
    let increment = read_vec::<i64>(&group, "increment", None)?;
    let count = Some(increment.len());
    let grain_count = read_vec::<i64>(&group, "grain_count", count)?;
    let bonds_broken = read_vec::<i64>(&group, "bonds_broken", count)?;
    // Files written before debris was told apart have none.
    let debris = if group.link_exists("debris") {
        read_vec::<i64>(&group, "debris", count)?
    } else {
        vec![0; increment.len()]
    };
    let all = read_vec::<i64>(&group, "grains", None)?;
    let pressure = read_table(&group, "membrane_pressure", increment.len(), membranes)?;
    let stress = read_table(&group, "wall_stress", increment.len(), walls)?;
    let natural = |name: &str, v: i64| {
        usize::try_from(v).map_err(|_| Fail(format!("breakouts/{name} holds {v}")))
    };
    let mut rest = &all[..];
    let mut breakouts = Vec::with_capacity(increment.len());
    for k in 0..increment.len() {
        let size = natural("grain_count", grain_count[k])?;
        if size > rest.len() {
            return Err(Fail(format!(
                "breakouts/grains is shorter than breakouts/grain_count says ({} grains)",
                all.len()
            )));
        }
        let (mine, after) = rest.split_at(size);
        rest = after;
        let mut cluster = Vec::with_capacity(size);
        for &i in mine {
            let i = natural("grains", i)?;
            match taken_out.get_mut(i) {
                Some(out) if !*out => *out = true,
                Some(_) => return Err(Fail(format!("grain {i} is taken out twice"))),
                None => return Err(Fail(format!("breakouts/grains names grain {i}"))),
            }
            cluster.push(i);
        }
        cluster.sort_unstable();
        breakouts.push(Breakout {
            increment: natural("increment", increment[k])?,
            grains: cluster,
            bonds_broken: natural("bonds_broken", bonds_broken[k])?,
            debris: debris[k] != 0,
            pressure: pressure[k].clone(),
            stress: stress[k]
                .iter()
                .map(|s| (!s.is_nan()).then_some(*s))
                .collect(),
        });
    }
    if !rest.is_empty() {
        return Err(Fail(format!(
            "breakouts/grains holds {} grains, breakouts/grain_count adds up to fewer",
            all.len()
        )));
    }
    Ok(breakouts)
}

/// A `rows` x `width` dataset of f64 as rows.
fn read_table(g: &Group, name: &str, rows: usize, width: usize) -> R<Vec<Vec<f64>>> {
    let ds = dataset(g, name)?;
    let shape = ds.shape();
    let raw = ds
        .read_raw::<f64>()
        .map_err(|e| Fail(format!("dataset `{}/{name}`: {e}", g.name())))?;
    if shape != [rows, width] || raw.len() != rows * width {
        return Err(Fail(format!(
            "dataset `{}/{name}` has shape {shape:?}, expected ({rows}, {width})",
            g.name()
        )));
    }
    Ok((0..rows)
        .map(|r| raw[r * width..(r + 1) * width].to_vec())
        .collect())
}
