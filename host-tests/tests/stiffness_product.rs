//! `Scene::stiffness_product`, the operator CG iterates on, against the
//! derivative of the elastic forces on real meshes: at rest the tangent
//! stiffness has no geometric term, so `−K d = d f(x + s d)/ds` at `s = 0`.

use corofem::{Error, Material, Method, Parameter};
use corofem_host_tests::{shared_mesh, Rng};

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn equals_the_force_derivative_at_rest_on_real_meshes() {
    for name in ["liver_ftw_3k.tetmesh", "bunny_ftw_1k.tetmesh"] {
        let mesh = shared_mesh(name);
        let material = Material {
            young: 1.0e5,
            poisson: 0.4,
            density: 1000.0,
        };
        let n = mesh.nodes.len();
        // Displacement direction: random components in [−1, 1) m; the
        // difference quotient below moves the nodes by eps times that.
        let mut rng = Rng::new(11);
        let d: Vec<[f32; 3]> = (0..n).map(|_| rng.vec3(1.0)).collect();
        for method in [Method::Qr, Method::Polar, Method::Linear] {
            let mut scene = mesh.scene(&material);
            scene.set_method(method).unwrap();
            let mut kd = vec![[0.0f32; 3]; n];
            scene.stiffness_product(&d, &mut kd).unwrap();
            // Central difference of the forces along d, with a step small
            // against the mesh (its edges are of order 1e-2 m or more).
            let eps = 1.0e-5f32;
            let mut fp = vec![[0.0f32; 3]; n];
            let mut fm = vec![[0.0f32; 3]; n];
            let shifted = |s: f32| d.iter().map(|v| v.map(|c| c * s)).collect::<Vec<_>>();
            scene.set_displacements(&shifted(eps)).unwrap();
            scene.elastic_forces(&mut fp).unwrap();
            scene.set_displacements(&shifted(-eps)).unwrap();
            scene.elastic_forces(&mut fm).unwrap();
            let (mut err2, mut ref2) = (0.0f64, 0.0f64);
            for i in 0..n {
                for c in 0..3 {
                    let fd = (f64::from(fp[i][c]) - f64::from(fm[i][c])) / (2.0 * f64::from(eps));
                    err2 += (fd - f64::from(kd[i][c])).powi(2);
                    ref2 += f64::from(kd[i][c]).powi(2);
                }
            }
            let rel = (err2 / ref2).sqrt();
            eprintln!("{name} {method:?}: |fd − (−K d)| / |K d| = {rel:.2e}");
            // The difference quotient carries f32 round-off of forces of
            // size ~|K| |x| divided by eps·|K d|: about 1e-7 · |x| / eps with
            // |x| ~ 0.1–1 m, so up to ~1e-2; O(eps²) truncation is far below.
            // A wrong sign, a missing term or a wrong factor gives O(1).
            assert!(rel < 2e-2, "{name} {method:?}: {rel}");
        }
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn refuses_bad_input_and_leaves_the_state_alone() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    let material = Material {
        young: 3.0e4,
        poisson: 0.45,
        density: 1000.0,
    };
    let mut scene = mesh.scene(&material);
    let n = mesh.nodes.len();
    let before = scene.state_hash();
    let mut out = vec![[0.0f32; 3]; n];
    let mut d = vec![[1.0f32; 3]; n];
    let bad = |parameter| Err(Error::InvalidParameter { parameter });
    assert_eq!(
        scene.stiffness_product(&d[..n - 1], &mut out),
        bad(Parameter::ProductInput)
    );
    assert_eq!(
        scene.stiffness_product(&d, &mut out[..n - 1]),
        bad(Parameter::ProductOut)
    );
    d[3][1] = f32::NAN;
    assert_eq!(
        scene.stiffness_product(&d, &mut out),
        bad(Parameter::ProductInput)
    );
    d[3][1] = 1.0;
    // A uniform translation has no elastic response: K d = 0 exactly.
    scene.stiffness_product(&d, &mut out).unwrap();
    assert!(out.iter().all(|v| *v == [0.0; 3]));
    assert_eq!(scene.state_hash(), before);
}
