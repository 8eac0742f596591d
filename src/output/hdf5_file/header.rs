//! The run's header: scene name, law, walls, regions and membranes, written once.

use super::*;

pub(super) fn write_header(file: &File, h: &RunHeader) -> R<()> {
    set_str_attr(file, "format", FORMAT)?;
    set_attr(file, "format_version", &FORMAT_VERSION)?;
    set_str_attr(file, "grainstat_version", &h.version)?;
    set_str_attr(file, "scene_name", &h.scene_name)?;
    set_str_attr(file, "law", &h.law)?;
    set_attr(file, "depth", &h.depth)?;
    set_attr(file, "fixed_rotations", &u8::from(h.fixed_rotations))?;
    set_attr(file, "grains", &(h.radius.len() as i64))?;
    set_attr(file, "walls", &(h.walls.len() as i64))?;

    let run = file.create_group("run")?;
    put_text(&run, "scene", &h.scene_text)?;
    put_text(&run, "solver", &h.solver_text)?;

    let grains = file.create_group("grains")?;
    put(&grains, "radius", ArrayView1::from(&h.radius[..]))?;
    // Point numbers for XDMF, whose point cells need a connectivity array.
    let index: Array1<i64> = (0..h.radius.len() as i64).collect();
    put(&grains, "index", index.view())?;

    write_walls(&file.create_group("walls")?, &h.walls)?;
    write_membranes(file, &h.membranes)?;
    write_regions(file, &h.regions)
}

/// The static part of walls, one row per wall, into `group` (`/walls` of a result file).
pub(crate) fn write_walls(group: &Group, walls: &[WallHeader]) -> R<()> {
    let names: Vec<String> = walls.iter().map(|w| w.name.clone()).collect();
    put_strings(group, "name", &names)?;
    let normal: Vec<[f64; 2]> = walls.iter().map(|w| w.normal).collect();
    put(group, "normal", ArrayView2::from(&normal[..]))?;
    let offset: Vec<f64> = walls.iter().map(|w| w.offset).collect();
    put(group, "offset", ArrayView1::from(&offset[..]))?;
    let pivot: Vec<[f64; 2]> = walls.iter().map(|w| w.pivot).collect();
    put(group, "pivot", ArrayView2::from(&pivot[..]))?;
    let control: Vec<String> = walls
        .iter()
        .map(|w| control_name(w.control).to_owned())
        .collect();
    put_strings(group, "control", &control)?;
    let friction: Vec<f64> = walls.iter().map(|w| w.friction).collect();
    put(group, "friction", ArrayView1::from(&friction[..]))?;
    let length: Vec<f64> = walls.iter().map(|w| w.length.unwrap_or(f64::NAN)).collect();
    put(group, "length", ArrayView1::from(&length[..]))?;
    // Circles as centre x, centre y, radius, grains inside (1) or outside (0); NaN for lines.
    let circle: Vec<[f64; 4]> = walls
        .iter()
        .map(|w| match w.circle {
            Some(c) => [
                c.center[0],
                c.center[1],
                c.radius,
                c.grains_inside as u8 as f64,
            ],
            None => [f64::NAN; 4],
        })
        .collect();
    put(group, "circle", ArrayView2::from(&circle[..]))?;
    // The direction a moving plug's centre goes; NaN for lines and circles that grow.
    let moves: Vec<[f64; 2]> = walls
        .iter()
        .map(|w| w.circle.and_then(|c| c.moves).unwrap_or([f64::NAN; 2]))
        .collect();
    put(group, "circle_moves", ArrayView2::from(&moves[..]))?;
    Ok(())
}

/// The static part of `w` walls from `group`, as [`write_walls`] wrote them.
pub(crate) fn read_walls(group: &Group, w: usize) -> R<Vec<WallHeader>> {
    let names = read_vec::<VarLenUnicode>(group, "name", Some(w))?;
    let normal = read_rows::<f64, 2>(group, "normal", Some(w))?;
    let offset = read_vec::<f64>(group, "offset", Some(w))?;
    // Files written before walls turned: each wall's foot from the origin, on its line.
    let pivot = match group.link_exists("pivot") {
        true => read_rows::<f64, 2>(group, "pivot", Some(w))?,
        false => (0..w).map(|k| normal[k].map(|v| v * offset[k])).collect(),
    };
    let control = read_vec::<VarLenUnicode>(group, "control", Some(w))?;
    let friction = read_vec::<f64>(group, "friction", Some(w))?;
    let length = read_vec::<f64>(group, "length", Some(w))?;
    let circle = read_rows::<f64, 4>(group, "circle", Some(w))?;
    let moves = match group.link_exists("circle_moves") {
        true => read_rows::<f64, 2>(group, "circle_moves", Some(w))?,
        false => vec![[f64::NAN; 2]; w],
    };
    (0..w)
        .map(|k| {
            let control = match control[k].as_str() {
                "displacement" => WallControl::Displacement,
                "stress" => WallControl::Stress,
                other => return Err(Fail(format!("wall {k} has control `{other}`"))),
            };
            Ok(WallHeader {
                name: names[k].as_str().to_owned(),
                normal: normal[k],
                offset: offset[k],
                pivot: pivot[k],
                control,
                friction: friction[k],
                length: (!length[k].is_nan()).then_some(length[k]),
                circle: (!circle[k][2].is_nan()).then_some(Circle {
                    center: [circle[k][0], circle[k][1]],
                    radius: circle[k][2],
                    grains_inside: circle[k][3] != 0.0,
                    moves: (!moves[k][0].is_nan()).then_some(moves[k]),
                }),
            })
        })
        .collect()
}

pub(super) fn read_header(file: &File) -> R<RunHeader> {
    let version = get_attr::<i64>(file, "format_version")?;
    if version != FORMAT_VERSION {
        return Err(Fail(format!(
            "layout version {version}; this grainstat reads version {FORMAT_VERSION}"
        )));
    }
    let text = |name: &str| -> R<String> {
        let run = file.group("run")?;
        let v = dataset(&run, name)?
            .read_scalar::<VarLenUnicode>()
            .map_err(|e| Fail(format!("dataset `/run/{name}`: {e}")))?;
        Ok(v.as_str().to_owned())
    };
    let grains = file.group("grains")?;
    let n = get_count(file, "grains")?;
    let radius = read_vec::<f64>(&grains, "radius", Some(n))?;

    let walls = read_walls(&file.group("walls")?, get_count(file, "walls")?)?;

    Ok(RunHeader {
        scene_name: get_str_attr(file, "scene_name")?,
        scene_text: text("scene")?,
        solver_text: text("solver")?,
        version: get_str_attr(file, "grainstat_version")?,
        depth: get_attr::<f64>(file, "depth")?,
        radius,
        walls,
        fixed_rotations: get_attr::<u8>(file, "fixed_rotations")? != 0,
        law: get_str_attr(file, "law")?,
        membranes: read_membranes(file)?,
        regions: read_regions(file)?,
    })
}

/// Regions as their names and shapes (see [`Region::to_row`]).
fn write_regions(file: &File, regions: &[Region]) -> R<()> {
    let group = file.create_group("regions")?;
    let names: Vec<String> = regions.iter().map(|r| r.name.clone()).collect();
    put_strings(&group, "name", &names)?;
    let shape: Vec<[f64; 5]> = regions.iter().map(Region::to_row).collect();
    put(&group, "shape", ArrayView2::from(&shape[..]))?;
    Ok(())
}

/// The regions of a file; none in a file written before regions were measured.
pub(super) fn read_regions(file: &File) -> R<Vec<Region>> {
    if !file.link_exists("regions") {
        return Ok(Vec::new());
    }
    let group = file.group("regions")?;
    let names = read_vec::<VarLenUnicode>(&group, "name", None)?;
    let shape = read_rows::<f64, 5>(&group, "shape", Some(names.len()))?;
    names
        .iter()
        .zip(shape)
        .map(|(name, row)| {
            Region::from_row(name.as_str().to_owned(), row)
                .ok_or_else(|| Fail(format!("region `{name}` has an unknown shape {}", row[0])))
        })
        .collect()
}

/// Membranes as kind (0 a side, 1 a ring) and the side's outward direction or the ring's
/// centre.
fn write_membranes(file: &File, membranes: &[Membrane]) -> R<()> {
    let group = file.create_group("membranes")?;
    let names: Vec<String> = membranes.iter().map(|m| m.name.clone()).collect();
    put_strings(&group, "name", &names)?;
    let shape: Vec<[f64; 3]> = membranes
        .iter()
        .map(|m| match m.shape {
            MembraneShape::Side { outward } => [0.0, outward[0], outward[1]],
            MembraneShape::Ring { center } => [1.0, center[0], center[1]],
        })
        .collect();
    put(&group, "shape", ArrayView2::from(&shape[..]))?;
    Ok(())
}

fn read_membranes(file: &File) -> R<Vec<Membrane>> {
    let group = file.group("membranes")?;
    let names = read_vec::<VarLenUnicode>(&group, "name", None)?;
    let shape = read_rows::<f64, 3>(&group, "shape", Some(names.len()))?;
    Ok(names
        .iter()
        .zip(&shape)
        .map(|(name, s)| Membrane {
            name: name.as_str().to_owned(),
            shape: if s[0] == 0.0 {
                MembraneShape::Side {
                    outward: [s[1], s[2]],
                }
            } else {
                MembraneShape::Ring {
                    center: [s[1], s[2]],
                }
            },
            pressure: 0.0,
        })
        .collect())
}
