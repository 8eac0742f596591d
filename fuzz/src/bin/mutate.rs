//! The fuzz target's check on stable Rust, for machines without a nightly toolchain (which
//! libFuzzer needs): seed scenes (every `.toml` under `examples/` and `solvers/`, the scenes
//! of `grainstat::samples`, and one with a grain too far out) mutated at random from a seed,
//! for a given time.
//!
//! ```sh
//! cargo run --release --bin mutate -- 600        # ten minutes, seed 1
//! cargo run --release --bin mutate -- 600 7      # seed 7
//! ```
//!
//! An input that fails the check is written to `artifacts/mutate/` and the run goes on; the
//! summary counts inputs, how many parsed, and the failures.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Values that have broken parsers before: non-finite, signed zero, extremes, wrong types.
#[rustfmt::skip]
const VALUES: &[&str] = &[
    "nan", "-nan", "inf", "-inf", "+inf", "0", "-0.0", "0.0", "1", "-1", "1e308", "1e-308",
    "5e-324", "1.7976931348623157e308", "18446744073709551615", "9223372036854775807",
    "-9223372036854775808", "4294967296", "\"\"", "\"x\"", "[]", "{}", "true", "[1, 2]",
    "{ a = 1 }", "\"infinite\"", "\"glued\"", "\"stress\"", "\"displacement\"", "1e6",
    "\"inside\"", "\"outside\"", "\"hertz\"", "\"linear\"", "\"product\"", "[nan, 0.0]",
    "[0.0, 0.0]", "[1e300, 1e300]",
];

/// Keys and table headers of the scene format, to splice in.
#[rustfmt::skip]
const KEYS: &[&str] = &[
    "name", "law", "normal_stiffness", "shear_modulus", "poisson", "friction", "cohesion",
    "cohesion_horizontal", "regions", "[[regions]]", "inner_radius",
    "bonded", "fixed_rotations", "depth", "cohesion_radius", "file", "x", "y", "r", "crystal",
    "rows", "columns", "radius", "short_first", "sample", "walls", "stress_controlled",
    "stress", "point", "normal", "control", "length", "center", "grains", "increments",
    "displacement", "shear", "every", "region", "aspect", "distribution", "kind",
    "mean_radius", "ratio", "seed", "start_fraction", "solid_fraction", "pressure", "shape",
    "[material]", "[grains]", "[grains.crystal]", "[box]", "[[walls]]", "[[circles]]",
    "[[membranes]]", "[[stages]]", "[output]", "[sample]",
];

fn seeds(root: &Path) -> Vec<String> {
    let mut texts = Vec::new();
    for dir in ["examples", "solvers"] {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        paths.sort();
        for p in paths {
            if p.extension().is_some_and(|e| e == "toml") {
                if let Ok(text) = std::fs::read_to_string(&p) {
                    texts.push(text);
                }
            }
        }
    }
    for scene in [
        grainstat::samples::crystal_biaxial(5, 4, 1e6, 3e6),
        grainstat::samples::two_discs("hertz", 1e5),
    ] {
        texts.push(toml::to_string(&scene).expect("sample scenes serialise"));
    }
    // Grains farther apart than the contact detection's cell grid holds: once a panic.
    let mut far = grainstat::samples::two_discs("linear", 1e5);
    far.grains.x[1] = 1e300;
    texts.push(toml::to_string(&far).expect("sample scenes serialise"));
    texts
}

/// One random change to `text`.
fn mutate(text: &mut Vec<u8>, rng: &mut ChaCha8Rng, pool: &[String]) {
    let len = text.len();
    let at = |rng: &mut ChaCha8Rng| rng.random_range(0..=len);
    match rng.random_range(0..10) {
        // A byte changed, inserted or removed.
        0 if len > 0 => {
            let i = rng.random_range(0..len);
            text[i] = rng.random();
        }
        1 => {
            let i = at(rng);
            let b = *b"=[]{}\",.\n#'-+e0123456789 "
                .get(rng.random_range(0..26))
                .unwrap_or(&b'x');
            text.insert(i, b);
        }
        2 if len > 0 => {
            let i = rng.random_range(0..len);
            let j = (i + rng.random_range(1..16)).min(len);
            text.drain(i..j);
        }
        // A value replaced by one of the troublemakers.
        3 | 4 => {
            let s = String::from_utf8_lossy(text).into_owned();
            let eqs: Vec<usize> = s.match_indices('=').map(|(i, _)| i).collect();
            if let Some(&e) = eqs.get(rng.random_range(0..eqs.len().max(1))) {
                let end = s[e..].find('\n').map_or(s.len(), |k| e + k);
                let v = VALUES[rng.random_range(0..VALUES.len())];
                *text = format!("{} {}{}", &s[..=e], v, &s[end..]).into_bytes();
            }
        }
        // A key or header spliced in.
        5 => {
            let i = at(rng);
            let k = KEYS[rng.random_range(0..KEYS.len())];
            let v = VALUES[rng.random_range(0..VALUES.len())];
            let line = if k.starts_with('[') {
                format!("\n{k}\n")
            } else {
                format!("\n{k} = {v}\n")
            };
            text.splice(i..i, line.into_bytes());
        }
        // A line duplicated or moved.
        6 | 7 => {
            let s = String::from_utf8_lossy(text).into_owned();
            let mut lines: Vec<&str> = s.lines().collect();
            if !lines.is_empty() {
                let i = rng.random_range(0..lines.len());
                let j = rng.random_range(0..lines.len());
                if rng.random() {
                    lines.insert(j, lines[i]);
                } else {
                    let l = lines.remove(i);
                    lines.insert(j.min(lines.len()), l);
                }
            }
            *text = lines.join("\n").into_bytes();
        }
        // Cut short, or a piece of another seed spliced in.
        8 => text.truncate(at(rng)),
        _ => {
            let other = pool[rng.random_range(0..pool.len())].as_bytes();
            let a = rng.random_range(0..=other.len());
            let b = (a + rng.random_range(0..200)).min(other.len());
            let i = at(rng);
            text.splice(i..i, other[a..b].iter().copied());
        }
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let seconds: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(60);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let pool = seeds(&root);
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("artifacts/mutate");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Failures are counted and saved, not printed a thousand times.
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let (mut inputs, mut parsed, mut failures) = (0u64, 0u64, 0u64);
    let mut messages = std::collections::BTreeMap::<String, u64>::new();
    while start.elapsed() < Duration::from_secs(seconds) {
        let mut text = pool[rng.random_range(0..pool.len())].as_bytes().to_vec();
        for _ in 0..rng.random_range(1..8) {
            mutate(&mut text, &mut rng, &pool);
        }
        inputs += 1;
        let ok = std::str::from_utf8(&text)
            .ok()
            .is_some_and(|t| grainstat::scene::parse_scene(t, "fuzz.toml").is_ok());
        parsed += u64::from(ok);
        let result = std::panic::catch_unwind(|| grainstat_fuzz::check_scene(&text));
        if let Err(panic) = result {
            failures += 1;
            let message = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            let first = message.lines().next().unwrap_or("").to_string();
            let seen = messages.entry(first).or_default();
            *seen += 1;
            if *seen == 1 {
                let _ = std::fs::create_dir_all(&out);
                let _ = std::fs::write(out.join(format!("crash-{inputs}.toml")), &text);
                eprintln!("input {inputs}: {message}");
            }
        }
    }
    println!(
        "{inputs} inputs in {:.0} s (seed {seed}), {parsed} parsed as scenes, {failures} failed \
         the check",
        start.elapsed().as_secs_f64()
    );
    for (m, n) in messages {
        println!("  {n} x {m}");
    }
    if failures > 0 {
        std::process::exit(1);
    }
}
