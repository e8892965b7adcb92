//! Benchmark scenes: the same mesh, material, constraints and loads for the
//! f32 core and the f64 reference.

use corofem::VecScene;
use corofem::{BoxMesh, BuildOptions, Material, Method, Preconditioner, Settings};
use corofem_io::{read_mesh, to_core};
use std::path::Path;

use crate::reference::{Model, RefSettings};

/// A scene: mesh, material, fixed nodes, gravity and damping.
#[derive(Clone, Debug)]
pub struct SceneDef {
    /// Short name used in file names and plots.
    pub name: String,
    /// Node positions (m).
    pub nodes: Vec<[f32; 3]>,
    /// Positively oriented tetrahedra.
    pub tets: Vec<[u32; 4]>,
    /// Young's modulus (Pa).
    pub young: f32,
    /// Poisson ratio.
    pub poisson: f32,
    /// Density (kg/m³).
    pub density: f32,
    /// Fixed nodes.
    pub fixed: Vec<u32>,
    /// Gravity (m/s²).
    pub gravity: [f32; 3],
    /// Mass damping (1/s).
    pub rayleigh_mass: f32,
    /// Stiffness damping (s).
    pub rayleigh_stiffness: f32,
}

/// Swaps the last two nodes of negatively oriented tetrahedra (same rule as
/// the core's `BuildOptions::reorient`), so both sides see the same order.
pub fn orient(nodes: &[[f32; 3]], tets: &mut [[u32; 4]]) {
    for t in tets.iter_mut() {
        let p = |k: usize| nodes[t[k] as usize].map(f64::from);
        let (a, b, c, d) = (p(0), p(1), p(2), p(3));
        let e = |x: [f64; 3]| [x[0] - a[0], x[1] - a[1], x[2] - a[2]];
        let (u, v, w) = (e(b), e(c), e(d));
        let det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]);
        if det < 0.0 {
            t.swap(2, 3);
        }
    }
}

/// A generated box `size` (m) of `cells`, 6 tets per cell, clamped at x = 0,
/// gravity along −z.
pub fn boxed(name: &str, size: [f32; 3], cells: [u32; 3], young: f32) -> SceneDef {
    let mesh = BoxMesh {
        size,
        cells,
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0f32; 3]; mesh.node_count()];
    let mut tets = vec![[0u32; 4]; mesh.tet_count()];
    let (n, t) = mesh.generate(&mut nodes, &mut tets).expect("box mesh");
    nodes.truncate(n);
    tets.truncate(t);
    let fixed = (0..n as u32)
        .filter(|&i| nodes[i as usize][0] == 0.0)
        .collect();
    SceneDef {
        name: name.to_owned(),
        nodes,
        tets,
        young,
        poisson: 0.3,
        density: 1000.0,
        fixed,
        gravity: [0.0, 0.0, -9.81],
        rayleigh_mass: 0.0,
        rayleigh_stiffness: 0.0,
    }
}

/// The 1 m × 0.2 m × 0.2 m cantilever of `beam_sag.toml` at a finer
/// resolution (20×4×4 cells, 1920 tets), E = 1e7 Pa, released from rest
/// under gravity; no damping.
pub fn beam() -> SceneDef {
    boxed("beam", [1.0, 0.2, 0.2], [20, 4, 4], 1.0e7)
}

/// A mesh file read and scaled to metres, with its tetrahedra oriented.
pub fn from_file(name: &str, path: &Path, scale: f64) -> SceneDef {
    let mesh = read_mesh(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (nodes, mut tets) = to_core(&mesh, scale);
    orient(&nodes, &mut tets);
    SceneDef {
        name: name.to_owned(),
        nodes,
        tets,
        young: 3.0e4,
        poisson: 0.45,
        density: 1000.0,
        fixed: Vec::new(),
        gravity: [0.0, -9.81, 0.0],
        rayleigh_mass: 1.0,
        rayleigh_stiffness: 0.01,
    }
}

/// SOFA's liver (596 tets) on its three pins, hanging under gravity from
/// rest, with the damping of `examples/scenes/timing_liver.toml`.
pub fn liver(meshes: &Path) -> SceneDef {
    let mut s = from_file("liver", &meshes.join("sofa_liver.tetmesh"), 0.03);
    s.fixed = vec![3, 39, 64];
    s
}

/// The 1k-tet bunny (y up, ~0.2 m) held at its lowest 5 % in y, falling
/// sideways under gravity along −x: it bends over. E = 1e5 Pa.
pub fn bunny(meshes: &Path) -> SceneDef {
    let mut s = from_file("bunny", &meshes.join("bunny_ftw_1k.tetmesh"), 1.0);
    let (lo, hi) = s
        .nodes
        .iter()
        .fold((f32::MAX, f32::MIN), |(l, h), p| (l.min(p[1]), h.max(p[1])));
    let cut = lo + 0.05 * (hi - lo);
    s.fixed = (0..s.nodes.len() as u32)
        .filter(|&i| s.nodes[i as usize][1] <= cut)
        .collect();
    s.young = 1.0e5;
    s.gravity = [-9.81, 0.0, 0.0];
    s.rayleigh_mass = 0.0;
    s.rayleigh_stiffness = 0.0;
    s
}

impl SceneDef {
    /// The material as the core takes it.
    pub fn material(&self) -> Material {
        Material {
            young: self.young,
            poisson: self.poisson,
            density: self.density,
        }
    }

    /// A built core scene with these settings' method, dt and CG budget,
    /// and the paper's CG (the lumped mass, from zero): what the report's
    /// speed-against-error grid, scaling and peer runs measure. The default
    /// solver (`two-level`, warm) is measured against it by
    /// `examples/solver_error.rs` (docs/bench.md, "Preconditioners").
    pub fn core(&self, method: Method, dt: f32, cg_iterations: u32) -> VecScene {
        self.core_with(method, dt, cg_iterations, Preconditioner::Mass)
    }

    /// The same with the preconditioner `pre`, warm-started unless it is the
    /// lumped mass (the paper's CG, from zero).
    pub fn core_with(
        &self,
        method: Method,
        dt: f32,
        cg_iterations: u32,
        pre: Preconditioner,
    ) -> VecScene {
        let mut scene = VecScene::with_capacity(self.nodes.len(), self.tets.len());
        scene
            .build(
                &self.nodes,
                &self.tets,
                &self.material(),
                BuildOptions::default(),
            )
            .expect("build");
        scene.fix_nodes(&self.fixed).expect("fix");
        scene
            .set_settings(Settings {
                method,
                dt,
                cg_iterations,
                cg_tolerance: 0.0,
                rayleigh_mass: self.rayleigh_mass,
                rayleigh_stiffness: self.rayleigh_stiffness,
                warm_start: Settings::with_preconditioner(pre).warm_start,
                preconditioner: pre,
                gravity: self.gravity,
                // As in a default scene.
                energy_guard: true,
                free_rotation: true,
                friction_damping: Settings::new().friction_damping,
                contact_rounds: Settings::new().contact_rounds,
            })
            .expect("settings");
        scene
    }

    /// The f64 reference model of the same scene.
    pub fn reference(&self) -> Model<f64> {
        Model::new(
            &self.nodes,
            &self.tets,
            f64::from(self.young),
            f64::from(self.poisson),
            f64::from(self.density),
            &self.fixed,
        )
    }

    /// Reference settings for time step `dt` (s).
    pub fn ref_settings(&self, dt: f64) -> RefSettings {
        RefSettings {
            dt,
            rayleigh_mass: f64::from(self.rayleigh_mass),
            rayleigh_stiffness: f64::from(self.rayleigh_stiffness),
            gravity: self.gravity.map(f64::from),
            tolerance: 1.0e-12,
        }
    }
}

/// The shared meshes directory (`/work/shared/meshes` or `COROFEM_MESHES`).
pub fn meshes_dir() -> std::path::PathBuf {
    std::env::var_os("COROFEM_MESHES")
        .map(Into::into)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"))
}
