//! QR vertex-order anisotropy: the QR frame is built from the edges a→b and
//! a→c, so a co-rotated element's response under large deformation depends
//! on which of its nodes is called `a` (the paper's section 4 admits it).
//! The same beam is bent far into the nonlinear range with every tetrahedron's
//! nodes listed in other (orientation-preserving) orders, and the settled
//! shapes are compared. `Polar` and `Linear` do not depend on the order and
//! give the round-off floor the QR figure is read against.

use corofem::{Material, Method, Settings};
use corofem_host_tests::{shared_mesh, CoreMesh};

/// Even permutations of `(a, b, c, d)`: a 3-cycle and two double
/// transpositions. They keep every element positively oriented.
const ORDERS: [[usize; 4]; 3] = [[1, 2, 0, 3], [1, 0, 3, 2], [3, 2, 1, 0]];

/// Settled displacements (m) of the 10 m × 2 m × 2 m beam clamped at x = 0,
/// sagging under gravity by about 30% of its length (E = 1e7 Pa).
fn settled(mesh: &CoreMesh, method: Method) -> Vec<[f32; 3]> {
    corofem_host_tests::progress(
        "anisotropy",
        format_args!(
            "{method:?}: 400 converged steps of a bent beam of {} tets",
            mesh.tets.len()
        ),
    );
    let material = Material {
        young: 1.0e7,
        poisson: 0.3,
        density: 1000.0,
    };
    let mut s = mesh.scene(&material);
    s.fix_nodes(&mesh.select(|p| p[0] <= 1e-6)).unwrap();
    s.set_settings(Settings {
        method,
        dt: 0.02,
        // Each implicit step solved to 1e-6: what remains of the order
        // dependence is the method's, not a truncated CG's.
        cg_iterations: 400,
        cg_tolerance: 1e-6,
        // Critically damps the first bending mode (ω₁ = 3.52 √(EI/ρAL⁴) ≈
        // 2 rad/s: α_M = 2ω₁), so 8 s (16 time constants) settle it to far
        // below the differences measured.
        rayleigh_mass: 4.0,
        gravity: [0.0, 0.0, -9.81],
        ..Settings::default()
    })
    .unwrap();
    for _ in 0..400 {
        s.step().unwrap();
    }
    (0..mesh.nodes.len() as u32)
        .map(|i| s.displacement(i).unwrap())
        .collect()
}

/// RMS of `a − b` over RMS of `a`.
fn relative_rms(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let sq = |v: [f64; 3]| v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let (mut diff, mut norm) = (0.0, 0.0);
    for (p, q) in a.iter().zip(b) {
        diff += sq([0, 1, 2].map(|c| f64::from(p[c]) - f64::from(q[c])));
        norm += sq(p.map(f64::from));
    }
    (diff / norm).sqrt()
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn qr_anisotropy_under_large_bending_is_measured_and_small() {
    let mesh = shared_mesh("beam_10x2x2_h05_t6.tetmesh");
    for method in [Method::Qr, Method::Polar, Method::Linear] {
        let base = settled(&mesh, method);
        let tip = base.iter().map(|u| -u[2]).fold(0.0f32, f32::max);
        let mut worst = 0.0f64;
        for order in ORDERS {
            let permuted = CoreMesh {
                nodes: mesh.nodes.clone(),
                tets: mesh.tets.iter().map(|t| order.map(|k| t[k])).collect(),
            };
            worst = worst.max(relative_rms(&base, &settled(&permuted, method)));
        }
        println!("ANISOTROPY {method:?}: tip sag {tip:.3} m, vertex-order difference {worst:.2e} (relative RMS)");
        let bound = match method {
            // Order-independent methods: only f32 round-off (ε = 1.2e-7) in
            // other summation orders, carried through 400 steps each solved
            // to 1e-6 relative (measured 2e-7 polar, 3e-8 linear); 1e-5 is
            // far above that and far below QR's figure.
            Method::Polar | Method::Linear => 1e-5,
            // QR: the order changes the element rotations themselves
            // (measured 3.5e-3). The product's claim: under 1% at 30% sag.
            _ => 1e-2,
        };
        assert!(worst < bound, "{method:?}: {worst:e}");
        assert!(
            tip > 2.0,
            "the beam must bend far into the nonlinear range: {tip} m"
        );
    }
}
