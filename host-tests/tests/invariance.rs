//! Rotational invariance: a rigidly rotated body has no elastic force, and a
//! loaded beam rotated by an arbitrary rotation deflects exactly as the
//! rotated unrotated one.

use corofem::{Material, Method, Settings, StaticSettings};
use corofem_host_tests::{box_mesh, f64v, shared_mesh, CoreMesh};

/// Largest nodal force (N) with the body at `positions`.
fn max_force(mesh: &CoreMesh, method: Method, positions: &[[f32; 3]]) -> f64 {
    let mut scene = mesh.scene(&Material {
        young: 1.0e5,
        poisson: 0.3,
        density: 1000.0,
    });
    scene.set_method(method).unwrap();
    scene.set_positions(positions).unwrap();
    let mut f = vec![[0.0f32; 3]; mesh.nodes.len()];
    scene.elastic_forces(&mut f).unwrap();
    f.iter()
        .map(|v| f64v::norm(f64v::up(*v)))
        .fold(0.0, f64::max)
}

fn transformed(mesh: &CoreMesh, r: &[[f64; 3]; 3], scale: f64) -> Vec<[f32; 3]> {
    mesh.nodes
        .iter()
        .map(|p| {
            let q = f64v::rot(r, f64v::up(*p));
            [
                (scale * q[0]) as f32,
                (scale * q[1]) as f32,
                (scale * q[2]) as f32,
            ]
        })
        .collect()
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn rigid_rotation_has_no_elastic_force() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    // Reference: the forces of a uniform 1% stretch.
    let reference = max_force(&mesh, Method::Qr, &transformed(&mesh, &identity, 1.01));
    for (axis, angle) in [
        ([0.0, 0.0, 1.0], 0.7),
        ([0.6, 0.0, 0.8], 2.5),
        ([0.48, 0.6, 0.64], -1.9),
    ] {
        let r = f64v::rotation(axis, angle);
        let x = transformed(&mesh, &r, 1.0);
        for method in [Method::Qr, Method::Polar, Method::QrRestB] {
            let f = max_force(&mesh, method, &x);
            eprintln!(
                "rotation {angle} rad, {method:?}: max |f| = {f:.3e} N, {:.2e} of a 1% stretch",
                f / reference
            );
            // Rotating the coordinates in f64 and rounding to f32 moves each
            // node by ≤ ε|x| ≈ 1e-6 (|x| ≲ 6); over ~0.5 long edges that is a
            // strain of ~2e-6, i.e. 2e-4 of the 1% stretch. Bound: 1e-3.
            assert!(f < 1e-3 * reference, "{method:?}: {f} vs {reference}");
        }
        // Without co-rotation, a rotation is a huge strain.
        let f = max_force(&mesh, Method::Linear, &x);
        assert!(
            f > 10.0 * reference,
            "Linear should not be invariant: {f} vs {reference}"
        );
    }
}

/// Static cantilever under gravity, soft enough to sag by ~4% of its length
/// (Euler–Bernoulli: qL⁴/8EI = 2452·4⁴/(8·1e8·0.0052) = 0.15 m; the coarse
/// linear tetrahedra are stiffer and sag about half of that); returns the
/// displacement field.
fn sag(mesh: &CoreMesh, r: &[[f64; 3]; 3], method: Method) -> Vec<[f64; 3]> {
    let rotated = CoreMesh {
        nodes: transformed(mesh, r, 1.0),
        tets: mesh.tets.clone(),
    };
    let mut scene = rotated.scene(&Material {
        young: 1.0e8,
        poisson: 0.3,
        density: 1000.0,
    });
    let g = f64v::rot(r, [0.0, 0.0, -9.81]);
    scene
        .set_settings(Settings {
            method,
            gravity: [g[0] as f32, g[1] as f32, g[2] as f32],
            ..Settings::default()
        })
        .unwrap();
    scene.fix_nodes(&mesh.select(|p| p[0] <= 1e-6)).unwrap();
    let cfg = StaticSettings {
        max_iterations: 60,
        cg_iterations: 600,
        ..StaticSettings::default()
    };
    let last = scene.solve_static(&cfg, |_| {}).unwrap();
    assert!(last.converged, "{last:?}");
    (0..mesh.nodes.len() as u32)
        .map(|i| f64v::up(scene.displacement(i).unwrap()))
        .collect()
}

#[test]
fn rotated_beam_deflects_as_the_rotated_unrotated_one() {
    let mesh = box_mesh([4.0, 0.5, 0.5], [16, 2, 2], 6);
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let r = f64v::rotation([0.48, 0.6, 0.64], 2.1);
    for method in [Method::Qr, Method::Polar] {
        let base = sag(&mesh, &identity, method);
        let turned = sag(&mesh, &r, method);
        let tip = base.iter().map(|u| f64v::norm(*u)).fold(0.0, f64::max);
        let err = base
            .iter()
            .zip(&turned)
            .map(|(u, v)| {
                let ru = f64v::rot(&r, *u);
                f64v::norm([ru[0] - v[0], ru[1] - v[1], ru[2] - v[2]])
            })
            .fold(0.0, f64::max);
        eprintln!("{method:?}: tip deflection {tip:.4} m, largest difference from the rotated solution {err:.2e} m ({:.2e} relative)", err / tip);
        assert!(tip > 0.05, "the beam must bend visibly: {tip}");
        // Both solves stop when an update is below 1e-4 of the displacement
        // (StaticSettings::update_tolerance), so they agree to about that.
        assert!(err < 1e-3 * tip, "{method:?}: {err} vs {tip}");
    }
}
