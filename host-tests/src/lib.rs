//! Shared helpers for the host tests: the shared meshes, generated boxes and
//! small f64 vector maths for checking. Big scenes go in the core's
//! `VecScene`.

use std::path::PathBuf;

use corofem::{BoxMesh, BuildOptions, Material, Scene, Storage, VecScene};

pub mod reliability;

/// A progress line for a test that runs for many seconds: written to the
/// terminal's stderr directly, so it shows while the test harness captures
/// the test's own output (`cargo test` shows nothing else until the test
/// ends). `what` says what the test is doing, `test` which test it is.
pub fn progress(test: &str, what: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr().lock(), "    {test}: {what}");
}

/// A mesh in the core's input form.
#[derive(Clone, Debug)]
pub struct CoreMesh {
    /// Node positions (m).
    pub nodes: Vec<[f32; 3]>,
    /// Tetrahedra.
    pub tets: Vec<[u32; 4]>,
}

impl CoreMesh {
    /// Builds a scene of exactly this mesh's size.
    pub fn scene(&self, material: &Material) -> VecScene {
        let mut s = VecScene::with_capacity(self.nodes.len(), self.tets.len());
        s.build(&self.nodes, &self.tets, material, BuildOptions::default())
            .expect("valid mesh");
        s
    }

    /// Indices of the nodes for which `pred(position)` holds.
    pub fn select(&self, pred: impl Fn([f32; 3]) -> bool) -> Vec<u32> {
        (0..self.nodes.len() as u32)
            .filter(|&i| pred(self.nodes[i as usize]))
            .collect()
    }
}

/// The shared mesh folder, if present (`../shared/meshes` from the workspace).
pub fn shared_meshes() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    dir.is_dir().then_some(dir)
}

/// Loads a shared mesh by file name.
///
/// A test that needs one is marked
/// `#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]`: the
/// build script sets `shared_meshes` when the folder exists, so without it
/// `cargo test` lists those tests as ignored, with the reason. Run anyway
/// (`--ignored`), this panics naming the missing folder.
pub fn shared_mesh(name: &str) -> CoreMesh {
    let dir = shared_meshes().expect("this test needs ../shared/meshes");
    let mesh = corofem_io::read_mesh(&dir.join(name)).expect("shared mesh reads");
    CoreMesh {
        nodes: mesh
            .nodes
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
            .collect(),
        tets: mesh
            .tets
            .iter()
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32, t[3] as u32])
            .collect(),
    }
}

/// The largest depth of any boundary node inside `probe` (m, 0 when none
/// is inside).
pub fn penetration(scene: &VecScene, probe: &corofem::Probe) -> f32 {
    (0..scene.node_count() as u32)
        .filter(|&i| scene.on_boundary(i))
        .map(|i| -probe.distance(scene.position(i).unwrap_or([0.0; 3])))
        .fold(0.0, f32::max)
}

/// A generated box mesh.
pub fn box_mesh(size: [f32; 3], cells: [u32; 3], tets_per_cell: u8) -> CoreMesh {
    let b = BoxMesh {
        size,
        cells,
        tets_per_cell,
    };
    let mut nodes = vec![[0.0; 3]; b.node_count()];
    let mut tets = vec![[0; 4]; b.tet_count()];
    b.generate(&mut nodes, &mut tets).expect("valid box");
    CoreMesh { nodes, tets }
}

/// Builds a generated box (6 tetrahedra per cell, the default material and
/// options) into `scene`.
pub fn build_box<S: Storage>(scene: &mut Scene<S>, size: [f32; 3], cells: [u32; 3]) {
    let mesh = box_mesh(size, cells, 6);
    scene
        .build(
            &mesh.nodes,
            &mesh.tets,
            &Material::default(),
            BuildOptions::default(),
        )
        .expect("valid box");
}

/// f64 helpers for checks.
pub mod f64v {
    /// `a × b`.
    pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    /// `a − b`.
    pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    /// `|a|`.
    pub fn norm(a: [f64; 3]) -> f64 {
        (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
    }
    /// f32 → f64.
    pub fn up(a: [f32; 3]) -> [f64; 3] {
        [a[0] as f64, a[1] as f64, a[2] as f64]
    }
    /// Rotation matrix (rows) of angle `angle` (rad) about the unit axis `a`.
    pub fn rotation(a: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        let [x, y, z] = a;
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    }
    /// `R v`.
    pub fn rot(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        [
            r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
            r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
            r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
        ]
    }
}

/// Net force `Σ f` and net torque `Σ x × f` (about the origin) in f64, and
/// the scale `Σ |f|` and `Σ |x| |f|` they should be compared with.
pub fn net_force_torque(
    positions: &[[f32; 3]],
    forces: &[[f32; 3]],
) -> ([f64; 3], [f64; 3], f64, f64) {
    let (mut f, mut t, mut fs, mut ts) = ([0.0f64; 3], [0.0f64; 3], 0.0, 0.0);
    for (x, fi) in positions.iter().zip(forces) {
        let (x, fi) = (f64v::up(*x), f64v::up(*fi));
        let c = f64v::cross(x, fi);
        for k in 0..3 {
            f[k] += fi[k];
            t[k] += c[k];
        }
        fs += f64v::norm(fi);
        ts += f64v::norm(x) * f64v::norm(fi);
    }
    (f, t, fs, ts)
}

/// A small deterministic pseudo-random generator (xorshift64*), so tests need
/// no extra crate and give the same numbers everywhere.
pub struct Rng(u64);

impl Rng {
    /// Seeded generator.
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    /// Uniform in `[0, 1)`.
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
    /// An f32 vector with components uniform in `[−half, half)`.
    pub fn vec3(&mut self, half: f64) -> [f32; 3] {
        [
            self.range(-half, half) as f32,
            self.range(-half, half) as f32,
            self.range(-half, half) as f32,
        ]
    }
    /// A random unit vector.
    pub fn unit(&mut self) -> [f64; 3] {
        loop {
            let v = [
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            ];
            let n = f64v::norm(v);
            if n > 0.1 && n <= 1.0 {
                return [v[0] / n, v[1] / n, v[2] / n];
            }
        }
    }
}

/// A smooth surface over a mesh: its boundary Loop-subdivided `levels`
/// times. Convex parts of the limit surface lie inside the tetrahedra and
/// concave ones outside, so it has vertices of both kinds; each level has
/// four times the triangles.
pub fn smooth_surface(mesh: &CoreMesh, levels: u32) -> corofem_io::Surface {
    let mut s = corofem_io::boundary_surface(&mesh.nodes, &mesh.tets).expect("valid mesh");
    for _ in 0..levels {
        s = corofem_io::loop_subdivide(&s).expect("indices in range");
    }
    s
}

/// The code examples of docs/library.md (the library beyond the README's
/// first example), compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../docs/library.md")]
pub struct LibraryGuide;

/// The total mass, and the mass-weighted mean position and velocity (f64
/// sums).
pub fn centre(scene: &VecScene) -> (f64, [f64; 3], [f64; 3]) {
    let (mut m, mut x, mut v) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
    for i in 0..scene.node_count() as u32 {
        let mi = f64::from(scene.mass(i).unwrap());
        let p = scene.position(i).unwrap();
        let vi = scene.velocity(i).unwrap();
        m += mi;
        for k in 0..3 {
            x[k] += mi * f64::from(p[k]);
            v[k] += mi * f64::from(vi[k]);
        }
    }
    (m, x.map(|c| c / m), v.map(|c| c / m))
}
