//! Where and when a cylinder test's bonds broke: for each written increment of a result file
//! (`grainstat run examples/cylinder-test.toml`), the membrane's pressure, the bonds broken so
//! far, and those within `W` mean grain diameters of the borehole's surface as a share of the
//! bonds there at the start (thesis 4.4: the cylinder has failed when 1% of the bonds near
//! the borehole are broken).
//!
//! ```sh
//! cargo run --release --example cylinder-cracks -- results/cylinder-test.h5 [W = 3]
//! ```

use grainstat::geometry::{GrainSet, Side};
use grainstat::output::{read_increments, read_state};
use std::process::ExitCode;

/// Distance of a contact point between grains `a` and `b` from the centre (the origin).
fn contact_radius(grains: &GrainSet, a: usize, b: usize) -> f64 {
    let (p, q) = (grains.position[a], grains.position[b]);
    let (ra, rb) = (grains.radius[a], grains.radius[b]);
    let t = ra / (ra + rb);
    (p[0] + t * (q[0] - p[0])).hypot(p[1] + t * (q[1] - p[1]))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: cylinder-cracks RESULT.h5 [width in mean diameters, default 3]");
        return ExitCode::from(2);
    };
    let width: f64 = match args.get(2).map(|w| w.parse()) {
        None => 3.0,
        Some(Ok(w)) => w,
        Some(Err(e)) => {
            eprintln!("width: {e}");
            return ExitCode::from(2);
        }
    };
    match report(path, width) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(4)
        }
    }
}

fn report(path: &str, width: f64) -> Result<(), grainstat::Error> {
    let increments = read_increments(path)?;
    let (_, first) = read_state(path, increments[0])?;
    let grains = &first.grains;
    let d = 2.0 * grains.mean_radius();
    // The borehole's surface: the innermost grain edge.
    let a = (0..grains.len())
        .map(|g| grains.position[g][0].hypot(grains.position[g][1]) - grains.radius[g])
        .fold(f64::INFINITY, f64::min);
    let near =
        |grains: &GrainSet, i: usize, j: usize| contact_radius(grains, i, j) <= a + width * d;
    let bonded_near = first
        .contacts
        .contacts
        .iter()
        .filter(|c| c.bonded)
        .filter(|c| matches!(c.pair.a, Side::Grain(i) if near(grains, i, c.pair.b)))
        .count();
    let bonded = first.contacts.contacts.iter().filter(|c| c.bonded).count();
    println!(
        "borehole surface at {:.4e} m; {bonded} bonds, {bonded_near} within {width} mean diameters of it",
        a
    );
    println!("increment  pressure [Pa]  broken  broken near  share near  nearest break [d]");
    for &k in &increments {
        let (_, state) = read_state(path, k)?;
        let broken = &state.contacts.broken_bonds;
        let radii: Vec<f64> = broken
            .iter()
            .filter_map(|b| match b.pair.a {
                Side::Grain(i) => Some(contact_radius(&state.grains, i, b.pair.b)),
                Side::Wall(_) => None,
            })
            .collect();
        let count_near = radii.iter().filter(|&&r| r <= a + width * d).count();
        let nearest = radii.iter().cloned().fold(f64::INFINITY, f64::min);
        let pressure = state.membranes.first().map_or(f64::NAN, |m| m.pressure);
        println!(
            "{k:9}  {pressure:13.4e}  {:6}  {count_near:11}  {:10.4}  {}",
            broken.len(),
            count_near as f64 / bonded_near.max(1) as f64,
            if nearest.is_finite() {
                format!("{:.2}", (nearest - a) / d)
            } else {
                "-".to_string()
            }
        );
    }
    Ok(())
}
