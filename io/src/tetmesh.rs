//! The project's own `tetmesh 1` text format (parsed by hand: it is four lines of
//! grammar and no crate knows it).
//!
//! ```text
//! tetmesh 1
//! <n_nodes> <n_tets>
//! x y z          (n_nodes lines)
//! i j k l        (n_tets lines, 0-based node indices)
//! ```
//!
//! The reader tolerates blank lines and surrounding whitespace; the writer produces
//! neither.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{check_count, MeshError};
use crate::mesh::Mesh;
use crate::text::{plural, shorten, tokens, LineReader};

/// First line of every `tetmesh 1` file.
const MAGIC: &str = "tetmesh 1";

/// Parses the text of a `tetmesh 1` file.
///
/// `name` is only used in error messages (normally the file name). Checks the
/// header, both counts (each at most [`MAX_COUNT`](crate::MAX_COUNT), checked
/// before allocating), that every coordinate is a finite number, that every index
/// is in range, that there is at least one tetrahedron and that nothing follows the
/// last tetrahedron. Node order and tetrahedron orientation are kept as written.
pub fn parse_tetmesh(text: &str, name: &str) -> Result<Mesh, MeshError> {
    let mut r = LineReader::new(text, name);

    let (ln, line) = r.expect_line(|| format!("header \"{MAGIC}\""))?;
    if tokens(line) != ["tetmesh", "1"] {
        return Err(r.malformed(
            ln,
            format!("header \"{MAGIC}\""),
            format!("\"{}\"", shorten(line)),
        ));
    }

    let (ln, line) = r.expect_line(|| "counts line \"<n_nodes> <n_tets>\"".to_owned())?;
    let t = tokens(line);
    if t.len() != 2 {
        return Err(r.malformed(
            ln,
            "2 counts \"<n_nodes> <n_tets>\"".to_owned(),
            plural(t.len(), "value"),
        ));
    }
    let n_nodes = r.u64(ln, t[0], || "node count".to_owned())?;
    let n_tets = r.u64(ln, t[1], || "tetrahedron count".to_owned())?;
    let n_nodes = check_count(name, Some(ln), "node", n_nodes)?;
    let n_tets = check_count(name, Some(ln), "tetrahedron", n_tets)?;
    if n_tets == 0 {
        return Err(MeshError::NoTetrahedra {
            file: name.to_owned(),
            skipped: 0,
            higher_order: 0,
        });
    }

    let mut nodes = Vec::with_capacity(n_nodes);
    for k in 0..n_nodes {
        let (ln, line) = r.expect_line(|| format!("node {} of {n_nodes}", k + 1))?;
        let t = tokens(line);
        if t.len() != 3 {
            return Err(r.malformed(
                ln,
                format!("3 coordinates (node {} of {n_nodes})", k + 1),
                plural(t.len(), "value"),
            ));
        }
        let mut p = [0.0; 3];
        for (c, (v, tok)) in p.iter_mut().zip(&t).enumerate() {
            *v = r.f64(ln, tok, || {
                format!("{} coordinate of node {k}", ["x", "y", "z"][c])
            })?;
        }
        nodes.push(p);
    }

    let mut tets = Vec::with_capacity(n_tets);
    for k in 0..n_tets {
        let (ln, line) = r.expect_line(|| format!("tetrahedron {} of {n_tets}", k + 1))?;
        let t = tokens(line);
        if t.len() != 4 {
            return Err(r.malformed(
                ln,
                format!("4 node indices (tetrahedron {} of {n_tets})", k + 1),
                plural(t.len(), "value"),
            ));
        }
        let mut tet = [0usize; 4];
        for (v, tok) in tet.iter_mut().zip(&t) {
            let i = r.u64(ln, tok, || format!("node index of tetrahedron {k}"))?;
            if i >= n_nodes as u64 {
                return Err(MeshError::IndexOutOfRange {
                    file: name.to_owned(),
                    line: Some(ln),
                    index: i,
                    nodes: n_nodes,
                });
            }
            *v = i as usize;
        }
        tets.push(tet);
    }

    if let Some((ln, _)) = r.next_line() {
        let mut extra = 1;
        while r.next_line().is_some() {
            extra += 1;
        }
        return Err(MeshError::CountMismatch {
            file: name.to_owned(),
            line: Some(ln),
            what: "node and tetrahedron lines".to_owned(),
            declared: n_nodes + n_tets,
            found: n_nodes + n_tets + extra,
        });
    }
    Ok(Mesh { nodes, tets })
}

/// Formats a mesh as `tetmesh 1` text.
///
/// Coordinates are written with Rust's shortest round-trip formatting, so
/// [`parse_tetmesh`] gives back exactly the same `f64` values.
pub fn format_tetmesh(mesh: &Mesh) -> String {
    let mut s = String::with_capacity(32 + 40 * mesh.nodes.len() + 24 * mesh.tets.len());
    // Writing into a String cannot fail.
    let _ = writeln!(s, "{MAGIC}\n{} {}", mesh.nodes.len(), mesh.tets.len());
    for [x, y, z] in &mesh.nodes {
        let _ = writeln!(s, "{x:?} {y:?} {z:?}");
    }
    for [a, b, c, d] in &mesh.tets {
        let _ = writeln!(s, "{a} {b} {c} {d}");
    }
    s
}

/// Writes a mesh to `path` in `tetmesh 1` format (see [`format_tetmesh`]).
pub fn write_tetmesh(path: &Path, mesh: &Mesh) -> std::io::Result<()> {
    std::fs::write(path, format_tetmesh(mesh))
}
