//! Writes the grains of `samples::hertz_patch` as `x,y,r` CSV (the exchange format other DEM
//! codes read): `cargo run --example write_sand_patch > examples/data/sand-patch.csv`.

use grainstat::samples;

fn main() {
    let scene = samples::hertz_patch(24, 12, 7, 0.6, 0.02, 0);
    let g = &scene.grains;
    println!("x,y,r");
    for i in 0..g.r.len() {
        println!("{:e},{:e},{:e}", g.x[i], g.y[i], g.r[i]);
    }
}
