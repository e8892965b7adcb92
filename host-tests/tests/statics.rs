//! Static sag of a cantilever against an independent linear FEM solution
//! (scikit-fem, host-tests/reference) and Euler–Bernoulli theory.

use corofem::{Material, Settings, StaticSettings};
use corofem_host_tests::shared_mesh;

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/reference/cantilever_reference.json"
    ))
    .unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Mean z-displacement of the free end under gravity (m).
fn tip_sag(mesh_name: &str) -> Option<f64> {
    let mesh = shared_mesh(&format!("{mesh_name}.tetmesh"))?;
    let material = Material {
        young: 1.0e9,
        poisson: 0.3,
        density: 1000.0,
    };
    let mut scene = mesh.scene(&material);
    scene.fix_nodes(&mesh.select(|p| p[0] <= 1e-6)).unwrap();
    scene
        .set_settings(Settings {
            gravity: [0.0, 0.0, -9.81],
            ..Settings::default()
        })
        .unwrap();
    let last = scene
        .solve_static(&StaticSettings::default(), |it| {
            eprintln!("{mesh_name}: {it:?}")
        })
        .unwrap();
    assert!(last.converged, "{mesh_name}: {last:?}");
    let tip = mesh.select(|p| p[0] >= 10.0 - 1e-6);
    Some(
        tip.iter()
            .map(|&i| scene.displacement(i as usize).unwrap()[2] as f64)
            .sum::<f64>()
            / tip.len() as f64,
    )
}

#[test]
fn cantilever_sag_matches_linear_fem() {
    let r = reference();
    for name in [
        "beam_10x2x2_h1_t6",
        "beam_10x2x2_h1_t5",
        "beam_10x2x2_h05_t6",
        "beam_10x2x2_h05_t5",
        "beam_10x2x2_h025_t6",
    ] {
        let Some(sag) = tip_sag(name) else { return };
        let want = r["meshes"][name]["gravity"]["tip_uz_mean"]
            .as_f64()
            .unwrap();
        let rel = (sag - want).abs() / want.abs();
        eprintln!(
            "{name}: corofem {sag:.6e}, scikit-fem {want:.6e}, relative difference {rel:.2e}"
        );
        assert!(rel < 1e-3, "{name}: {rel}");
    }
}
