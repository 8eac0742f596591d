use grainstat::contact::SlipTangent;
use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::{LinearKind, SolverConfig};
use std::path::Path;

fn main() {
    let which = std::env::args().nth(1).unwrap_or("hertz".into());
    let lu = std::env::args().nth(2).is_some();
    let scene = match which.as_str() {
        "rattle" => samples::hertz_patch(12, 10, 1, 0.6, 0.03, 25),
        "rattle0" => samples::hertz_patch(12, 10, 1, 0.0, 0.03, 25),
        "smooth" => samples::hertz_patch(12, 10, 1, 0.0, 0.0, 0),
        "vac" => samples::hertz_patch(12, 10, 1, 0.6, 0.03, 0),
        _ => samples::hertz_patch(12, 10, 1, 0.6, 0.0, 0),
    };
    let grains = build_grains(&scene.grains, Path::new("."), "probe").unwrap();
    let mut config = SolverConfig::default();
    if lu {
        config.linear = LinearKind::Lu;
        config.slip_tangent = SlipTangent::Consistent;
    }
    config.tolerance = 1e-12;
    config.displacement_tolerance = 1e-12;
    let mut sim = Simulation::new(&scene, grains, config, "probe").unwrap();
    while !sim.is_finished() {
        let r = sim.run_increment().unwrap();
        println!("inc {} it {} passes {} cuts {} res {:.2e} hist {:?} made {} lost {} contacts {} stress {:?} macro {:?}", r.increment, r.newton_iterations, r.topology_passes, r.cuts, r.residual, sim.last_residuals.iter().map(|v| format!("{v:.1e}")).collect::<Vec<_>>(), r.contacts_made, r.contacts_lost, sim.state.contacts.len(), r.measurements.wall_stress, r.measurements.macro_stress);
    }
    println!("{:?}", sim.stats.counters);
}
