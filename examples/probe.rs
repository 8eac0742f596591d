use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;

fn main() {
    let which = std::env::args().nth(1).unwrap_or("two".into());
    let scene = match which.as_str() {
        "two" => samples::two_discs("hertz", 1e5),
        "twolin" => samples::two_discs("linear", 1e5),
        _ => samples::crystal_biaxial(9, 8, 1e5, 3e5),
    };
    let grains = build_grains(&scene.grains, Path::new("."), "probe").unwrap();
    let mut config = SolverConfig::default();
    config.tolerance = 1e-12;
    config.displacement_tolerance = 1e-12;
    let mut sim = Simulation::new(&scene, grains, config, "probe").unwrap();
    while !sim.is_finished() {
        let r = sim.run_increment().unwrap();
        println!("inc {} it {} passes {} res {:.2e} hist {:?} made {} lost {} stress {:?} macro {:?}", r.increment, r.newton_iterations, r.topology_passes, r.residual, sim.last_residuals.iter().map(|v| format!("{v:.1e}")).collect::<Vec<_>>(), r.contacts_made, r.contacts_lost, r.measurements.wall_stress, r.measurements.macro_stress);
    }
    println!("{:?}", sim.stats);
}
