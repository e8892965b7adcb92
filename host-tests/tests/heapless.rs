//! Fixed-capacity lists as firmware keeps them (`heapless::Vec`) go into
//! the API as the slices they dereference to: probes that come and go, and
//! node lists picked by position. Nothing in corofem depends on heapless.

use corofem::{Material, Plane, Probe, Settings, VecScene};
use corofem_host_tests::{box_mesh, penetration, CoreMesh};

/// A soft block, 4 × 4 × 2 cm, its bottom on the ground at z = 0.
fn block() -> (CoreMesh, VecScene) {
    let mesh = box_mesh([0.04, 0.04, 0.02], [8, 8, 4], 6);
    let mut scene = mesh.scene(&Material {
        young: 2.0e4,
        poisson: 0.3,
        density: 1000.0,
    });
    scene.set_ground(Some(Plane::Z_UP)).unwrap();
    scene
        .set_settings(Settings {
            dt: 1e-3,
            rayleigh_mass: 20.0,
            ..scene.default_settings()
        })
        .unwrap();
    (mesh, scene)
}

/// Two fingers press the block, held in a `heapless::Vec`; the first is
/// lifted away by taking it out of the list (which renumbers the second),
/// a third arrives, and a fourth finds the list full. The probe that stays
/// keeps its contact through the renumbering, and no node ends inside any.
#[test]
fn probes_in_a_heapless_vec_come_and_go() {
    let (_, mut scene) = block();
    let radius = 0.006;
    let above = |x: f32, y: f32| [x, y, 0.02 + radius];
    let mut fingers: heapless::Vec<Probe, 3> = heapless::Vec::new();
    for x in [0.01, 0.03] {
        fingers
            .push(Probe::sphere(radius, above(x, 0.02)).unwrap())
            .unwrap();
    }
    let depth = 0.003;
    let h = 1e-3;
    let mut fastest = 0.0f32;
    let mut worst = 0.0f32;
    let mut step = |scene: &mut VecScene, fingers: &mut [Probe]| {
        scene.step_with_probes(fingers).unwrap();
        for v in scene.velocities() {
            fastest = fastest.max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
        }
        for p in fingers.iter() {
            worst = worst.max(penetration(scene, p));
        }
    };
    // Pressed 3 mm over 0.3 s, held 0.2 s.
    for k in 1..=500u32 {
        let z = 0.02 + radius - depth * (k.min(300) as f32 / 300.0);
        for (p, x) in fingers.iter_mut().zip([0.01, 0.03]) {
            p.move_to([x, 0.02, z], [0.0, 0.0, 1.0]).unwrap();
        }
        step(&mut scene, &mut fingers);
    }
    assert!(fingers.iter().all(|p| p.contacts() > 0));
    let pressing = fingers[1].force()[2];
    // The first finger leaves: the second is now the list's first.
    fingers.remove(0);
    let z = 0.02 + radius - depth;
    for _ in 0..200 {
        fingers[0]
            .move_to([0.03, 0.02, z], [0.0, 0.0, 1.0])
            .unwrap();
        step(&mut scene, &mut fingers);
        assert!(fingers[0].contacts() > 0, "the staying finger let go");
    }
    let after = fingers[0].force()[2];
    println!("staying finger: {pressing:.4} N before, {after:.4} N after the other left");
    // It held on: the block, relieved of the other finger, pushes it with
    // a force of the same sign and size (the two presses barely interact
    // 2 cm apart on a 4 cm block).
    assert!(after > 0.5 * pressing && after < 2.0 * pressing);
    // A third finger arrives above the block; a fourth would overflow the
    // list, which says so instead of growing.
    fingers
        .push(Probe::sphere(radius, above(0.02, 0.03)).unwrap())
        .unwrap();
    assert!(fingers
        .push(Probe::sphere(radius, above(0.02, 0.01)).unwrap())
        .is_ok());
    assert!(fingers
        .push(Probe::sphere(radius, above(0.03, 0.03)).unwrap())
        .is_err());
    for _ in 0..50 {
        step(&mut scene, &mut fingers);
    }
    // A node that lands on a finger in a step is inside it by at most how
    // far it moves in that step (plus the rounding of positions of 0.03 m).
    let bound = fastest * h + 1e-8;
    println!("penetration {worst:e} m (bound {bound:e} m)");
    assert!(
        worst <= bound,
        "penetration {worst:e} m against {bound:e} m"
    );
}

/// Node lists picked by position into fixed-capacity vectors: the block's
/// bottom fixed, the nodes under a point grabbed by the tool. A list that
/// would overflow stops at its capacity, and the caller knows.
#[test]
fn node_lists_in_heapless_vecs() {
    let (mesh, mut scene) = block();
    scene.set_ground(None).unwrap();
    let mut bottom: heapless::Vec<u32, 128> = heapless::Vec::new();
    for i in mesh.select(|p| p[2] < 1e-6) {
        bottom.push(i).unwrap(); // 9 × 9 = 81 nodes
    }
    scene.fix_nodes(&bottom).unwrap();
    let mut under: heapless::Vec<u32, 4> = heapless::Vec::new();
    let full = mesh
        .select(|p| {
            p[2] > 0.02 - 1e-6 && (p[0] - 0.02).abs() < 0.006 && (p[1] - 0.02).abs() < 0.006
        })
        .into_iter()
        .any(|i| under.push(i).is_err());
    // 3 × 3 top nodes within 6 mm of the centre: the list keeps 4.
    assert!(full);
    assert_eq!(under.len(), 4);
    scene.grab(&under, 2000.0).unwrap();
    let start = scene.tool_target();
    for _ in 0..300 {
        scene
            .step_haptic([start[0], start[1], start[2] + 0.005])
            .unwrap();
    }
    // The grabbed nodes rose towards the target; the fixed ones did not move.
    for &i in &under {
        let rise = scene.displacement(i).unwrap()[2];
        println!("grabbed node {i} rose {rise:e} m");
        assert!(rise > 1e-3, "node {i} rose {rise} m");
    }
    for &i in &bottom {
        assert_eq!(scene.displacement(i).unwrap(), [0.0; 3]);
    }
}
