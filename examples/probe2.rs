use grainstat::contact::kappa;
use grainstat::geometry::Side;
use grainstat::samples;
use grainstat::scene::build_grains;
use grainstat::simulation::Simulation;
use grainstat::solver::SolverConfig;
use std::path::Path;
fn main() {
    for (rows, cols) in [(21, 30), (41, 30), (41, 60), (81, 60), (81, 120)] {
        let scene = samples::crystal_biaxial(rows, cols, 1e6, 3e6);
        let grains = build_grains(&scene.grains, Path::new("."), "c").unwrap();
        let mut sim = Simulation::new(&scene, grains, SolverConfig::default(), "c").unwrap();
        let t = std::time::Instant::now();
        while sim.state.stage == 0 { sim.run_increment().unwrap(); }
        let r = 1e-4; let c = 1.0 / (4.0 * 3f64.sqrt() * r * r);
        let f0 = 1e6 / (3.0 * c);
        // interior: centre band, 1/4..3/4 in x and y
        let g = &sim.state.grains;
        let (w, h) = (2.0 * r * cols as f64, 3f64.sqrt() * r * rows as f64);
        let (mut st, mut nt, mut sn, mut nn, mut ss) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for ct in &sim.state.contacts.contacts {
            let Side::Grain(a) = ct.pair.a else { continue };
            let (pa, pb) = (g.position[a], g.position[ct.pair.b]);
            let (x, y) = (0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]));
            if x < 0.25 * w || x > 0.75 * w || y < 0.25 * h || y > 0.75 * h { continue; }
            if (pb[1] - pa[1]).abs() < 0.5 * r { st += ct.response.normal_force; nt += 1.0 } else { sn += ct.response.normal_force; ss += ct.response.shear_force.abs(); nn += 1.0 }
        }
        println!("{rows}x{cols} ({} grains) {:.2}s: F't/A123 {:.4} F'n/A123 {:.4} |F's|/F'n {:.2e}  k={}", g.len(), t.elapsed().as_secs_f64(), st / nt / f0, sn / nn / f0, ss / sn, kappa(0.16));
    }
}
