//! `corofem info MESH`: size and quality figures of a mesh file.

use std::fmt::Write as _;
use std::path::Path;

use corofem_io::MeshStats;

use crate::error::{CliError, CliResult};
use crate::mesh_input::plural;
use crate::scene_file::MAX_NODES;

/// Reads `path` and prints its figures on stdout: a mesh's, or a surface's
/// for an `.obj` or `.stl` file.
pub fn info(path: &Path) -> CliResult<()> {
    if corofem_io::SurfaceFormat::from_path(path).is_some() {
        let surface = corofem_io::read_surface(path).map_err(|e| CliError(e.to_string()))?;
        print!("{}", surface_report(&path.display().to_string(), &surface));
        return Ok(());
    }
    let mesh = corofem_io::read_mesh(path).map_err(|e| CliError(e.to_string()))?;
    let stats = corofem_io::mesh_stats(&mesh);
    let mut text = report(&path.display().to_string(), &stats);
    text.push_str(&usable_line(corofem_io::unusable(&mesh, 1.0)));
    print!("{text}");
    Ok(())
}

/// The `corofem run` line: whether the solver can use the mesh (at
/// `[mesh] scale = 1`), by the test `run` applies.
pub fn usable_line(why: Option<corofem_io::Unusable>) -> String {
    match why {
        None => "  corofem run    usable (at [mesh] scale = 1)\n".to_owned(),
        Some(why) => format!("  corofem run    rejects the mesh: {why}\n"),
    }
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

/// The report of a surface file: counts, bounding box, how closed and how
/// consistently wound it is, and whether `[visual]` can bind it.
pub fn surface_report(name: &str, s: &corofem_io::Surface) -> String {
    let mut o = String::new();
    let mut used = vec![false; s.vertices.len()];
    for &i in s.triangles.iter().flatten() {
        used[i as usize] = true;
    }
    let unused = used.iter().filter(|&&u| !u).count();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &s.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    // Each edge's uses, counted +1 one way round and −1 the other: a closed,
    // consistently wound surface uses every edge twice, once each way.
    let mut edges: std::collections::HashMap<(u32, u32), (u32, i32)> =
        std::collections::HashMap::new();
    for t in &s.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
        }
    }
    let open = edges.values().filter(|e| e.0 == 1).count();
    let shared = edges.values().filter(|e| e.0 > 2).count();
    let flipped = edges.values().filter(|e| e.0 == 2 && e.1 != 0).count();
    let v3 = |v: [f64; 3]| format!("[{}, {}, {}]", g(v[0]), g(v[1]), g(v[2]));
    let _ = writeln!(o, "{name}");
    let _ = writeln!(
        o,
        "  vertices       {} ({unused} in no triangle)",
        s.vertices.len()
    );
    let _ = writeln!(o, "  triangles      {}", s.triangles.len());
    let _ = writeln!(
        o,
        "  bounding box   {} .. {}  (size {})",
        v3(lo),
        v3(hi),
        v3([0, 1, 2].map(|k| hi[k] - lo[k]))
    );
    let closed = if open == 0 && shared == 0 && flipped == 0 {
        "closed, consistently wound".to_owned()
    } else {
        format!(
            "{} on one triangle only, {} on more than two, {} wound the same way twice",
            plural(open, "edge"),
            plural(shared, "edge"),
            plural(flipped, "edge")
        )
    };
    let _ = writeln!(o, "  edges          {} ({closed})", edges.len());
    let check = match corofem::check_surface(&s.vertices, &s.triangles) {
        Ok(()) => "binds, if within reach of the tetrahedra ([visual])".to_owned(),
        Err(e) => format!("refused by [visual]: {e}"),
    };
    let _ = writeln!(o, "  surface        {check}");
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
            "{} degenerate (zero volume, or flat to 1e-12 of the longest edge cubed: corofem run rejects the mesh)",
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
                 reorient = true), 1 degenerate (zero volume, or flat to 1e-12 of the longest \
                 edge cubed: corofem run rejects the mesh), \
                 1 positively oriented"
            ),
            "{r}"
        );
        assert!(!r.contains("all tetrahedra"), "{r}");
    }
}
