//! A scene in a `static`: `StaticScene::new` is a `const fn` whose value is
//! all zero bits, so that on a microcontroller the scene lands in `.bss`
//! and costs no flash (`.ci/firmware.sh` checks the firmware's sections).
//! Its settings read as the defaults for its storage until set (the
//! paper's CG: it has no preconditioner slots), and it steps with them.

use std::sync::Mutex;

use corofem::{Capacity, Error, Preconditioner, Settings, Slots, StaticScene};
use corofem_host_tests::build_box;

corofem::capacity! {
    /// A 2×2×2-cell block (27 nodes, 48 tetrahedra), 4 grab slots.
    struct BlockSlots { nodes: 27, elements: 48, grabs: 4 }
}
/// The block's scene.
type Block = StaticScene<BlockSlots>;

static SCENE: Mutex<Block> = Mutex::new(Block::new());

/// Builds the block into `s` and holds its face `x = 0`.
fn build(s: &mut Block) {
    build_box(s, [0.2, 0.2, 0.2], [2, 2, 2]);
    let face: Vec<u32> = (0..27)
        .filter(|&i| s.rest_position(i).is_some_and(|p| p[0] == 0.0))
        .collect();
    assert_eq!(face.len(), 9);
    s.fix_nodes(&face).unwrap();
}

#[test]
fn a_static_scene_holds_what_its_capacity_declares() {
    let scene = SCENE.lock().unwrap();
    // Whole element blocks: 48 rounded up to a multiple of the lanes.
    let elements = corofem::element_blocks(48) * corofem::ELEMENTS_PER_BLOCK;
    let want = Slots {
        elements,
        ..BlockSlots::SLOTS
    };
    assert_eq!(scene.capacity(), want);
    assert_eq!(
        (scene.node_capacity(), scene.element_capacity()),
        (27, elements)
    );
    assert!(!scene.supports(Preconditioner::BlockJacobi));
}

#[test]
fn a_static_scene_has_the_default_settings_and_steps_with_them() {
    let mut scene = SCENE.lock().unwrap();
    let defaults = Settings::with_preconditioner(Preconditioner::Mass);
    assert_eq!(scene.default_settings(), defaults);
    assert_eq!(*scene.settings(), defaults);
    build(&mut scene);
    assert_eq!(*scene.settings(), defaults);

    let mut given = Box::new(Block::new());
    build(&mut given);
    // The solver's own default preconditioner needs slots this storage
    // does not have: refused, by name.
    if Preconditioner::DEFAULT != Preconditioner::Mass {
        assert_eq!(
            given.set_settings(Settings::default()),
            Err(Error::PreconditionerUnavailable {
                preconditioner: Preconditioner::DEFAULT
            })
        );
    }
    given.set_settings(defaults).unwrap();
    for _ in 0..10 {
        scene.step().unwrap();
        given.step().unwrap();
    }
    assert_eq!(scene.state_hash(), given.state_hash());
    assert_eq!(scene.time(), given.time());
    assert!(scene.time() > 0.0);
    // The body sagged: the steps used a non-zero time step and gravity.
    assert!(scene.displacement(26).unwrap()[2] < 0.0);
}
