//! `corofem info MESH`: size and quality figures of a mesh file.

use std::fmt::Write as _;
use std::path::Path;

use corofem_io::MeshStats;

use crate::error::{CliError, CliResult};
use crate::mesh_input::plural;
use crate::scene_file::MAX_NODES;

/// Reads `path` and prints its figures on stdout.
pub fn info(path: &Path) -> CliResult<()> {
    let mesh = corofem_io::read_mesh(path).map_err(|e| CliError(e.to_string()))?;
    let stats = corofem_io::mesh_stats(&mesh);
    print!("{}", report(&path.display().to_string(), &stats));
    Ok(())
}

/// The human-readable report of `stats` for the file `name`.
pub fn report(name: &str, s: &MeshStats) -> String {
    let mut o = String::new();
    let v3 = |v: [f64; 3]| format!("[{}, {}, {}]", g(v[0]), g(v[1]), g(v[2]));
    let size = [0, 1, 2].map(|k| s.bbox_max[k] - s.bbox_min[k]);
    // Writing into a String cannot fail.
    let _ = writeln!(o, "{name}");
    let _ = writeln!(
        o,
        "  nodes          {} ({} unused)",
        s.nodes, s.unused_nodes
    );
    let _ = writeln!(o, "  tetrahedra     {}", s.tets);
    let _ = writeln!(
        o,
        "  bounding box   {} .. {}  (size {})",
        v3(s.bbox_min),
        v3(s.bbox_max),
        v3(size)
    );
    let _ = writeln!(
        o,
        "  volume         total {}, per tetrahedron min {} / max {}  (file units cubed)",
        g(s.total_volume),
        g(s.min_tet_volume),
        g(s.max_tet_volume)
    );
    let _ = writeln!(
        o,
        "  dihedral angle min {:.2} deg, max {:.2} deg",
        s.min_dihedral_deg, s.max_dihedral_deg
    );
    let orientation = orientation(s);
    let _ = writeln!(o, "  orientation    {orientation}");
    let _ = writeln!(o, "  zero volume    {}", s.zero_volume_tets);
    if s.unused_nodes > 0 {
        let _ = writeln!(
            o,
            "  note           corofem run drops the {} and renumbers the rest",
            plural(s.unused_nodes, "unused node")
        );
    }
    if s.nodes - s.unused_nodes > MAX_NODES {
        let _ = writeln!(
            o,
            "  note           too many nodes for corofem (at most {MAX_NODES})"
        );
    }
    o
}

/// The orientation line: positive, negative (fixable with `reorient`) or
/// degenerate (zero volume: no orientation, and no fix).
fn orientation(s: &MeshStats) -> String {
    let positive = s.tets - s.negative_tets - s.zero_volume_tets;
    if positive == s.tets {
        return "all tetrahedra positively oriented".to_owned();
    }
    let mut parts = Vec::new();
    if s.negative_tets > 0 {
        parts.push(format!(
            "{} negatively oriented (corofem run rejects them unless [mesh] reorient = true)",
            s.negative_tets
        ));
    }
    if s.zero_volume_tets > 0 {
        parts.push(format!(
            "{} degenerate (zero volume: corofem run rejects the mesh)",
            s.zero_volume_tets
        ));
    }
    if positive > 0 {
        parts.push(format!("{positive} positively oriented"));
    }
    parts.join(", ")
}

/// A number in 6 significant digits.
fn g(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10();
    if (-4.0..6.0).contains(&mag) {
        let decimals = (5.0 - mag.floor()).max(0.0) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    } else {
        format!("{x:.5e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short() {
        assert_eq!(g(0.0), "0");
        assert_eq!(g(1.5), "1.5");
        assert_eq!(g(6.512345678), "6.51235");
        assert_eq!(g(-2.0), "-2");
        assert_eq!(g(1.0e-7), "1.00000e-7");
    }

    #[test]
    fn report_has_every_figure() {
        let m = corofem_io::Mesh {
            nodes: vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [5.0; 3],
            ],
            tets: vec![[0, 1, 2, 3]],
        };
        let r = report("t.tetmesh", &corofem_io::mesh_stats(&m));
        for word in [
            "nodes          5 (1 unused)",
            "tetrahedra     1",
            "bounding box",
            "volume",
            "dihedral",
            "orientation",
            "zero volume",
            "drops the 1 unused node and",
        ] {
            assert!(r.contains(word), "{word} missing in\n{r}");
        }
    }

    #[test]
    fn a_flat_tetrahedron_is_degenerate_not_positive() {
        let m = corofem_io::Mesh {
            nodes: vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            tets: vec![[0, 1, 2, 3], [0, 1, 2, 4], [0, 2, 1, 4]],
        };
        let r = report("t.tetmesh", &corofem_io::mesh_stats(&m));
        assert!(
            r.contains(
                "orientation    1 negatively oriented (corofem run rejects them unless [mesh] \
                 reorient = true), 1 degenerate (zero volume: corofem run rejects the mesh), \
                 1 positively oriented"
            ),
            "{r}"
        );
        assert!(!r.contains("all tetrahedra"), "{r}");
    }
}
