//! The lists of what only some nodes carry — the tool's grab offsets and the
//! constant loads — are fixed-capacity slots of the storage (`grabs` and
//! `loads` of its capacity). Full slots refuse one node more with a typed error and
//! change nothing; the order in which forces are set, replaced and removed
//! does not change the results.

use corofem::{Error, Scene, StaticScene, StepStats, Storage};
use corofem_host_tests::build_box;

corofem::capacity! {
    /// 2 grab slots and 2 load slots.
    struct TightSlots { nodes: 64, elements: 128, grabs: 2, loads: 2 }
}
corofem::capacity! {
    /// No grab or load slot.
    struct NoSlots { nodes: 64, elements: 128 }
}
/// The scene with 2 grab and 2 load slots.
type Tight = StaticScene<TightSlots>;

/// Forces of the tests (N).
const F3: [f32; 3] = [0.0, 0.0, -2.0];
const F5: [f32; 3] = [1.0, 0.5, 0.0];
const F5_LATER: [f32; 3] = [-1.0, 0.0, 3.0];

/// The 2 m × 1 m × 1 m block of 12 tetrahedra and 12 nodes (node
/// `i + 3 (j + 2 k)` at `(i, j, k)` m), its face x = 0 fixed.
fn scene() -> Tight {
    let mut s = Tight::new();
    build(&mut s);
    s.fix_nodes(&[0, 3, 6, 9]).unwrap();
    s
}

/// (Re)builds the block into `s`.
fn build<S: Storage>(s: &mut Scene<S>) {
    build_box(s, [2.0, 1.0, 1.0], [2, 1, 1]);
}

/// Steps `s` 20 times (1 ms, the default settings) and returns the last
/// statistics and the state hash.
fn run(s: &mut Tight) -> (StepStats, u64) {
    let mut last = StepStats::default();
    for k in 0..20 {
        last = s.step_haptic([2.0 + 0.001 * k as f32, 0.5, 0.5]).unwrap();
    }
    (last, s.state_hash())
}

#[test]
fn full_slots_refuse_one_node_more_and_change_nothing() {
    let loaded = || {
        let mut s = scene();
        s.set_force(7, F5).unwrap();
        s.set_force(4, F3).unwrap();
        s.grab(&[11, 8], 50.0).unwrap();
        s
    };
    let want = run(&mut loaded());

    let mut s = loaded();
    // Three distinct nodes (one listed twice) for two slots.
    assert_eq!(
        s.grab(&[1, 2, 2, 4], 50.0),
        Err(Error::TooManyGrabbed {
            count: 3,
            capacity: 2
        })
    );
    assert_eq!(
        s.set_force(9, [1.0; 3]),
        Err(Error::TooManyLoads { capacity: 2 })
    );
    // Replacing a force in a full list is not a new node, and a zero force
    // on a node without one takes no slot.
    s.set_force(7, F5).unwrap();
    s.set_force(9, [0.0; 3]).unwrap();
    assert!(s.is_grabbing());
    assert_eq!(run(&mut s), want, "a refused call changed the scene");

    // Control: the grab and the forces do act (else the comparison above
    // could not fail).
    let mut bare = scene();
    bare.grab(&[11, 8], 50.0).unwrap();
    assert_ne!(run(&mut bare).1, want.1);
    let mut unloaded = loaded();
    unloaded.clear_forces();
    assert_ne!(run(&mut unloaded).1, want.1);
}

#[test]
fn forces_give_the_same_bits_whatever_order_they_are_set_in() {
    let mut direct = scene();
    direct.set_force(4, F3).unwrap();
    direct.set_force(7, F5_LATER).unwrap();
    direct.grab(&[11], 50.0).unwrap();
    let want = run(&mut direct);

    // Set out of node order, replaced, removed (freeing its slot), re-added:
    // the list stays in node order with one entry per loaded node.
    let mut s = scene();
    s.set_force(7, F5).unwrap();
    s.set_force(4, [9.0; 3]).unwrap();
    s.set_force(4, [0.0; 3]).unwrap();
    s.set_force(10, [4.0; 3]).unwrap();
    s.set_force(10, [0.0; 3]).unwrap();
    s.set_force(4, F3).unwrap();
    s.set_force(7, F5_LATER).unwrap();
    s.grab(&[11], 50.0).unwrap();
    assert_eq!(run(&mut s), want);

    // The slot freed by a removal takes a new node, and a rebuild frees all.
    s.set_force(7, [0.0; 3]).unwrap();
    s.set_force(1, F5).unwrap();
    let mut fresh = scene();
    fresh.set_force(1, F5).unwrap();
    fresh.set_force(2, F5).unwrap();
    assert_eq!(
        fresh.set_force(4, F5),
        Err(Error::TooManyLoads { capacity: 2 })
    );
    build(&mut fresh);
    fresh.set_force(4, F5).unwrap();
    fresh.set_force(8, F5).unwrap();
}

#[test]
fn a_scene_without_slots_refuses_every_grab_and_load() {
    let mut s = StaticScene::<NoSlots>::new();
    build(&mut s);
    assert_eq!(
        s.grab(&[3], 10.0),
        Err(Error::TooManyGrabbed {
            count: 1,
            capacity: 0
        })
    );
    assert!(!s.is_grabbing());
    assert_eq!(
        s.set_force(4, [1.0; 3]),
        Err(Error::TooManyLoads { capacity: 0 })
    );
}
