//! Resting contacts settle: stiff bodies put down on the ground come to
//! rest on a constant set of contacts, across time steps and friction
//! coefficients, with the default solver. A body that a pressure wave
//! crosses within the step has its contact solved whole
//! (docs/contact.md, "Stiff bodies").

use corofem::{Friction, Material, Plane, Settings, VecScene};
use corofem_host_tests::{box_mesh, shared_mesh, CoreMesh};

const G: f32 = 9.81;

/// Rotates the mesh by `angle` about the y axis and lifts it so that its
/// lowest node is `gap` above the plane z = 0.
fn tilted(mut mesh: CoreMesh, angle: f32, gap: f32) -> CoreMesh {
    let (s, c) = angle.sin_cos();
    for p in &mut mesh.nodes {
        *p = [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]];
    }
    let low = mesh
        .nodes
        .iter()
        .map(|p| p[2])
        .fold(f32::INFINITY, f32::min);
    for p in &mut mesh.nodes {
        p[2] += gap - low;
    }
    mesh
}

/// What a settling run gives: the kinetic energy at the end against the
/// weight's potential scale `M |g| L` (`L` the body's extent), the contact
/// counts over the last half second, the most inverted elements, and the
/// support's vertical part at the end against the weight.
struct Settled {
    kinetic_ratio: f64,
    contacts: (u32, u32),
    inverted: u32,
    support_ratio: f64,
}

fn settle(mesh: &CoreMesh, material: &Material, dt: f32, mu: f32, seconds: f32) -> Settled {
    let mut scene: VecScene = mesh.scene(material);
    scene
        .set_settings(Settings {
            dt,
            gravity: [0.0, 0.0, -G],
            ..Settings::default()
        })
        .unwrap();
    scene.set_ground(Some(Plane::Z_UP)).unwrap();
    scene.set_ground_friction(Friction::coulomb(mu).unwrap());
    let mass: f64 = (0..mesh.nodes.len() as u32)
        .map(|i| f64::from(scene.mass(i).unwrap()))
        .sum();
    let extent = (0..3)
        .map(|k| {
            let (lo, hi) = mesh.nodes.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| {
                (lo.min(p[k]), hi.max(p[k]))
            });
            f64::from(hi - lo).powi(2)
        })
        .sum::<f64>()
        .sqrt();
    let steps = (seconds / dt).round() as u32;
    let last = (0.5 / dt).round() as u32;
    let (mut lo, mut hi, mut inverted) = (u32::MAX, 0u32, 0u32);
    let mut support = 0.0f64;
    for k in 0..steps {
        let stats = scene.step().unwrap();
        inverted = inverted.max(stats.inverted);
        if k + last >= steps {
            lo = lo.min(stats.contacts);
            hi = hi.max(stats.contacts);
        }
        support = f64::from(stats.support_force[2]);
    }
    let weight = mass * f64::from(G);
    Settled {
        kinetic_ratio: f64::from(scene.kinetic_energy()) / (weight * extent),
        contacts: (lo, hi),
        inverted,
        support_ratio: support / weight,
    }
}

/// A body at rest: kinetic energy below 1e-8 of `M |g| L` (for the bunny,
/// a speed of about 1e-4 √(g L): 0.1 mm/s), the same contacts in every
/// step of the last half second, no element inverted, and the support the
/// weight to 1e-3 (the sweeps' tolerance on each impulse is 1e-6 of the
/// weight's over the step, summed over a few rows; 1e-3 leaves the
/// rounding of the rigid motion's sums room).
fn assert_rests(what: &str, s: &Settled) {
    eprintln!(
        "    {what}: kinetic {:.2e} of M g L, contacts {}..{} over the last 0.5 s, {} inverted, support {:.5} of the weight",
        s.kinetic_ratio, s.contacts.0, s.contacts.1, s.inverted, s.support_ratio
    );
    assert!(
        s.kinetic_ratio < 1e-8,
        "{what}: kinetic energy {:e} of M g L",
        s.kinetic_ratio
    );
    assert_eq!(
        s.contacts.0, s.contacts.1,
        "{what}: the contact set changes"
    );
    assert!(s.contacts.0 >= 3, "{what}: rests on {} nodes", s.contacts.0);
    assert_eq!(s.inverted, 0, "{what}: inverted elements");
    assert!(
        (s.support_ratio - 1.0).abs() < 1e-3,
        "{what}: support {} of the weight",
        s.support_ratio
    );
}

/// The stiff, nearly incompressible bunny (E 100 MPa, ν 0.49) put down on
/// its curved side 1 mm above the ground comes to rest on a few points
/// within 1 s, at dt 1, 5 and 10 ms and μ 0.3, 0.5 and 1.0.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn a_stiff_bunny_settles_on_its_side() {
    // The mesh is y up: turned a quarter about x, it lies on its side.
    let mut mesh = shared_mesh("bunny_ftw_3k.tetmesh");
    for p in &mut mesh.nodes {
        *p = [p[0], -p[2], p[1]];
    }
    let mesh = tilted(mesh, 0.0, 1e-3);
    let material = Material {
        young: 1.0e8,
        poisson: 0.49,
        density: 1000.0,
    };
    for dt in [1e-3, 5e-3, 1e-2] {
        for mu in [0.3, 0.5, 1.0] {
            let s = settle(&mesh, &material, dt, mu, 1.5);
            assert_rests(&format!("bunny, dt {dt}, μ {mu}"), &s);
        }
    }
}

/// The stiff bunny of `examples/scenes/bunny_side_drop_stiff.toml` dropped
/// 0.3 m onto its side with friction lands, turns over and comes to rest,
/// with no element inverted on the way.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn a_stiff_bunny_dropped_with_friction_comes_to_rest() {
    let mut mesh = shared_mesh("bunny_ftw_3k.tetmesh");
    for p in &mut mesh.nodes {
        *p = [p[0], -p[2], p[1]];
    }
    let mesh = tilted(mesh, 0.0, 0.3);
    let material = Material {
        young: 1.0e8,
        poisson: 0.49,
        density: 1000.0,
    };
    for mu in [0.5, 1.0] {
        let s = settle(&mesh, &material, 1e-2, mu, 4.0);
        assert_rests(&format!("dropped bunny, μ {mu}"), &s);
    }
}

/// A stiff block (4 × 4 × 2 cm, E 10 MPa) put down on one edge, tilted by
/// 30°, falls onto its face and comes to rest there, at dt 1 and 5 ms, on
/// both meshes of cells, μ 0.5 and 1.0.
#[test]
fn a_stiff_block_put_down_on_an_edge_settles() {
    let material = Material {
        young: 1.0e7,
        poisson: 0.3,
        density: 1000.0,
    };
    for tets_per_cell in [5, 6] {
        let mesh = tilted(
            box_mesh([0.04, 0.04, 0.02], [4, 4, 2], tets_per_cell),
            30f32.to_radians(),
            0.0,
        );
        for dt in [1e-3, 5e-3] {
            for mu in [0.5, 1.0] {
                let s = settle(&mesh, &material, dt, mu, 1.5);
                assert_rests(
                    &format!("block of {tets_per_cell}-tet cells, dt {dt}, μ {mu}"),
                    &s,
                );
            }
        }
    }
}
