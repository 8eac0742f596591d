//! XDMF 3 beside a result file, so that ParaView opens a run directly: one time step per
//! complete written increment, the grains as points and the contacts as lines between them.
//! Every array is a reference into the HDF5 file, none is copied.
//!
//! Grains are a `Polyvertex` grid on `grains/position` (geometry `XY`: ParaView adds
//! z = 0) with one point cell per grain (`/grains/index`) and the radius, rotation and
//! displacement (a 2-component vector) as point attributes. Contacts are a `Polyline` grid of
//! two nodes per element on the same points, connected by `contacts/nodes` (a wall contact is
//! a line of zero length at its grain), with normal force, shear force and state as cell
//! attributes. Every array is a whole dataset: ParaView's XDMF 3 reader drops attributes
//! given as hyperslabs, and cannot make point cells without a connectivity array.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::h5::{dataset, get_count, read_error, R};
use super::hdf5_file::{group_name, increment_groups, open_existing};
use crate::Error;

/// The XDMF file written beside a result file: the same name with `.xmf`.
pub fn xdmf_path(result: &Path) -> PathBuf {
    result.with_extension("xmf")
}

/// What the XDMF needs of one increment.
struct Step {
    increment: usize,
    /// Contacts (rows of `contacts/nodes`).
    contacts: usize,
}

/// Write the XDMF for the result file `result` beside it; returns its path.
pub fn write_xdmf(result: &Path) -> Result<PathBuf, Error> {
    let file = open_existing(result)?;
    let read = || -> R<(usize, Vec<Step>)> {
        let grains = get_count(&file, "grains")?;
        // Written since the XDMF exists; older files lack it.
        dataset(&file.group("grains")?, "index")?;
        let inc = file.group("increments")?;
        let mut steps = Vec::new();
        for (increment, name, complete) in increment_groups(&inc)? {
            if complete {
                let g = inc.group(&name)?;
                let contacts = dataset(&g, "contacts/nodes")?.shape()[0];
                steps.push(Step {
                    increment,
                    contacts,
                });
            }
        }
        Ok((grains, steps))
    };
    let (grains, steps) = read().map_err(read_error(result))?;
    let h5 = result
        .file_name()
        .map(|n| escape(&n.to_string_lossy()))
        .unwrap_or_default();
    let path = xdmf_path(result);
    std::fs::write(&path, document(&h5, grains, &steps))
        .map_err(|e| Error::io(path.display(), e))?;
    Ok(path)
}

fn document(h5: &str, grains: usize, steps: &[Step]) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
    x.push_str("<Xdmf Version=\"3.0\">\n  <Domain>\n");
    x.push_str("    <Grid Name=\"grains\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for s in steps {
        grains_grid(&mut x, h5, grains, s.increment);
    }
    x.push_str("    </Grid>\n");
    x.push_str(
        "    <Grid Name=\"contacts\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for s in steps {
        contacts_grid(&mut x, h5, grains, s);
    }
    x.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    x
}

/// A dataset of the result file: `dims` as XDMF writes them, `kind` its number type and
/// size in bytes.
fn hdf(h5: &str, path: &str, dims: &str, (kind, bytes): (&str, usize)) -> String {
    format!(
        "<DataItem Dimensions=\"{dims}\" NumberType=\"{kind}\" Precision=\"{bytes}\" \
         Format=\"HDF\">{h5}:{path}</DataItem>"
    )
}

const FLOAT: (&str, usize) = ("Float", 8);
const INT: (&str, usize) = ("Int", 8);
const BYTE: (&str, usize) = ("UChar", 1);

fn grains_grid(x: &mut String, h5: &str, n: usize, increment: usize) {
    let g = format!("/increments/{}", group_name(increment));
    let _ = write!(
        x,
        "      <Grid Name=\"grains\" GridType=\"Uniform\">\n        <Time Value=\"{increment}\"/>\n        \
         <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\">{}</Topology>\n        \
         <Geometry GeometryType=\"XY\">{}</Geometry>\n",
        hdf(h5, "/grains/index", &n.to_string(), INT),
        hdf(h5, &format!("{g}/grains/position"), &format!("{n} 2"), FLOAT)
    );
    let attributes = [
        (
            "radius",
            "Scalar",
            "/grains/radius".to_string(),
            n.to_string(),
        ),
        (
            "rotation",
            "Scalar",
            format!("{g}/grains/rotation"),
            n.to_string(),
        ),
        (
            "displacement",
            "Vector",
            format!("{g}/grains/displacement"),
            format!("{n} 2"),
        ),
    ];
    for (name, kind, path, dims) in attributes {
        let _ = writeln!(
            x,
            "        <Attribute Name=\"{name}\" AttributeType=\"{kind}\" Center=\"Node\">{}</Attribute>",
            hdf(h5, &path, &dims, FLOAT)
        );
    }
    x.push_str("      </Grid>\n");
}

fn contacts_grid(x: &mut String, h5: &str, n: usize, s: &Step) {
    let g = format!("/increments/{}", group_name(s.increment));
    let m = s.contacts;
    let _ = write!(
        x,
        "      <Grid Name=\"contacts\" GridType=\"Uniform\">\n        <Time Value=\"{}\"/>\n        \
         <Topology TopologyType=\"Polyline\" NumberOfElements=\"{m}\" NodesPerElement=\"2\">{}</Topology>\n        \
         <Geometry GeometryType=\"XY\">{}</Geometry>\n",
        s.increment,
        hdf(h5, &format!("{g}/contacts/nodes"), &format!("{m} 2"), INT),
        hdf(h5, &format!("{g}/grains/position"), &format!("{n} 2"), FLOAT)
    );
    let attributes = [
        ("normal_force", FLOAT),
        ("shear_force", FLOAT),
        ("state", BYTE),
    ];
    for (name, kind) in attributes {
        let _ = writeln!(
            x,
            "        <Attribute Name=\"{name}\" AttributeType=\"Scalar\" Center=\"Cell\">{}</Attribute>",
            hdf(h5, &format!("{g}/contacts/{name}"), &m.to_string(), kind)
        );
    }
    x.push_str("      </Grid>\n");
}

/// Text safe inside XML.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
