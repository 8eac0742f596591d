//! Range checks on a parsed scene. Serde has already checked keys and types; this catches
//! values the types allow but the physics does not (a negative radius, a NaN, a stage that
//! loads a wall that does not exist), so a run never starts from a scene it cannot finish.
//!
//! Each problem is a (key path, message) pair; the loader turns the path into a line.

use super::load::child_key;
use super::{CircleSide, Friction, GrainSource, LawKind, Material, Scene, WallControl, BOX_SIDES};
use crate::contact::ContactSet;
use crate::geometry::{gap_between, GrainSet, Side, WallSet};
use std::collections::BTreeMap;

/// The most grains a scene may ask for: far beyond what fits in memory (10^6 grains take a few
/// GB), so a mistyped count is an error rather than an allocation that never ends.
const MAX_GRAINS: usize = 100_000_000;

/// The most increments a load program may have: the counters add them up, and a run of more
/// would not end in any case.
const MAX_INCREMENTS: usize = 1_000_000_000;

/// Every problem in `scene`, as (key path, message) pairs in file order; empty if it is fine.
pub(crate) fn validate(scene: &Scene) -> Vec<(String, String)> {
    let mut p = Problems::default();
    material(&scene.material, &mut p);
    match &scene.sample {
        // A scene that prepares a sample has no grains yet.
        Some(spec) => {
            sample(spec, &mut p);
            if p.0.is_empty() {
                crushing_stress(spec, &scene.material, &mut p);
            }
            if grain_problems(&scene.grains).is_empty() {
                p.push(
                    "grains",
                    "a scene with a `[sample]` section prepares its grains: leave `[grains]` out",
                );
            }
        }
        None => p.0.extend(grain_problems(&scene.grains)),
    }
    let walls = walls(scene, &mut p);
    stages(scene, &walls, &mut p);
    regions(&scene.regions, &mut p);
    if scene.output.every == 0 {
        p.push(
            "output.every",
            "must be at least 1 (the state is written every `every`-th increment)",
        );
    }
    if scene
        .output
        .file
        .as_deref()
        .is_some_and(|f| f.trim().is_empty())
    {
        p.push("output.file", "must name a file (or leave `file` out)");
    }
    p.0
}

/// The problems of a sample section.
fn sample(s: &crate::scene::SampleSpec, p: &mut Problems) {
    use crate::sample::prepare::RegionShape;
    if s.grains == 0 || s.grains > MAX_GRAINS {
        p.push(
            "sample.grains",
            format!("must be at least 1 and at most {MAX_GRAINS:.0e}"),
        );
    }
    if p.finite("sample.stress", s.stress) && s.stress <= 0.0 {
        p.push("sample.stress", "must be > 0 (Pa)");
    }
    if p.finite("sample.friction", s.friction) && s.friction < 0.0 {
        p.push("sample.friction", "must be >= 0");
    }
    if p.finite("sample.start_fraction", s.start_fraction)
        && !(s.start_fraction > 0.0 && s.start_fraction <= 1.0)
    {
        p.push("sample.start_fraction", "must be in (0, 1]");
    }
    if p.finite("sample.solid_fraction", s.solid_fraction)
        && !(s.solid_fraction > 0.0 && s.solid_fraction <= 0.9)
    {
        p.push(
            "sample.solid_fraction",
            "must be in (0, 0.9]: discs cannot fill more than about 0.9 of a plane",
        );
    }
    if let Some(a) = s.aspect {
        let least = if s.region == RegionShape::Annulus {
            1.0
        } else {
            0.0
        };
        if p.finite("sample.aspect", a) && a <= least {
            p.push("sample.aspect", format!("must be > {least}"));
        }
    }
    if let Err(e) = s.distribution.check() {
        p.push("sample.distribution", e.to_string());
    }
}

/// The deepest overlap a sample's target stress may press grains into, as a fraction of the
/// mean radius.
const MAX_SAMPLE_OVERLAP: f64 = 0.25;

/// A sample's target stress must leave the grains' overlaps small, as the contact laws
/// assume: a contact carrying the stress on a grain's section, `F = sigma 2 rbar D`, must
/// overlap by at most [`MAX_SAMPLE_OVERLAP`] of the mean radius (`F / k_n`, or Hertz with
/// `E* = G / (1 - nu)` and `R* = rbar / 2`). Far beyond that, growth runs away and ends in
/// NaN.
fn crushing_stress(s: &crate::scene::SampleSpec, m: &Material, p: &mut Problems) {
    let r = s.distribution.mean_radius;
    let force = s.stress * 2.0 * r * m.depth.unwrap_or(2.0 * r);
    let overlap = match (m.law, m.normal_stiffness, m.shear_modulus) {
        (LawKind::Linear, Some(k), _) => force / k,
        (LawKind::Hertz, _, Some(g)) => {
            let e = g / (1.0 - m.poisson);
            (3.0 * force / (4.0 * e * (r / 2.0).sqrt())).powf(2.0 / 3.0)
        }
        _ => return,
    };
    if overlap > MAX_SAMPLE_OVERLAP * r {
        p.push(
            "sample.stress",
            format!(
                "would press the grains {:.2e} of their mean radius into one another (a \
                 contact carrying the stress on a grain's section); the contact laws hold for \
                 overlaps up to {MAX_SAMPLE_OVERLAP}: lower the stress or stiffen the material",
                overlap / r
            ),
        );
    }
}

/// The problems of a grain source alone; also used when grains are built outside a scene.
pub(crate) fn grain_problems(g: &GrainSource) -> Vec<(String, String)> {
    let mut p = Problems::default();
    let inline = !(g.x.is_empty() && g.y.is_empty() && g.r.is_empty());
    let mut found = Vec::new();
    if g.file.is_some() {
        found.push("`file`");
    }
    if inline {
        found.push("inline `x`/`y`/`r`");
    }
    if g.crystal.is_some() {
        found.push("`crystal`");
    }
    if g.sample.is_some() {
        found.push("`sample`");
    }
    const SOURCES: &str = "`file = \"grains.csv\"`, inline `x`, `y`, `r` lists, a \
                           `[grains.crystal]` table, or `sample = \"sample.h5\"`";
    match found.len() {
        0 => p.push("grains", format!("no grains: give one of {SOURCES}")),
        1 => {}
        _ => p.push(
            "grains",
            format!(
                "give exactly one grain source ({SOURCES}), not {}",
                found.join(" and ")
            ),
        ),
    }
    if let Some(file) = &g.file {
        if file.trim().is_empty() {
            p.push("grains.file", "must name a CSV file of `x, y, r` lines");
        }
    }
    if g.walls.is_some() && g.sample.is_none() {
        p.push(
            "grains.walls",
            "keeps walls of a prepared sample: give `sample = \"sample.h5\"` too",
        );
    }
    if let Some(sample) = &g.sample {
        if sample.trim().is_empty() {
            p.push(
                "grains.sample",
                "must name a sample file (HDF5, written by `sample::write_sample`)",
            );
        }
    }
    if inline {
        let n = g.x.len();
        if n == 0 {
            p.push(
                "grains.x",
                "is empty: `x`, `y` and `r` need one entry per grain",
            );
        }
        for (key, list) in [("y", &g.y), ("r", &g.r)] {
            if list.len() != n {
                p.push(
                    format!("grains.{key}"),
                    format!(
                        "has {} entries but `x` has {n}: `x`, `y` and `r` need one entry per grain",
                        list.len()
                    ),
                );
            }
        }
        for (i, &v) in g.x.iter().enumerate() {
            p.finite(&format!("grains.x[{i}]"), v);
        }
        for (i, &v) in g.y.iter().enumerate() {
            p.finite(&format!("grains.y[{i}]"), v);
        }
        for (i, &v) in g.r.iter().enumerate() {
            p.positive(&format!("grains.r[{i}]"), v);
        }
        let sound = |v: &[f64]| v.len() == n && v.iter().all(|x| x.is_finite());
        if n > 0 && sound(&g.x) && sound(&g.y) && sound(&g.r) {
            if let Some((i, axis, message)) = super::load::span_problem(&g.x, &g.y, &g.r) {
                p.push(format!("grains.{axis}[{i}]"), message);
            }
        }
    }
    if let Some(c) = &g.crystal {
        if c.rows == 0 {
            p.push("grains.crystal.rows", "must be at least 1");
        }
        if c.columns < 2 {
            p.push(
                "grains.crystal.columns",
                format!(
                    "must be at least 2 (short rows have `columns - 1` grains), not {}",
                    c.columns
                ),
            );
        }
        if c.rows.checked_mul(c.columns).is_none_or(|n| n > MAX_GRAINS) {
            p.push(
                "grains.crystal",
                format!("`rows * columns` must be at most {MAX_GRAINS:.0e} grains"),
            );
        }
        p.positive("grains.crystal.radius", c.radius);
    }
    p.0
}

fn material(m: &Material, p: &mut Problems) {
    let (needed, needed_what, other) = match m.law {
        LawKind::Linear => (
            ("normal_stiffness", m.normal_stiffness),
            "the linear law needs `normal_stiffness` > 0 [N/m]",
            ("shear_modulus", m.shear_modulus),
        ),
        LawKind::Hertz => (
            ("shear_modulus", m.shear_modulus),
            "the Hertz law needs `shear_modulus` > 0 [Pa]",
            ("normal_stiffness", m.normal_stiffness),
        ),
    };
    let key = format!("material.{}", needed.0);
    match needed.1 {
        Some(v) => p.positive(&key, v),
        None => p.push(key, needed_what),
    }
    if let Some(v) = other.1 {
        p.finite(&format!("material.{}", other.0), v);
    }
    if !(m.poisson.is_finite() && (0.0..0.5).contains(&m.poisson)) {
        p.push(
            "material.poisson",
            format!("must be in [0, 0.5), not {}", m.poisson),
        );
    }
    p.friction("material.friction", m.friction);
    p.non_negative("material.cohesion", m.cohesion);
    let f = m.cohesion_horizontal;
    if !(f.is_finite() && (0.0..=1.0).contains(&f)) {
        p.push(
            "material.cohesion_horizontal",
            format!(
                "must be in [0, 1] (a horizontal bond's strength over a vertical one's), not {f}"
            ),
        );
    } else if f != 1.0 && m.law == LawKind::Hertz {
        p.push(
            "material.cohesion_horizontal",
            "anisotropic cohesion needs the linear law (`law = \"linear\"`); Hertz contacts have no bonds",
        );
    }
    if m.law == LawKind::Hertz {
        if m.cohesion > 0.0 {
            p.push(
                "material.cohesion",
                "cohesion needs the linear law (`law = \"linear\"`); Hertz contacts have no bonds",
            );
        }
        if m.bonded {
            p.push(
                "material.bonded",
                "bonds need the linear law (`law = \"linear\"`); Hertz contacts have no bonds",
            );
        }
    }
    if let Some(d) = m.depth {
        p.positive("material.depth", d);
    }
}

/// Checks `box` and `[[walls]]`; returns every wall name with its control.
fn walls(scene: &Scene, p: &mut Problems) -> BTreeMap<String, WallControl> {
    // The walls kept from a sample (checked against the sample when it is read).
    let mut known = scene.grains.walls.clone().unwrap_or_default();
    if let Some(b) = &scene.wall_box {
        p.friction("box.friction", b.friction);
        p.finite("box.stress", b.stress);
        for (i, side) in b.stress_controlled.iter().enumerate() {
            let key = format!("box.stress_controlled[{i}]");
            if !BOX_SIDES.contains(&side.as_str()) {
                p.push(
                    key,
                    format!(
                        "`{side}` is not a side of the box: use `bottom`, `right`, `top` or `left`"
                    ),
                );
            } else if b.stress_controlled[..i].contains(side) {
                p.push(key, format!("`{side}` is listed twice"));
            }
        }
        for side in BOX_SIDES {
            let control = if b.stress_controlled.iter().any(|s| s == side) {
                WallControl::Stress
            } else {
                WallControl::Displacement
            };
            known.insert(side.to_string(), control);
        }
    }
    for (i, w) in scene.walls.iter().enumerate() {
        let at = format!("walls[{i}]");
        if w.name.trim().is_empty() {
            p.push(format!("{at}.name"), "must not be empty");
        } else if known.contains_key(&w.name) {
            let why = if scene.wall_box.is_some() && BOX_SIDES.contains(&w.name.as_str()) {
                format!(
                    "`{}` is already a side of `box`: wall names must be unique",
                    w.name
                )
            } else {
                format!(
                    "another wall is already named `{}`: wall names must be unique",
                    w.name
                )
            };
            p.push(format!("{at}.name"), why);
        } else {
            known.insert(w.name.clone(), w.control);
        }
        for (j, &v) in w.point.iter().enumerate() {
            p.finite(&format!("{at}.point[{j}]"), v);
        }
        let mut normal_ok = true;
        for (j, &v) in w.normal.iter().enumerate() {
            normal_ok &= p.finite(&format!("{at}.normal[{j}]"), v);
        }
        if normal_ok && w.normal[0].hypot(w.normal[1]) == 0.0 {
            p.push(
                format!("{at}.normal"),
                "must not be zero: it is the direction from the wall into the sample",
            );
        }
        p.friction(&format!("{at}.friction"), w.friction);
        p.finite(&format!("{at}.stress"), w.stress);
        if let Some(l) = w.length {
            p.positive(&format!("{at}.length"), l);
        }
    }
    let mut unique = |p: &mut Problems, key: String, name: &str, control: WallControl| {
        if name.trim().is_empty() {
            p.push(key, "must not be empty");
        } else if known.contains_key(name) {
            p.push(
                key,
                format!("a wall or membrane is already named `{name}`: names must be unique"),
            );
        } else {
            known.insert(name.to_string(), control);
        }
    };
    for (i, c) in scene.circles.iter().enumerate() {
        let at = format!("circles[{i}]");
        unique(p, format!("{at}.name"), &c.name, c.control);
        for (j, &v) in c.center.iter().enumerate() {
            p.finite(&format!("{at}.center[{j}]"), v);
        }
        p.positive(&format!("{at}.radius"), c.radius);
        p.friction(&format!("{at}.friction"), c.friction);
        p.finite(&format!("{at}.stress"), c.stress);
        if c.touch && c.moves.is_none() {
            p.push(
                format!("{at}.touch"),
                "needs `moves`: the direction to bring the plug along",
            );
        }
        if let Some(m) = c.moves {
            let ok = p.finite(&format!("{at}.moves[0]"), m[0])
                & p.finite(&format!("{at}.moves[1]"), m[1]);
            if ok && m[0].hypot(m[1]) == 0.0 {
                p.push(
                    format!("{at}.moves"),
                    "must not be zero: it is the direction the centre moves",
                );
            }
            if c.grains == CircleSide::Inside {
                p.push(
                    format!("{at}.moves"),
                    "only a plug (grains = \"outside\") can move; a ring grows or shrinks",
                );
            }
        }
    }
    // A membrane is loaded like a stress-controlled wall: by `stress` in the stages.
    for (i, m) in scene.membranes.iter().enumerate() {
        let at = format!("membranes[{i}]");
        unique(p, format!("{at}.name"), &m.name, WallControl::Stress);
        match (m.side, m.ring) {
            (Some(v), None) => {
                let ok = p.finite(&format!("{at}.side[0]"), v[0]) & p.finite(&format!("{at}.side[1]"), v[1]);
                if ok && v[0].hypot(v[1]) == 0.0 {
                    p.push(format!("{at}.side"), "must not be zero: it points out of the sample");
                }
            }
            (None, Some(c)) => {
                p.finite(&format!("{at}.ring[0]"), c[0]);
                p.finite(&format!("{at}.ring[1]"), c[1]);
            }
            _ => p.push(
                at.clone(),
                "give exactly one of `side = [x, y]` (out of the sample) or `ring = [x, y]` (centre)",
            ),
        }
        if p.finite(&format!("{at}.pressure"), m.pressure) && m.pressure < 0.0 {
            p.push(
                format!("{at}.pressure"),
                "must be >= 0 (Pa): a membrane only pushes",
            );
        }
    }
    known
}

fn stages(scene: &Scene, walls: &BTreeMap<String, WallControl>, p: &mut Problems) {
    // The controls as the stages change them.
    let mut walls = walls.clone();
    let mut total = 0usize;
    for (i, s) in scene.stages.iter().enumerate() {
        let at = format!("stages[{i}]");
        total = total.saturating_add(s.increments);
        if s.increments == 0 {
            p.push(format!("{at}.increments"), "must be at least 1");
        } else if total > MAX_INCREMENTS {
            p.push(
                format!("{at}.increments"),
                format!("brings the load program to more than {MAX_INCREMENTS:.0e} increments"),
            );
        }
        if let Some(drop) = s.failure_drop {
            let key = format!("{at}.failure_drop");
            if !(drop > 0.0 && drop < 1.0) {
                p.push(key, "must be between 0 and 1: a fraction of the peak force");
            } else if !s.until_failure {
                p.push(
                    key,
                    "needs `until_failure = true`: the drop ends a test loaded to failure",
                );
            }
        }
        if s.until_breakout && !s.breakouts {
            p.push(
                format!("{at}.until_breakout"),
                "needs `breakouts = true`: the test ends at the first cluster taken out",
            );
        }
        if s.breakouts && !s.until_failure {
            p.push(
                format!("{at}.breakouts"),
                "needs `until_failure = true`: loading goes on after a breakout until the sample fails",
            );
        }
        for (name, &control) in &s.control {
            let key = child_key(&format!("{at}.control"), name);
            if scene.membranes.iter().any(|m| &m.name == name) {
                p.push(
                    key,
                    format!("`{name}` is a membrane: it is always loaded by its pressure"),
                );
                continue;
            }
            match walls.get_mut(name) {
                Some(c) => *c = control,
                None => p.push(key, no_wall(name, &walls)),
            }
        }
        let walls = &walls;
        for (name, &v) in &s.stress {
            let key = child_key(&format!("{at}.stress"), name);
            match walls.get(name) {
                None => p.push(key, no_wall(name, walls)),
                Some(WallControl::Displacement) => p.push(
                    key,
                    format!(
                        "wall `{name}` is displacement-controlled: move it under `displacement`, \
                         or make it stress-controlled (`box.stress_controlled` for a box side, \
                         `control = \"stress\"` for a `[[walls]]` wall)"
                    ),
                ),
                Some(WallControl::Stress) => {
                    p.finite(&key, v);
                }
            }
        }
        for (name, &v) in &s.displacement {
            let key = child_key(&format!("{at}.displacement"), name);
            match walls.get(name) {
                None => p.push(key, no_wall(name, walls)),
                Some(WallControl::Stress) => p.push(
                    key,
                    format!(
                        "wall `{name}` is stress-controlled: load it under `stress`, or make it \
                         displacement-controlled"
                    ),
                ),
                Some(WallControl::Displacement) => {
                    p.finite(&key, v);
                }
            }
        }
        for (name, &v) in &s.shear {
            let key = child_key(&format!("{at}.shear"), name);
            if walls.contains_key(name) {
                p.finite(&key, v);
            } else {
                p.push(key, no_wall(name, walls));
            }
        }
        let curved = |name: &str| {
            scene.circles.iter().any(|c| c.name == name)
                || scene.membranes.iter().any(|m| m.name == name)
        };
        for (name, &v) in &s.shear_strain {
            let key = child_key(&format!("{at}.shear_strain"), name);
            if !walls.contains_key(name) {
                p.push(key, no_wall(name, walls));
            } else if curved(name) {
                p.push(
                    key,
                    format!("`{name}` is not a straight wall: only a straight wall shears a box"),
                );
            } else if p.finite(&key, v) && v.abs() >= 0.5 {
                p.push(
                    key,
                    format!("must be below 0.5 in size (rad): the side walls turn by it, not {v}"),
                );
            }
        }
        for (k, name) in s.glue.iter().enumerate() {
            let key = format!("{at}.glue[{k}]");
            if !walls.contains_key(name) {
                p.push(key, no_wall(name, walls));
            } else if curved(name) {
                p.push(
                    key,
                    format!("`{name}` is not a straight wall: grains are glued to straight walls"),
                );
            }
        }
    }
    if scene.stages.is_empty() && scene.sample.is_none() {
        p.push(
            "stages",
            "the scene has no load stages, so there is nothing to do: add at least one \
             `[[stages]]` table with `increments` and the stresses or displacements to apply",
        );
    }
}

fn no_wall(name: &str, walls: &BTreeMap<String, WallControl>) -> String {
    if walls.is_empty() {
        format!(
            "there is no wall named `{name}`: the scene has no walls (add `[box]` or `[[walls]]`)"
        )
    } else {
        let names: Vec<String> = walls.keys().map(|n| format!("`{n}`")).collect();
        format!(
            "there is no wall named `{name}`; the walls are {}",
            names.join(", ")
        )
    }
}

/// Each region: a name of its own, and either a rectangle (`min` below `max`) or a circle
/// or ring (`center`, `radius`, `inner_radius` below it), finite.
fn regions(regions: &[super::RegionSpec], p: &mut Problems) {
    for (k, r) in regions.iter().enumerate() {
        let key = |name: &str| format!("regions[{k}].{name}");
        if r.name.trim().is_empty() {
            p.push(key("name"), "must name the region");
        } else if regions[..k].iter().any(|o| o.name == r.name) {
            p.push(key("name"), format!("`{}` names two regions", r.name));
        }
        let rectangle = r.min.is_some() || r.max.is_some();
        let ring = r.center.is_some() || r.radius.is_some() || r.inner_radius.is_some();
        match (rectangle, ring) {
            (true, true) => p.push(
                key(if r.center.is_some() {
                    "center"
                } else {
                    "radius"
                }),
                "a region is a rectangle (`min`, `max`) or a circle (`center`, `radius`, \
                 perhaps `inner_radius`), not both",
            ),
            (false, false) => p.push(
                key("name"),
                "give a rectangle (`min`, `max`) or a circle (`center`, `radius`, perhaps \
                 `inner_radius` for a ring)",
            ),
            (true, false) => rectangle_region(r, &key, p),
            (false, true) => ring_region(r, &key, p),
        }
    }
}

fn rectangle_region(r: &super::RegionSpec, key: &dyn Fn(&str) -> String, p: &mut Problems) {
    let (Some(min), Some(max)) = (r.min, r.max) else {
        let missing = if r.min.is_none() { "min" } else { "max" };
        p.push(
            key(missing),
            "a rectangle needs both `min` and `max` corners",
        );
        return;
    };
    let finite = |c: [f64; 2]| c[0].is_finite() && c[1].is_finite();
    if !finite(min) {
        p.push(key("min"), "must be finite");
    } else if !finite(max) {
        p.push(key("max"), "must be finite");
    } else if !(max[0] > min[0] && max[1] > min[1]) {
        p.push(key("max"), "must lie above and to the right of `min`");
    }
}

fn ring_region(r: &super::RegionSpec, key: &dyn Fn(&str) -> String, p: &mut Problems) {
    let (Some(center), Some(radius)) = (r.center, r.radius) else {
        let missing = if r.center.is_none() {
            "center"
        } else {
            "radius"
        };
        p.push(key(missing), "a circle or ring needs `center` and `radius`");
        return;
    };
    if !(center[0].is_finite() && center[1].is_finite()) {
        p.push(key("center"), "must be finite");
    }
    p.positive(&key("radius"), radius);
    if let Some(inner) = r.inner_radius {
        if !(inner.is_finite() && inner >= 0.0 && inner < radius) {
            p.push(
                key("inner_radius"),
                format!("must be >= 0 and below `radius` ({radius}), not {inner}"),
            );
        }
    }
}

/// Problems found so far, with the common checks.
#[derive(Default)]
struct Problems(Vec<(String, String)>);

impl Problems {
    fn push(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.0.push((key.into(), message.into()));
    }

    /// NaN and infinity are valid TOML (`nan`, `inf`) but never a valid input here.
    fn finite(&mut self, key: &str, v: f64) -> bool {
        if !v.is_finite() {
            self.push(key, format!("must be a finite number, not {v}"));
        }
        v.is_finite()
    }

    fn positive(&mut self, key: &str, v: f64) {
        if !(v.is_finite() && v > 0.0) {
            self.push(key, format!("must be a finite number > 0, not {v}"));
        }
    }

    fn non_negative(&mut self, key: &str, v: f64) {
        if !(v.is_finite() && v >= 0.0) {
            self.push(key, format!("must be a finite number >= 0, not {v}"));
        }
    }

    fn friction(&mut self, key: &str, f: Friction) {
        if let Friction::Coefficient(v) = f {
            if !(v.is_finite() && v >= 0.0) {
                self.push(
                    key,
                    format!(
                        "must be a finite coefficient >= 0 (or \"infinite\" for no slip), not {v}"
                    ),
                );
            }
        }
    }
}

/// The deepest overlap a contact may have where a fresh run starts, as a fraction of the
/// smaller radius. Prepared samples overlap by 1e-4 to 1e-3 of a radius; deeper means grains
/// in one another or a wall placed across them, which no contact law is meant for.
const MAX_START_OVERLAP: f64 = 0.1;

/// The first contact of a fresh start that overlaps too deeply, as (key path, message): the
/// grains of `scene`, its walls as built, and the contacts found between them.
pub(crate) fn start_overlap(
    scene: &Scene,
    grains: &GrainSet,
    walls: &WallSet,
    contacts: &ContactSet,
) -> Option<(String, String)> {
    contacts.contacts.iter().find_map(|c| {
        let b = c.pair.b;
        match c.pair.a {
            Side::Grain(a) => {
                let smaller = grains.radius[a].min(grains.radius[b]);
                let overlap = -gap_between(grains, a, b) / smaller;
                (overlap > MAX_START_OVERLAP).then(|| {
                    (
                        "grains".to_string(),
                        format!(
                            "grains {a} and {b} (0-based) overlap by {:.3} of the smaller radius \
                             at the start, more than {MAX_START_OVERLAP}: two grains in one place?",
                            overlap
                        ),
                    )
                })
            }
            Side::Wall(w) => {
                let wall = &walls.walls[w];
                let overlap =
                    (grains.radius[b] - wall.distance(grains.position[b])) / grains.radius[b];
                (overlap > MAX_START_OVERLAP).then(|| {
                    let key = match (
                        scene.walls.iter().position(|s| s.name == wall.name),
                        scene.circles.iter().position(|s| s.name == wall.name),
                    ) {
                        (Some(k), _) => format!("walls[{k}]"),
                        (None, Some(k)) => format!("circles[{k}]"),
                        (None, None) => "box".to_string(),
                    };
                    (
                        key,
                        format!(
                            "wall `{}` cuts {:.3} of grain {b}'s radius (0-based) at the start, \
                             more than {MAX_START_OVERLAP}: the grains must start on the wall's \
                             sample side (its normal points into the sample)",
                            wall.name, overlap
                        ),
                    )
                })
            }
        }
    })
}
