//! The f64 reference integrator against the f32 core with converged CG: the
//! trajectories agree to f32 level.

use corofem::Method;
use corofem_bench::scenes;

#[test]
fn reference_matches_the_core_with_converged_cg() {
    // 10×2×2 cells, 240 tets, soft enough to swing visibly in 50 ms.
    let s = scenes::boxed("beam", [1.0, 0.2, 0.2], [10, 2, 2], 1.0e6);
    let dt = 1.0e-3;
    let mut core = s.core(Method::Qr, dt as f32, 2000);
    let mut reference = s.reference();
    let rs = s.ref_settings(dt);
    let (mut err2, mut ref2) = (0.0f64, 0.0f64);
    for _ in 0..50 {
        core.step().unwrap();
        let st = reference.step(&rs);
        assert!(st.residual <= 1e-12, "{st:?}");
        for (i, p) in core.positions().enumerate() {
            let r = reference.position(i);
            let u = reference.u[i];
            for c in 0..3 {
                err2 += (f64::from(p[c]) - r[c]).powi(2);
                ref2 += u[c] * u[c];
            }
        }
    }
    let rel = (err2 / ref2).sqrt();
    eprintln!("relative RMS position error {rel:.3e}");
    // Tip sag after 50 ms is ~1e-2 m: the reference must move.
    assert!(ref2 > 0.0);
    // f32 state and an f32 CG stopped at its ε floor: ~1e-6..1e-5.
    assert!(rel < 1e-4, "relative RMS error {rel}");
}
