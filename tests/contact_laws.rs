//! One contact between two discs carries the whole wall load: the force must follow the law
//! (Hertz eq. 1, linear eq. 8) with the overlap measured from the converged positions, and
//! equal the wall load `sigma * length * D`.

use grainstat::contact::{hertz_stiffness, mean_radius};
use grainstat::geometry::Side;
use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

/// Run the two-disc scene and check each increment with `law(overlap) -> force`.
fn check_two_discs(law: &str, force_of: impl Fn(f64) -> f64) {
    let scene = samples::two_discs(law, 1e5);
    let grains = build_grains(&scene.grains, Path::new("."), "two").unwrap();
    // The residual is good to the round-off of the positions, some 1e5 times the overlap:
    // about 1e-16 * 1e5 of the force. The linear law's increments end at 0.9e-11 to 1.4e-11
    // of it, and two steps of that round-off are 2.7e-11.
    let config = SolverConfig {
        tolerance: 3e-11,
        ..SolverConfig::default()
    };
    let mut sim = Simulation::new(&scene, grains, config, "two").unwrap();
    while !sim.is_finished() {
        let report = sim.run_increment().unwrap();
        let g = &sim.state.grains;
        let c = sim
            .state
            .contacts
            .contacts
            .iter()
            .find(|c| c.pair.a == Side::Grain(0))
            .expect("the discs touch");
        let d = g.branch(0, 1);
        let overlap = g.radius[0] + g.radius[1] - d[0].hypot(d[1]);
        let law_force = force_of(overlap);
        let f = c.response.normal_force;
        // The overlap is a difference of lengths some 1e5 times larger: recomputed from the
        // positions it is good to about 1e-16 * 1e5.
        assert!(
            (f - law_force).abs() <= 1e-10 * law_force,
            "{law}: F_n {f:e} against the law {law_force:e}"
        );
        let top = &sim.state.walls.walls[1];
        let load = top.stress * 2e-4 * sim.depth;
        assert!(
            (f - load).abs() <= 1e-10 * load,
            "{law}: F_n {f:e} against the wall load {load:e} (residual {:e})",
            report.residual
        );
    }
}

#[test]
fn hertz_force_is_m_n_to_the_three_halves() {
    let m = hertz_stiffness(mean_radius(1e-4, Some(1e-4)), 1e9, 0.16);
    check_two_discs("hertz", |n| m * n.powf(1.5));
}

#[test]
fn linear_force_is_kn_n() {
    check_two_discs("linear", |n| 1e6 * n);
}
