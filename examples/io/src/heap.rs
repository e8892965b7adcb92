//! Scene storage on the heap, sized at run time, and the conversion of a
//! read mesh to the core's input types — for host programs and tests whose
//! meshes are only known at run time.

use corofem::{element_blocks, ElementBlock, Node, NodeEntry, NodeWork, PartsMut, Scene, Storage};

use crate::Mesh;

/// Scene storage in vectors.
#[derive(Clone, Debug)]
pub struct HeapStorage {
    nodes: Vec<Node>,
    work: Vec<NodeWork>,
    elems: Vec<ElementBlock>,
    /// Grab and load slots: one per node, so any node can be grabbed or loaded.
    grabs: Vec<NodeEntry>,
    loads: Vec<NodeEntry>,
}

impl HeapStorage {
    /// Room for `nodes` nodes and `elems` tetrahedra.
    pub fn new(nodes: usize, elems: usize) -> Self {
        Self {
            nodes: vec![Node::EMPTY; nodes],
            work: vec![NodeWork::EMPTY; nodes],
            grabs: vec![NodeEntry::EMPTY; nodes],
            loads: vec![NodeEntry::EMPTY; nodes],
            elems: vec![ElementBlock::EMPTY; element_blocks(elems)],
        }
    }
}

impl Storage for HeapStorage {
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (&self.nodes, &self.elems)
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        PartsMut {
            nodes: &mut self.nodes,
            work: &mut self.work,
            elems: &mut self.elems,
            grabs: &mut self.grabs,
            loads: &mut self.loads,
        }
    }
}

/// A scene whose storage is on the heap.
pub type HeapScene = Scene<HeapStorage>;

/// An empty heap scene with room for exactly `nodes` nodes and `elems` tetrahedra.
pub fn heap_scene(nodes: usize, elems: usize) -> HeapScene {
    Scene::with_storage(HeapStorage::new(nodes, elems))
}

/// The mesh as the core takes it: f32 coordinates (m, after multiplying by
/// `scale`) and u32 indices. Indices that do not fit in u32 become
/// `u32::MAX`, which the core rejects as out of range.
pub fn to_core(mesh: &Mesh, scale: f64) -> (Vec<[f32; 3]>, Vec<[u32; 4]>) {
    let nodes = mesh
        .nodes
        .iter()
        .map(|p| {
            [
                (p[0] * scale) as f32,
                (p[1] * scale) as f32,
                (p[2] * scale) as f32,
            ]
        })
        .collect();
    let tets = mesh
        .tets
        .iter()
        .map(|t| t.map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
        .collect();
    (nodes, tets)
}
