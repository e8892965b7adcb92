//! Scene building from raw bytes: arbitrary nodes (any f32, NaN included),
//! arbitrary indices, materials and options. `build` either succeeds with a
//! usable scene (positive finite masses and volumes, the rest shape an exact
//! equilibrium) or fails and leaves the previous scene exactly as it was.
//! A built scene then takes a few steps with arbitrary settings, which must
//! stay finite or be refused with the state unchanged.

#![no_main]

mod common;

use arbitrary::{Result, Unstructured};
use corofem::{BuildOptions, Settings, StaticScene};
use libfuzzer_sys::fuzz_target;

const N: usize = 16;
/// Element capacity: 12 rounded up to whole blocks (16 on x86_64).
const T: usize = corofem::element_blocks(12) * corofem::ELEMENTS_PER_BLOCK;
/// Grab and load slots: fewer than the nodes, so that full lists are fuzzed too.
const SLOTS: usize = 4;
corofem::capacity! {
    /// The fuzzed scene's room.
    struct SmallSlots { nodes: N, elements: T, grabs: SLOTS, loads: SLOTS }
}
type Small = StaticScene<SmallSlots>;

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});

/// A built, stepped unit tetrahedron: what a failed build must leave alone.
fn previous() -> Small {
    let mut s = Small::new();
    let nodes = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    s.build(
        &nodes,
        &[[0, 1, 2, 3]],
        &corofem::Material::default(),
        BuildOptions::default(),
    )
    .unwrap();
    s.fix_nodes(&[0]).unwrap();
    s.step().unwrap();
    s
}

fn node(u: &mut Unstructured, earlier: &[[f32; 3]]) -> Result<[f32; 3]> {
    Ok(match u.int_in_range(0u8..=4)? {
        // On a coarse grid: exact duplicates and coplanar faces.
        0 => [0; 3].map(|_| f32::from(u.arbitrary::<i8>().unwrap_or(0) % 4) * 0.5),
        // A copy of an earlier node, perhaps nudged.
        1 if !earlier.is_empty() => {
            let p = *u.choose(earlier)?;
            let eps = common::finite(u)? * 1e-6;
            [p[0] + eps, p[1], p[2]]
        }
        2 => common::any3(u)?,
        _ => common::finite3(u)?,
    })
}

fn run(u: &mut Unstructured) -> Result<()> {
    let n = u.int_in_range(0..=N + 1)?;
    let mut nodes = Vec::with_capacity(n);
    for _ in 0..n {
        let p = node(u, &nodes)?;
        nodes.push(p);
    }
    let t = u.int_in_range(0..=T + 1)?;
    let mut tets = Vec::with_capacity(t);
    for _ in 0..t {
        let mut tet = [0u32; 4];
        for i in &mut tet {
            *i = if u.ratio(1u8, 50)? {
                u.arbitrary()?
            } else {
                u32::from(u.arbitrary::<u8>()?) % (n as u32 + 1)
            };
        }
        tets.push(tet);
    }
    let material = common::material(u)?;
    let options = BuildOptions {
        reorient: u.arbitrary()?,
    };

    let before = previous();
    let mut s = before.clone();
    match s.build(&nodes, &tets, &material, options) {
        Err(e) => {
            assert!(!e.to_string().is_empty());
            assert!(
                common::fingerprint(&s) == common::fingerprint(&before),
                "{e:?} changed the scene"
            );
            assert!(common::same_future(&s, &before), "{e:?} changed the future");
            return Ok(());
        }
        Ok(()) => {
            assert_eq!((s.node_count(), s.element_count()), (n, t));
            for i in 0..n as u32 {
                let m = s.mass(i).unwrap();
                assert!(m > 0.0 && m.is_finite(), "node {i} mass {m}");
            }
            for e in 0..t {
                let v = s.rest_volume(e).unwrap();
                assert!(v > 0.0 && v.is_finite(), "element {e} volume {v}");
            }
            // The rest shape is an exact equilibrium.
            s.set_settings(Settings {
                gravity: [0.0; 3],
                ..s.default_settings()
            })
            .unwrap();
            let rest = s.state_hash();
            let r = s.step();
            assert!(r.is_ok(), "step from rest: {r:?}");
            assert_eq!(s.state_hash(), rest, "the rest shape moved by itself");
        }
    }
    // Arbitrary settings and loads, then steps.
    if let Ok(settings) = common::settings(u) {
        let _ = s.set_settings(settings);
    }
    for _ in 0..u.int_in_range(0u8..=3)? {
        let i = u.int_in_range(0..=(n - 1) as u32)?;
        let _ = s.set_force(i, common::any3(u)?);
    }
    for _ in 0..u.int_in_range(0u8..=8)? {
        let before = common::fingerprint(&s);
        match s.step() {
            Ok(stats) => {
                assert!(common::all_finite(&s), "a step produced a non-finite state");
                assert!(
                    stats.cg_residual.is_finite() && stats.tool_force.iter().all(|x| x.is_finite())
                );
            }
            Err(e) => assert!(common::fingerprint(&s) == before, "{e:?} changed the state"),
        }
    }
    Ok(())
}
