//! `VecScene` (feature `alloc`): a scene in `Vec`s sized at run time, for
//! meshes known only when a program runs. It holds exactly what it was
//! sized for, every node can be grabbed and loaded, it gives the bits of a
//! fixed-capacity scene, and a size that cannot be had is a build error,
//! never a panic.

use corofem::{Error, Preconditioner, Slots, StaticScene, VecScene, VecStorage};
use corofem_host_tests::{box_mesh, build_box};

/// A 3×2×2-cell box: 36 nodes, 72 tetrahedra.
const SIZE: [f32; 3] = [0.3, 0.2, 0.2];
const CELLS: [u32; 3] = [3, 2, 2];

#[test]
fn a_vec_scene_holds_what_it_was_sized_for() {
    let mesh = box_mesh(SIZE, CELLS, 6);
    let (n, t) = (mesh.nodes.len(), mesh.tets.len());
    let mut s = VecScene::with_capacity(n, t);
    assert_eq!(s.node_capacity(), n);
    assert!(s.element_capacity() >= t);
    // A grab and a load slot per node, and the two-level preconditioner
    // with as many aggregates as it takes for that many free nodes.
    assert_eq!(
        s.capacity(),
        Slots {
            nodes: n,
            elements: s.element_capacity(),
            grabs: n,
            loads: n,
            preconditioner: Preconditioner::TwoLevel,
            aggregates: corofem::aggregates_for(n, corofem::MAX_AGGREGATES),
        }
    );
    build_box(&mut s, SIZE, CELLS);
    assert_eq!((s.node_count(), s.element_count()), (n, t));
    // Every node has a grab and a load slot.
    let all: Vec<u32> = (0..n as u32).collect();
    s.grab(&all, 100.0).unwrap();
    for i in 0..n as u32 {
        s.set_force(i, [0.0, 0.0, -1.0e-3]).unwrap();
    }
    s.step().unwrap();
    // One node more than it holds is a typed error.
    let mut small = VecScene::with_capacity(n - 1, t);
    let material = corofem::Material::default();
    assert_eq!(
        small.build(&mesh.nodes, &mesh.tets, &material, Default::default()),
        Err(Error::TooManyNodes {
            count: n,
            capacity: n - 1
        })
    );
}

#[test]
fn a_vec_scene_has_the_bits_of_a_static_one() {
    let mut heap = VecScene::with_capacity(36, 72);
    corofem::capacity! {
        /// Room for exactly the box.
        struct BoxSlots { nodes: 36, elements: 72 }
    }
    let mut fixed = Box::new(StaticScene::<BoxSlots>::new());
    build_box(&mut heap, SIZE, CELLS);
    build_box(&mut *fixed, SIZE, CELLS);
    heap.fix_nodes(&[0, 4, 8]).unwrap();
    fixed.fix_nodes(&[0, 4, 8]).unwrap();
    // A `VecScene` has slots for every preconditioner; the static one has
    // none: both step with the static one's defaults, the paper's CG.
    assert_eq!(heap.default_settings(), corofem::Settings::new());
    heap.set_settings(fixed.default_settings()).unwrap();
    for _ in 0..20 {
        heap.step().unwrap();
        fixed.step().unwrap();
    }
    assert_eq!(heap.state_hash(), fixed.state_hash());
    assert_ne!(
        heap.state_hash(),
        VecScene::with_capacity(36, 72).state_hash()
    );
}

#[test]
fn a_size_that_cannot_be_had_is_a_build_error_not_a_panic() {
    // More nodes than a scene addresses are capped at 65 536; an element
    // count whose memory overflows leaves the element slots empty.
    let storage = VecStorage::with_capacity(usize::MAX, usize::MAX);
    let mut s = corofem::Scene::with_storage(storage);
    assert_eq!(s.node_capacity(), 1 << 16);
    assert_eq!(s.element_capacity(), 0);
    let mesh = box_mesh(SIZE, CELLS, 6);
    let material = corofem::Material::default();
    assert_eq!(
        s.build(&mesh.nodes, &mesh.tets, &material, Default::default()),
        Err(Error::TooManyElements {
            count: mesh.tets.len(),
            capacity: 0
        })
    );
    assert_eq!(s.node_count(), 0);
}
