//! Node selections of `[[fixed]]`, `[[force]]` and `[tool]`: a box, an index
//! list, or both, resolved against the built mesh.

use crate::error::{CliError, CliResult};
use crate::scene_file::{List, Selection};

/// The sorted, distinct node indices a selection chooses: the nodes whose rest
/// position lies in the box (bounds included) together with the listed ones.
///
/// Errors (naming `file` and the selection's table) when a listed index does
/// not exist or the box holds no node.
pub fn resolve(sel: &Selection, rest: &[[f32; 3]], file: &str) -> CliResult<Vec<u32>> {
    let n = rest.len();
    let mut out: Vec<u32> = Vec::with_capacity(sel.nodes.len());
    if let Some(&bad) = sel.nodes.iter().find(|&&i| i >= n as u64) {
        return Err(CliError(format!(
            "{file}: {} nodes: node {bad} does not exist: expected node indices from 0 to {} (the mesh has {n} nodes)",
            sel.label,
            n.saturating_sub(1)
        )));
    }
    out.extend(sel.nodes.iter().map(|&i| i as u32));
    if let Some((min, max)) = sel.bbox {
        let before = out.len();
        out.extend(
            rest.iter()
                .enumerate()
                .filter(|(_, p)| (0..3).all(|k| p[k] >= min[k] && p[k] <= max[k]))
                .map(|(i, _)| i as u32),
        );
        if out.len() == before {
            let (lo, hi) = bounds(rest);
            return Err(CliError(format!(
                "{file}: {} box = {{ min = {}, max = {} }}: selects no node; expected a box around at least one node (the mesh spans {} .. {})",
                sel.label,
                List(&min),
                List(&max),
                List(&lo),
                List(&hi)
            )));
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// Bounding box of `points`.
pub fn bounds(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sel(bbox: Option<([f32; 3], [f32; 3])>, nodes: Vec<u64>) -> Selection {
        Selection {
            label: "[[fixed]] #1".into(),
            bbox,
            nodes,
        }
    }

    const PTS: [[f32; 3]; 4] = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    #[test]
    fn union_of_box_and_list_sorted_and_distinct() {
        let s = sel(Some(([-1.0; 3], [0.5, 2.0, 0.5])), vec![3, 0]);
        assert_eq!(resolve(&s, &PTS, "f").unwrap(), vec![0, 2, 3]);
    }

    #[test]
    fn out_of_range_index_is_named() {
        let e = resolve(&sel(None, vec![1, 9]), &PTS, "f.toml")
            .unwrap_err()
            .0;
        assert!(
            e.starts_with("f.toml: [[fixed]] #1 nodes: node 9 does not exist"),
            "{e}"
        );
    }

    #[test]
    fn empty_box_is_an_error() {
        let e = resolve(&sel(Some(([5.0; 3], [6.0; 3])), vec![]), &PTS, "f")
            .unwrap_err()
            .0;
        assert!(e.contains("selects no node"), "{e}");
    }
}
