//! `grainstat info`: a human summary of a result file.

use super::*;

/// A human summary of a result file, for `grainstat info`.
pub fn info(path: impl AsRef<Path>) -> Result<String, Error> {
    let path = path.as_ref();
    read_in_child(path, || summarise(path).is_ok())?;
    summarise(path)
}

fn summarise(path: &Path) -> Result<String, Error> {
    let file = open_existing(path)?;
    let text = || -> R<String> {
        let header = read_header(&file)?;
        let inc = file.group("increments")?;
        let groups = increment_groups(&inc)?;
        let complete: Vec<usize> = groups.iter().filter(|g| g.2).map(|g| g.0).collect();
        let mut out = String::new();
        let w = &mut out;
        let _ = writeln!(w, "file        {}", path.display());
        let _ = writeln!(
            w,
            "scene       {} (grainstat {}, {} law{})",
            header.scene_name,
            header.version,
            header.law,
            if header.fixed_rotations {
                ", rotations fixed"
            } else {
                ""
            }
        );
        let _ = writeln!(
            w,
            "grains      {} (radius {:.4e} .. {:.4e} m), depth {:.4e} m",
            header.radius.len(),
            header.radius.iter().cloned().fold(f64::INFINITY, f64::min),
            header
                .radius
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max),
            header.depth
        );
        let walls: Vec<String> = header
            .walls
            .iter()
            .map(|h| format!("{} ({})", h.name, control_name(h.control)))
            .collect();
        let _ = writeln!(w, "walls       {}: {}", walls.len(), walls.join(", "));
        match (complete.first(), complete.last()) {
            (Some(first), Some(last)) => {
                let _ = writeln!(
                    w,
                    "increments  {} written, {} .. {}",
                    complete.len(),
                    first,
                    last
                );
            }
            _ => {
                let _ = writeln!(w, "increments  none complete");
            }
        }
        let incomplete = groups.len() - complete.len();
        if incomplete > 0 {
            let _ = writeln!(w, "            {incomplete} incomplete (removed on resume)");
        }
        if let Some(&last) = complete.last() {
            let g = inc.group(&group_name(last))?;
            let _ = writeln!(
                w,
                "\nincrement {} (stage {}, increment {} of the stage)",
                last,
                get_attr::<i64>(&g, "stage")?,
                get_attr::<i64>(&g, "stage_increment")?
            );
            let position = read_vec::<f64>(&g, "walls/position", Some(header.walls.len()))?;
            let applied = read_vec::<f64>(&g, "walls/stress", Some(header.walls.len()))?;
            let measured = read_vec::<f64>(&g, "walls/measured_stress", Some(header.walls.len()))?;
            let _ = writeln!(
                w,
                "  {:<12} {:>14} {:>16} {:>16}",
                "wall", "position [m]", "applied [Pa]", "measured [Pa]"
            );
            for (k, h) in header.walls.iter().enumerate() {
                let _ = writeln!(
                    w,
                    "  {:<12} {:>14.6e} {:>16.6e} {:>16.6e}",
                    h.name, position[k], applied[k], measured[k]
                );
            }
            let sigma = read_rows::<f64, 2>(&g, "macro_stress", Some(2))?;
            let _ = writeln!(
                w,
                "  macro stress [Pa]  xx {:.6e}  yy {:.6e}  xy {:.6e}  yx {:.6e}",
                sigma[0][0], sigma[1][1], sigma[0][1], sigma[1][0]
            );
            let _ = writeln!(
                w,
                "  volume [m^3]       {:.6e}",
                get_attr::<f64>(&g, "volume")?
            );
            let _ = writeln!(
                w,
                "  contacts           {} grain-grain, {} grain-wall, {:.4} per grain",
                get_attr::<i64>(&g, "grain_contacts")?,
                get_attr::<i64>(&g, "wall_contacts")?,
                get_attr::<f64>(&g, "contacts_per_grain")?
            );
            let _ = writeln!(
                w,
                "  bonds              {} intact, {} broken",
                get_attr::<i64>(&g, "bonds")?,
                dataset(&g, "broken_bonds")?
                    .shape()
                    .first()
                    .copied()
                    .unwrap_or(0)
            );
            let state = read_group_state(&g, &header)?;
            if !state.breakouts.is_empty() {
                let _ = writeln!(
                    w,
                    "  breakouts          {}: {}",
                    state.breakouts.len(),
                    breakouts_line(&state)
                );
            }
            let _ = writeln!(
                w,
                "  solver             residual {:.3e}, {} Newton iterations, {} topology passes, {} cuts",
                get_attr::<f64>(&g, "residual")?,
                get_attr::<i64>(&g, "newton_iterations")?,
                get_attr::<i64>(&g, "topology_passes")?,
                get_attr::<i64>(&g, "cuts")?
            );
        }
        if let Some(mut stats) = read_summary_group(&file)? {
            let timers = timers_mut(&mut stats.timers);
            let total: f64 = timers.iter().map(|(_, v)| **v).sum();
            let _ = writeln!(w, "\ntime [s]    {total:.3} in all");
            for (name, v) in timers {
                let _ = writeln!(w, "  {name:<24} {:>10.3}", *v);
            }
            let _ = writeln!(w, "counters");
            for (name, v) in counters_mut(&mut stats.counters) {
                let _ = writeln!(w, "  {name:<24} {:>10}", *v);
            }
        }
        Ok(out)
    };
    text().map_err(read_error(path))
}

/// Each breakout of `state` as `increment 12 (17 grains, 9 bonds broken; outer 4.5000e7
/// Pa)`, joined by commas.
fn breakouts_line(state: &State) -> String {
    let plural =
        |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
    (state.breakouts.iter())
        .map(|b| {
            let loads: Vec<String> = (b.carried(&state.membranes, &state.walls).iter())
                .map(|(name, v)| format!("{name} {v:.4e} Pa"))
                .collect();
            let loads = match loads.is_empty() {
                true => String::new(),
                false => format!("; {}", loads.join(", ")),
            };
            format!(
                "increment {} ({}, {}{loads}){}",
                b.increment,
                plural(b.grains.len(), "grain", "grains"),
                plural(b.bonds_broken, "bond broken", "bonds broken"),
                if b.debris { " debris" } else { "" },
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}
