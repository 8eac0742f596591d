//! Reading scene and solver files, and the grains a scene points to.
//!
//! The text is parsed once into a tree that keeps byte spans (`toml::de::DeTable`, the same
//! parser `toml_edit` uses), then deserialized from that tree into the typed structs and
//! range-checked. Whatever is wrong comes back as one [`InputError`] naming the file, the key
//! path and the line: a serde error's offset is located in the tree to get its key, and a
//! validation problem's key path is followed down the tree to get its line.

use super::validate::{grain_problems, validate};
use super::{GrainSource, Scene};
use crate::error::{Error, InputError};
use crate::geometry::GrainSet;
use crate::solver::config::REMOVED_SOLVER_KEYS;
use crate::solver::SolverConfig;
use serde::de::DeserializeOwned;
use std::ops::Range;
use std::path::Path;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// At most this many further problems are listed after the first.
const MORE_PROBLEMS: usize = 10;

/// Reads and checks a scene file; returns the scene and the text it came from (the text goes
/// into the results, so a run can be traced back to its exact input).
pub fn load_scene(path: &Path) -> Result<(Scene, String), InputError> {
    let (text, file) = read_text(path, "scene")?;
    parse_scene(&text, &file).map(|scene| (scene, text))
}

/// Parses and checks a scene given as text; `file` is only used in error messages.
pub fn parse_scene(text: &str, file: &str) -> Result<Scene, InputError> {
    parse_checked(text, file, validate)
}

/// Reads and checks a solver file; returns the settings and the text they came from.
pub fn load_solver(path: &Path) -> Result<(SolverConfig, String), InputError> {
    let (text, file) = read_text(path, "solver")?;
    parse_solver(&text, &file).map(|config| (config, text))
}

/// Parses and checks solver settings given as text; `file` is only used in error messages. A
/// setting of the global Newton solver the minimisation replaced is refused as unknown, with
/// a word on why.
pub fn parse_solver(text: &str, file: &str) -> Result<SolverConfig, InputError> {
    parse_checked(text, file, SolverConfig::validate).map_err(|mut e| {
        if e.key
            .as_deref()
            .is_some_and(|k| REMOVED_SOLVER_KEYS.contains(&k))
        {
            e.message.push_str(
                "; it was a setting of the global Newton solver, which the minimisation \
                 replaced: leave it out",
            );
        }
        e
    })
}

/// The grains of a scene: inline lists, a CSV file or a sample file (both relative to
/// `base_dir`, usually the scene file's folder) or a hexagonal crystal. Problems with the
/// source itself are reported against `scene_file`; problems inside the CSV against the CSV
/// file and its line, problems with a sample file against that file.
pub fn build_grains(
    source: &GrainSource,
    base_dir: &Path,
    scene_file: &str,
) -> Result<GrainSet, InputError> {
    // Checked again here because the source may not have come through `parse_scene`.
    if let Some((key, message)) = grain_problems(source).into_iter().next() {
        return Err(InputError::new(scene_file, message).at_key(key));
    }
    let grains = if let Some(file) = &source.file {
        read_grain_csv(&base_dir.join(file))
    } else if let Some(sample) = &source.sample {
        // The grains exactly as saved: origin, displacement and rotation included.
        crate::sample::read_sample(base_dir.join(sample))
            .map(|s| s.grains)
            .map_err(|e| match e {
                Error::Input(e) => e,
                Error::Io { path, message } => InputError::new(path, message),
                Error::Numeric(e) => {
                    InputError::new(base_dir.join(sample).display().to_string(), e.to_string())
                }
            })
    } else if let Some(c) = &source.crystal {
        Ok(crate::samples::hex_crystal(
            c.rows,
            c.columns,
            c.radius,
            c.short_first,
        ))
    } else {
        let position = source.x.iter().zip(&source.y).map(|(&x, &y)| [x, y]);
        Ok(GrainSet::new(position.collect(), source.r.clone()))
    }?;
    // Inline lists were checked with the scene, where their keys have lines.
    let x: Vec<f64> = grains.position.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = grains.position.iter().map(|p| p[1]).collect();
    match (
        span_problem(&x, &y, &grains.radius),
        &source.file,
        &source.sample,
    ) {
        (Some((_, _, message)), Some(file), _) | (Some((_, _, message)), None, Some(file)) => Err(
            InputError::new(base_dir.join(file).display().to_string(), message),
        ),
        _ => Ok(grains),
    }
}

/// Largest span of the grain centres along x or y, in largest diameters: the cell grid of the
/// contact detection holds 2^16 cells along each, each at least a diameter wide.
pub const MAX_SPAN_DIAMETERS: f64 = 65_536.0;

/// A grain whose centre lies farther from the others than the cell grid can hold: the grain,
/// the axis (`"x"` or `"y"`) and what is wrong. `x`, `y` and `r` are the grains' centres and
/// radii, finite.
pub(crate) fn span_problem(
    x: &[f64],
    y: &[f64],
    r: &[f64],
) -> Option<(usize, &'static str, String)> {
    let diameter = 2.0 * r.iter().fold(0.0f64, |m, &r| m.max(r));
    for (axis, c) in [("x", x), ("y", y)] {
        let low = (0..c.len()).min_by(|&a, &b| c[a].total_cmp(&c[b]))?;
        let high = (0..c.len()).max_by(|&a, &b| c[a].total_cmp(&c[b]))?;
        let span = c[high] - c[low];
        if span > MAX_SPAN_DIAMETERS * diameter {
            // The grain farther from the middle of the others is the one out of place.
            let mut sorted = c.to_vec();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[(sorted.len() - 1) / 2];
            let far = if c[high] - median >= median - c[low] {
                high
            } else {
                low
            };
            return Some((
                far,
                axis,
                format!(
                    "grain {far} at {axis} = {:e} puts the grains {span:e} m apart along {axis}: \
                     more than {MAX_SPAN_DIAMETERS} of their largest diameter ({diameter:e} m), \
                     which the contact detection's cell grid cannot hold",
                    c[far]
                ),
            ));
        }
    }
    None
}

/// Grains from a CSV file of `x, y, r` lines; problems name the file and the line.
pub(crate) fn read_grain_csv(path: &Path) -> Result<GrainSet, InputError> {
    let (text, name) = read_text(path, "grain")?;
    parse_grain_csv(&text, &name)
}

fn read_text(path: &Path, what: &str) -> Result<(String, String), InputError> {
    let file = path.display().to_string();
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((text, file)),
        Err(e) => Err(InputError::new(
            &file,
            format!("cannot read the {what} file: {e}"),
        )),
    }
}

/// Grains from CSV text: `x, y, r` per line, an optional header line first, blank lines and
/// `#` comments allowed.
fn parse_grain_csv(text: &str, file: &str) -> Result<GrainSet, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut position = Vec::new();
    let mut radius = Vec::new();
    let mut first = true;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let bad = |message: String| InputError::new(file, message).at_line(line);
        let content = raw.split('#').next().unwrap_or_default().trim();
        if content.is_empty() {
            continue;
        }
        let fields: Vec<&str> = content.split(',').map(str::trim).collect();
        let is_first = std::mem::replace(&mut first, false);
        let numeric = fields.first().is_some_and(|f| f.parse::<f64>().is_ok());
        if is_first && !numeric {
            continue; // a header such as `x,y,r`
        }
        if fields.len() != 3 {
            return Err(bad(format!(
                "expected 3 fields `x, y, r`, found {}: `{content}`",
                fields.len()
            )));
        }
        let mut v = [0.0; 3];
        for ((slot, field), name) in v.iter_mut().zip(&fields).zip(["x", "y", "r"]) {
            *slot = field
                .parse::<f64>()
                .map_err(|_| bad(format!("`{name}` is not a number: `{field}`")))?;
            if !slot.is_finite() {
                return Err(bad(format!(
                    "`{name}` must be a finite number, not `{field}`"
                )));
            }
        }
        if v[2] <= 0.0 {
            return Err(bad(format!("the radius must be > 0, not {}", v[2])));
        }
        position.push([v[0], v[1]]);
        radius.push(v[2]);
    }
    if radius.is_empty() {
        return Err(InputError::new(
            file,
            "no grains: the file has no `x, y, r` lines",
        ));
    }
    Ok(GrainSet::new(position, radius))
}

/// Deserializes `text`, then runs `check` on the result. The spanned tree is kept to find
/// the line (and, for a serde error, the key) of whatever is wrong.
fn parse_checked<T: DeserializeOwned>(
    text: &str,
    file: &str,
    check: impl Fn(&T) -> Vec<(String, String)>,
) -> Result<T, InputError> {
    let tree = DeTable::parse(text).map_err(|e| syntax_error(text, file, &e))?;
    let value = T::deserialize(toml::de::Deserializer::from(tree.clone()))
        .map_err(|e| serde_error(text, file, tree.get_ref(), &e))?;
    let problems = check(&value);
    if problems.is_empty() {
        Ok(value)
    } else {
        Err(problems_error(text, file, tree.get_ref(), &problems))
    }
}

/// The toml message, at most two lines of it.
fn short_message(e: &toml::de::Error) -> String {
    let lines: Vec<&str> = e.message().trim().lines().take(2).collect();
    lines.join("; ")
}

/// A TOML syntax error: the line only, since the tree around a syntax error cannot be
/// trusted to name the right key.
fn syntax_error(text: &str, file: &str, e: &toml::de::Error) -> InputError {
    let err = InputError::new(file, format!("invalid TOML: {}", short_message(e)));
    match e.span() {
        Some(span) => err.at_line(line_of(text, span.start)),
        None => err,
    }
}

/// A serde error (unknown key, wrong type, missing key): the key is the one whose span holds
/// the error's offset, plus the missing field if one is missing.
fn serde_error(text: &str, file: &str, tree: &DeTable, e: &toml::de::Error) -> InputError {
    let mut err = InputError::new(file, short_message(e));
    let mut path = match e.span() {
        // The document itself has the empty span at 0: a key missing at the top has no line.
        Some(span) if !(span.is_empty() && span.start == 0) => {
            err = err.at_line(line_of(text, span.start));
            locate(tree, span.start).unwrap_or_default()
        }
        _ => Vec::new(),
    };
    if let Some(field) = missing_field(e.message()) {
        path.push(Seg::Key(field.to_string()));
    }
    if !path.is_empty() {
        err = err.at_key(format_path(&path));
    }
    err
}

/// The field a serde "missing field `x`" message names.
fn missing_field(message: &str) -> Option<&str> {
    let rest = message.strip_prefix("missing field `")?;
    rest.split('`').next()
}

/// Validation problems as one [`InputError`]: the first one with its key and line, any
/// others listed in the message.
fn problems_error(
    text: &str,
    file: &str,
    tree: &DeTable,
    problems: &[(String, String)],
) -> InputError {
    let line = |key: &str| span_of_key(tree, key).map(|span| line_of(text, span.start));
    let one = |key: &str, message: &str| {
        let err = InputError::new(file, message).at_key(key);
        match line(key) {
            Some(l) => err.at_line(l),
            None => err,
        }
    };
    let Some((key, message)) = problems.first() else {
        return InputError::new(file, "invalid input");
    };
    let mut err = one(key, message);
    for (key, message) in problems.iter().skip(1).take(MORE_PROBLEMS) {
        err.message.push('\n');
        err.message.push_str(&one(key, message).to_string());
    }
    if problems.len() > MORE_PROBLEMS + 1 {
        let more = problems.len() - MORE_PROBLEMS - 1;
        err.message
            .push_str(&format!("\n... and {more} more problems"));
    }
    err
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// One step of a key path: a table key or an array index.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Seg {
    Key(String),
    Index(usize),
}

/// `parent.key`, the key quoted as in TOML when it is not a bare key (so that a wall named
/// `a.b` stays one step of the path).
pub(crate) fn child_key(parent: &str, key: &str) -> String {
    let mut out = parent.to_string();
    if !out.is_empty() {
        out.push('.');
    }
    push_key(&mut out, key);
    out
}

fn push_key(out: &mut String, key: &str) {
    let bare = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        out.push_str(key);
    } else {
        out.push('"');
        for c in key.chars() {
            if c == '"' || c == '\\' {
                out.push('\\');
            }
            out.push(c);
        }
        out.push('"');
    }
}

fn format_path(path: &[Seg]) -> String {
    let mut out = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                push_key(&mut out, k);
            }
            Seg::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// Splits `walls[1].normal` or `stages[0].stress."a.b"` into steps; `None` if malformed.
fn parse_path(path: &str) -> Option<Vec<Seg>> {
    let mut segs = Vec::new();
    let mut chars = path.chars().peekable();
    while let Some(&c) = chars.peek() {
        match c {
            '.' if !segs.is_empty() => {
                chars.next();
            }
            '[' => {
                chars.next();
                let mut digits = String::new();
                for d in chars.by_ref() {
                    if d == ']' {
                        break;
                    }
                    digits.push(d);
                }
                segs.push(Seg::Index(digits.parse().ok()?));
            }
            '"' => {
                chars.next();
                let mut key = String::new();
                loop {
                    match chars.next()? {
                        '"' => break,
                        '\\' => key.push(chars.next()?),
                        k => key.push(k),
                    }
                }
                segs.push(Seg::Key(key));
            }
            _ => {
                let mut key = String::new();
                while let Some(&k) = chars.peek() {
                    if k == '.' || k == '[' {
                        break;
                    }
                    key.push(k);
                    chars.next();
                }
                if key.is_empty() {
                    return None;
                }
                segs.push(Seg::Key(key));
            }
        }
    }
    Some(segs)
}

/// The span of the key (or array element) a path names, or of the nearest parent that
/// exists: a missing `material.normal_stiffness` points at `[material]`.
fn span_of_key(root: &DeTable, path: &str) -> Option<Range<usize>> {
    let segs = parse_path(path)?;
    let mut best = None;
    let mut table = Some(root);
    let mut value: Option<&DeValue> = None;
    for seg in &segs {
        let next: &Spanned<DeValue> = match (seg, table, value) {
            (Seg::Key(k), Some(t), _) => match t.get_key_value(k.as_str()) {
                Some((key, v)) => {
                    best = Some(key.span());
                    v
                }
                None => break,
            },
            (Seg::Index(i), _, Some(DeValue::Array(a))) => match a.get(*i) {
                Some(v) => {
                    best = Some(v.span());
                    v
                }
                None => break,
            },
            _ => break,
        };
        table = next.get_ref().as_table();
        value = Some(next.get_ref());
    }
    best
}

/// The key path of the smallest key or value whose span holds `offset`.
fn locate(root: &DeTable, offset: usize) -> Option<Vec<Seg>> {
    let mut best = None;
    walk_table(root, offset, &mut Vec::new(), &mut best);
    best.map(|(_, path)| path)
}

type Best = Option<(usize, Vec<Seg>)>;

fn walk_table(t: &DeTable, offset: usize, path: &mut Vec<Seg>, best: &mut Best) {
    for (k, v) in t.iter() {
        path.push(Seg::Key(k.get_ref().to_string()));
        consider(k.span(), offset, path, best);
        walk_value(v, offset, path, best);
        path.pop();
    }
}

fn walk_value(v: &Spanned<DeValue>, offset: usize, path: &mut Vec<Seg>, best: &mut Best) {
    consider(v.span(), offset, path, best);
    match v.get_ref() {
        DeValue::Table(t) => walk_table(t, offset, path, best),
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                path.push(Seg::Index(i));
                walk_value(item, offset, path, best);
                path.pop();
            }
        }
        _ => {}
    }
}

/// Keeps `path` if its span holds `offset` and is no longer than the best so far (ties go
/// to the deeper path, visited later: an `[[stages]]` header is both the array and its
/// first entry).
fn consider(span: Range<usize>, offset: usize, path: &[Seg], best: &mut Best) {
    let holds = span.start <= offset && offset < span.end.max(span.start + 1);
    let len = span.end.saturating_sub(span.start);
    if holds && best.as_ref().is_none_or(|(l, _)| len <= *l) {
        *best = Some((len, path.to_vec()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = r#"name = "t"
[material]
law = "linear"
normal_stiffness = 1e8

[grains.crystal]
rows = 5

[[walls]]
name = "a.b"
normal = [0.0,
  1.0]

[[stages]]
increments = 1
stress = { top = 1.0 }

[[stages]]
increments = 2
"#;

    fn line(path: &str) -> Option<usize> {
        let tree = DeTable::parse(DOC).unwrap();
        span_of_key(tree.get_ref(), path).map(|s| line_of(DOC, s.start))
    }

    #[test]
    fn paths_round_trip() {
        for p in [
            "material.friction",
            "walls[1].normal[0]",
            "stages[0].stress.\"a.b\"",
        ] {
            assert_eq!(format_path(&parse_path(p).unwrap()), p);
        }
        assert_eq!(
            child_key("stages[0].stress", "a.b"),
            "stages[0].stress.\"a.b\""
        );
        assert_eq!(child_key("", "x\"y"), "\"x\\\"y\"");
        assert_eq!(parse_path("a[x]"), None);
        assert_eq!(parse_path("\"open"), None);
    }

    #[test]
    fn key_paths_find_their_lines() {
        assert_eq!(line("name"), Some(1));
        assert_eq!(line("material"), Some(2));
        assert_eq!(line("material.normal_stiffness"), Some(4));
        assert_eq!(line("grains.crystal.rows"), Some(7));
        assert_eq!(line("walls[0].normal"), Some(11));
        assert_eq!(line("walls[0].normal[1]"), Some(12));
        assert_eq!(line("stages[0].stress.top"), Some(16));
        assert_eq!(line("stages[1].increments"), Some(19));
    }

    #[test]
    fn missing_keys_fall_back_to_their_parent() {
        assert_eq!(line("material.shear_modulus"), Some(2));
        assert_eq!(line("grains.crystal.radius"), Some(6));
        assert_eq!(line("stages[1].stress.top"), Some(18));
        assert_eq!(line("walls[3].name"), Some(9));
        assert_eq!(line("output.every"), None);
    }

    #[test]
    fn offsets_find_their_keys() {
        let tree = DeTable::parse(DOC).unwrap();
        let at = |needle: &str| {
            let offset = DOC.find(needle).unwrap();
            format_path(&locate(tree.get_ref(), offset).unwrap())
        };
        assert_eq!(at("normal_stiffness"), "material.normal_stiffness");
        assert_eq!(at("1e8"), "material.normal_stiffness");
        assert_eq!(at("1.0]"), "walls[0].normal[1]");
        assert_eq!(at("top"), "stages[0].stress.top");
        assert_eq!(at("[[stages]]\nincrements = 2"), "stages[1]");
        assert_eq!(at("[grains.crystal]"), "grains.crystal");
    }

    #[test]
    fn lines_count_from_one() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("a\nb\nc", 99), 3);
    }

    #[test]
    fn csv_lines() {
        let ok = "x,y,r\n# comment\n\n0, 0, 1e-4\n1e-3,0,2e-4 # trailing\n";
        let g = parse_grain_csv(ok, "g.csv").unwrap();
        assert_eq!(g.radius, vec![1e-4, 2e-4]);
        let e = parse_grain_csv("0,0,1\n0,0\n", "g.csv").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = parse_grain_csv("x,y,r\n0,0,1\n0,a,1\n", "g.csv").unwrap_err();
        assert_eq!(e.line, Some(3));
        let e = parse_grain_csv("0,0,1\n0,0,-1\n", "g.csv").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = parse_grain_csv("0,0,1\n0,0,nan\n", "g.csv").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = parse_grain_csv("x,y,r\n\n# nothing\n", "g.csv").unwrap_err();
        assert_eq!((e.line, e.message.contains("no grains")), (None, true));
    }
}
