//! The report's "Error metrics" section: the physical and reference checks that
//! the host tests assert (host-tests/tests/statics.rs, momentum.rs, laws.rs,
//! anisotropy.rs), measured here per mesh and method and written as tables and
//! CSV files, so a change that moves them shows in the report and not only as a
//! pass or a failure.
//!
//! Every number is computed in this run: the core runs in f32, and every sum,
//! norm and reference value computed here is f64. The only stored inputs are
//! the independent linear-FEM (scikit-fem) displacements in
//! host-tests/reference/.

use super::Progress;
use corofem::VecScene;
use corofem::{Method, StaticSettings};
use corofem_bench::args::ReportArgs as Opts;
use corofem_bench::reference::{cross, dot, sub};
use corofem_bench::scenes::{self, SceneDef};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Writes metrics_statics.csv, metrics_momentum.csv, metrics_anisotropy.csv
/// to `o.out` and appends the "Error metrics" section to `md`. Rows that need
/// a shared mesh are skipped, with a note on stderr and in the section, when
/// the mesh file is missing.
pub fn metrics(o: &Opts, md: &mut String) -> Res<()> {
    let t0 = Instant::now();
    writeln!(md, "## Error metrics\n")?;
    writeln!(
        md,
        "Measured in this run on the f32 core, with every sum and reference value in f64 \
         (the checks host-tests asserts, as numbers). See docs/bench.md, \"Error metrics\".\n"
    )?;
    statics(o, md)?;
    momentum(o, md)?;
    anisotropy(o, md)?;
    eprintln!("error metrics: {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// The four methods, in the order of the tables.
const METHODS: [(Method, &str); 4] = [
    (Method::Qr, "Qr"),
    (Method::Polar, "Polar"),
    (Method::Linear, "Linear"),
    (Method::QrRestB, "QrRestB"),
];

/// The shared mesh `file`, or `None` after a printed note (on stderr, and
/// into `notes`, the Markdown printed after the table) when it is missing.
fn mesh_file(file: &str, notes: &mut String) -> Res<Option<PathBuf>> {
    let p = scenes::meshes_dir().join(file);
    if p.is_file() {
        return Ok(Some(p));
    }
    eprintln!("error metrics: {} not found, its rows skipped", p.display());
    writeln!(
        notes,
        "*{file} not found in the shared meshes folder: its rows are skipped.*\n"
    )?;
    Ok(None)
}

/// Displacements (m) of every node of `scene`, widened to f64.
fn displacements(scene: &VecScene) -> Vec<[f64; 3]> {
    (0..scene.node_count() as u32)
        .map(|i| {
            scene
                .displacement(i)
                .unwrap_or([f32::NAN; 3])
                .map(f64::from)
        })
        .collect()
}

/// `|a|`.
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Formats a relative error for a table cell.
fn cell(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2e}")
    } else {
        "—".into()
    }
}

// ------------------------------------------------------------ static sag

/// The cantilever meshes of host-tests/reference, smallest first.
const BEAMS: [&str; 5] = [
    "beam_10x2x2_h1_t6",
    "beam_10x2x2_h1_t5",
    "beam_10x2x2_h05_t6",
    "beam_10x2x2_h05_t5",
    "beam_10x2x2_h025_t6",
];

/// The stored scikit-fem solution of one beam: per-node displacements (m)
/// from the CSV and the JSON's tip mean (m), checked against each other.
struct SagReference {
    u: Vec<Option<[f64; 3]>>,
    tip: f64,
}

/// host-tests/reference/, where the stored scikit-fem solutions are.
fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../host-tests/reference")
}

/// The number at the key path `keys` of the parsed cantilever_reference.json.
fn json_number(json: &serde_json::Value, keys: &[&str]) -> Res<f64> {
    keys.iter()
        .try_fold(json, |v, k| v.get(k))
        .and_then(serde_json::Value::as_f64)
        .ok_or_else(|| format!("cantilever_reference.json: no number at {}", keys.join(".")).into())
}

/// Reads the reference of `name` for a mesh of `nodes` nodes whose free-end
/// nodes are `tip_nodes`. The JSON's tip mean must equal the mean of the
/// CSV's u_z over `tip_nodes` (the same definition) to 1e-8 relative, or the
/// files and the mesh do not belong together.
fn sag_reference(
    json: &serde_json::Value,
    name: &str,
    nodes: usize,
    tip_nodes: &[usize],
) -> Res<SagReference> {
    let tip = json_number(json, &["meshes", name, "gravity", "tip_uz_mean"])?;
    let file = reference_dir().join(format!("cantilever_{name}_gravity.csv"));
    let text = std::fs::read_to_string(&file).map_err(|e| format!("{}: {e}", file.display()))?;
    let mut u = vec![None; nodes];
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(str::parse).collect::<Result<_, _>>()?;
        let i = v[0] as usize;
        *u.get_mut(i).ok_or("reference CSV: node out of range")? = Some([v[1], v[2], v[3]]);
    }
    let from_csv = tip_nodes
        .iter()
        .map(|&i| u[i].map_or(f64::NAN, |d| d[2]))
        .sum::<f64>()
        / tip_nodes.len() as f64;
    // Written so that a NaN (a tip node missing from the CSV) fails too.
    let agree = (from_csv - tip).abs() <= 1e-8 * tip.abs();
    if !agree {
        return Err(format!("{name}: reference CSV tip {from_csv:e} m, JSON {tip:e} m").into());
    }
    Ok(SagReference { u, tip })
}

/// Euler–Bernoulli tip deflection (m, signed, down negative) of a cantilever
/// of length `l`, width `b`, height `h` (m) under its own weight:
/// `−ρ g b h L⁴ / (8 E b h³/12)`.
fn euler_bernoulli(l: f64, b: f64, h: f64, young: f64, density: f64, g: f64) -> f64 {
    let q = density * g * b * h;
    let i = b * h * h * h / 12.0;
    -q * l.powi(4) / (8.0 * young * i)
}

/// Static sag of the reference cantilevers for every method.
fn statics(o: &Opts, md: &mut String) -> Res<()> {
    let beams: &[&str] = if o.quick { &BEAMS[..2] } else { &BEAMS };
    let json_path = reference_dir().join("cantilever_reference.json");
    let text =
        std::fs::read_to_string(&json_path).map_err(|e| format!("{}: {e}", json_path.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)?;
    // The material and load in f64 for the beam theory, rounded to f32 for the core.
    let (young, poisson, density, g) = (1.0e9f64, 0.3f64, 1000.0f64, 9.81f64);
    // Beam theory computed here, and checked against the script's value.
    let eb_nominal = euler_bernoulli(10.0, 2.0, 2.0, young, density, g);
    let eb_json = json_number(&json, &["analytical", "gravity", "euler_bernoulli_tip_uz"])?;
    if (eb_nominal - eb_json).abs() > 1e-9 * eb_json.abs() {
        return Err(format!("Euler–Bernoulli {eb_nominal:e} m here, {eb_json:e} m stored").into());
    }
    writeln!(
        md,
        "### Static sag against linear FEM (scikit-fem) and Euler–Bernoulli\n"
    )?;
    writeln!(
        md,
        "The 10 m × 2 m × 2 m cantilevers of host-tests/reference (E = 1e9 Pa, ν = 0.3, \
         ρ = 1000 kg/m³, clamped at x = 0, gravity −z), solved with `solve_static` \
         (default `StaticSettings`). *vs FEM*: |tip − tip_FEM| / |tip_FEM|, tip = mean u_z \
         at x = 10 m, against the stored scikit-fem P1 solution of the same mesh; *nodal*: \
         max over nodes and components of |u − u_FEM| / |tip_FEM|; *vs E–B*: \
         (|tip| − |tip_EB|) / |tip_EB|, negative when the sag is smaller, \
         |tip_EB| = qL⁴/(8EI) = {:.5e} m.\n",
        eb_nominal.abs()
    )?;
    let mut csv = String::from(
        "mesh,tets,nodes,method,newton_iterations,converged,tip_uz_m,fem_tip_uz_m,rel_err_vs_fem,max_nodal_err_rel,euler_bernoulli_tip_uz_m,rel_err_vs_euler_bernoulli,seconds\n",
    );
    writeln!(
        md,
        "| mesh | tets | method | Newton | tip u_z (m) | vs FEM | nodal | vs E–B |\n\
         |---|---|---|---|---|---|---|---|"
    )?;
    let mut bar = Progress::new("metrics: static sag", beams.len() * METHODS.len());
    let mut missing = String::new();
    for name in beams {
        let Some(path) = mesh_file(&format!("{name}.tetmesh"), &mut missing)? else {
            for _ in METHODS {
                bar.tick();
            }
            continue;
        };
        let mut def = scenes::from_file(name, &path, 1.0);
        def.young = young as f32;
        def.poisson = poisson as f32;
        def.density = density as f32;
        def.gravity = [0.0, 0.0, -g as f32];
        def.rayleigh_mass = 0.0;
        def.rayleigh_stiffness = 0.0;
        def.fixed = select(&def, |p| p[0] <= 1e-6);
        let tip_nodes: Vec<usize> = select(&def, |p| p[0] >= 10.0 - 1e-6)
            .into_iter()
            .map(|i| i as usize)
            .collect();
        let (lo, hi) = bounds(&def);
        let eb = euler_bernoulli(
            hi[0] - lo[0],
            hi[1] - lo[1],
            hi[2] - lo[2],
            young,
            density,
            g,
        );
        let r = sag_reference(&json, name, def.nodes.len(), &tip_nodes)?;
        for (method, label) in METHODS {
            let mut sc = def.core(method, 1e-3, 5);
            let t = Instant::now();
            let last = sc.solve_static(&StaticSettings::default(), |_| {});
            let secs = t.elapsed().as_secs_f64();
            let (iters, converged) = match &last {
                Ok(s) => (s.iteration + 1, s.converged),
                Err(_) => (0, false),
            };
            let u = displacements(&sc);
            let tip = tip_nodes.iter().map(|&i| u[i][2]).sum::<f64>() / tip_nodes.len() as f64;
            let nodal = u
                .iter()
                .zip(&r.u)
                .filter_map(|(a, b)| b.map(|b| norm_inf(sub(*a, b))))
                .fold(0.0f64, f64::max)
                / r.tip.abs();
            let vs_fem = (tip - r.tip).abs() / r.tip.abs();
            let vs_eb = (tip.abs() - eb.abs()) / eb.abs();
            writeln!(
                csv,
                "{name},{},{},{label},{iters},{converged},{tip:.8e},{:.8e},{vs_fem:.4e},{nodal:.4e},{eb:.8e},{vs_eb:.4e},{secs:.3}",
                def.tets.len(),
                def.nodes.len(),
                r.tip
            )?;
            writeln!(
                md,
                "| {} | {} | {label} | {iters}{} | {tip:.5e} | {} | {} | {:+.2}% |",
                name.trim_start_matches("beam_10x2x2_"),
                def.tets.len(),
                if converged { "" } else { " (not converged)" },
                cell(vs_fem),
                cell(nodal),
                100.0 * vs_eb
            )?;
            bar.tick();
        }
    }
    bar.finish();
    md.push('\n');
    md.push_str(&missing);
    std::fs::write(o.out.join("metrics_statics.csv"), csv)?;
    writeln!(
        md,
        "How to read it: *vs FEM* and *nodal* compare with the same discretisation. Linear \
         solves the same linear problem, so its figures are the f32 floor (ε = 1.2e-7). \
         The co-rotational methods are geometrically nonlinear: their tip sag differs from \
         linear FEM's by the second-order geometric effect (rotation² ≈ 1e-5) plus their \
         f32 force noise and the static solve's stopping rule (update < 1e-4 of the \
         displacement), and their *nodal* difference is mostly along x, the bent beam's \
         shortening, which linear FEM lacks. *vs E–B* is the mesh, not the \
         method: linear tetrahedra are too stiff in bending and the stubby beam (L/h = 5) \
         adds shear, so the FE sag is below theory by the same amount for every method, \
         less as the mesh is refined.\n"
    )?;
    Ok(())
}

/// Largest component magnitude of `a`.
fn norm_inf(a: [f64; 3]) -> f64 {
    a[0].abs().max(a[1].abs()).max(a[2].abs())
}

/// Nodes of `def` whose rest position satisfies `pred`.
fn select(def: &SceneDef, pred: impl Fn([f32; 3]) -> bool) -> Vec<u32> {
    (0..def.nodes.len() as u32)
        .filter(|&i| pred(def.nodes[i as usize]))
        .collect()
}

/// Bounding box (m) of `def`'s rest positions.
fn bounds(def: &SceneDef) -> ([f64; 3], [f64; 3]) {
    def.nodes
        .iter()
        .fold(([f64::MAX; 3], [f64::MIN; 3]), |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(p[k]));
                hi[k] = hi[k].max(f64::from(p[k]));
            }
            (lo, hi)
        })
}

// ------------------------------------------------- momentum and net torque

/// A small deterministic generator (xorshift64*), the same numbers on every
/// machine.
struct Rng(u64);

impl Rng {
    /// Uniform in `[−1, 1)`.
    fn signed(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * u - 1.0
    }
}

/// Momentum `Σ m v` (kg·m/s) and angular momentum `Σ (x − c) × m v`
/// (kg·m²/s) about the fixed point `c` (m), and their scales `Σ m |v|` and
/// `Σ m |x − c| |v|`, in f64.
fn momenta(s: &VecScene, c: [f64; 3]) -> ([f64; 3], [f64; 3], f64, f64) {
    let (mut p, mut l, mut ps, mut ls) = ([0.0f64; 3], [0.0f64; 3], 0.0, 0.0);
    for i in 0..s.node_count() as u32 {
        let m = f64::from(s.mass(i).unwrap_or(f32::NAN));
        let x = sub(s.position(i).unwrap_or([f32::NAN; 3]).map(f64::from), c);
        let v = s.velocity(i).unwrap_or([f32::NAN; 3]).map(f64::from);
        let xv = cross(x, v);
        for k in 0..3 {
            p[k] += m * v[k];
            l[k] += m * xv[k];
        }
        ps += m * norm(v);
        ls += m * norm(x) * norm(v);
    }
    (p, l, ps, ls)
}

/// Centre of mass (m) of the current positions, in f64.
fn centre_of_mass(s: &VecScene) -> [f64; 3] {
    let (mut m, mut c) = (0.0f64, [0.0f64; 3]);
    for i in 0..s.node_count() as u32 {
        let mi = f64::from(s.mass(i).unwrap_or(f32::NAN));
        let x = s.position(i).unwrap_or([f32::NAN; 3]);
        m += mi;
        for k in 0..3 {
            c[k] += mi * f64::from(x[k]);
        }
    }
    c.map(|x| x / m)
}

/// Relative net force `|Σ f| / Σ |f|` and net torque `|Σ (x − c) × f| /
/// Σ |x − c| |f|` of the internal elastic forces `f` of the current shape,
/// about the current centre of mass `c`.
fn net_force_torque(s: &mut VecScene, f: &mut [[f32; 3]]) -> (f64, f64) {
    if s.elastic_forces(f).is_err() {
        return (f64::NAN, f64::NAN);
    }
    let c = centre_of_mass(s);
    let (mut sf, mut st, mut fs, mut ts) = ([0.0f64; 3], [0.0f64; 3], 0.0, 0.0);
    for (i, fi) in (0u32..).zip(f).take(s.node_count()) {
        let x = sub(s.position(i).unwrap_or([f32::NAN; 3]).map(f64::from), c);
        let fi = fi.map(f64::from);
        let t = cross(x, fi);
        for k in 0..3 {
            sf[k] += fi[k];
            st[k] += t[k];
        }
        fs += norm(fi);
        ts += norm(x) * norm(fi);
    }
    if fs == 0.0 {
        return (0.0, 0.0);
    }
    (norm(sf) / fs, norm(st) / ts)
}

/// One free-body run's figures.
struct Drift {
    momentum: f64,
    angular: f64,
    force: f64,
    torque: f64,
    inverted: u32,
    failed: bool,
}

/// `steps` steps of `def` (free, no gravity, no damping) spinning at 2.3
/// rad/s about a tilted axis through its centre of mass, plus random
/// deforming velocities of 20 % of the spin speed (momentum.rs's start):
/// largest drifts of momentum and angular momentum relative to their initial
/// scales, and the largest relative net force and torque of the elastic
/// forces over the steps.
fn drift(def: &SceneDef, method: Method, cg: u32, dt: f32, steps: usize) -> Drift {
    let mut sc = def.core(method, dt, cg);
    let n = def.nodes.len();
    let c = def.nodes.iter().fold([0.0f64; 3], |a, p| {
        [0, 1, 2].map(|k| a[k] + f64::from(p[k]) / n as f64)
    });
    let omega = [0.3, -1.0, 2.0];
    let mut rng = Rng(3);
    let v: Vec<[f32; 3]> = def
        .nodes
        .iter()
        .map(|p| {
            let w = cross(omega, sub(p.map(f64::from), c));
            let s = 0.2 * norm(w);
            [0, 1, 2].map(|k| (w[k] + s * rng.signed()) as f32)
        })
        .collect();
    let mut d = Drift {
        momentum: 0.0,
        angular: 0.0,
        force: 0.0,
        torque: 0.0,
        inverted: 0,
        failed: sc.set_velocities(&v).is_err(),
    };
    // Angular momentum about the fixed point where the centre of mass starts.
    let c0 = centre_of_mass(&sc);
    let (p0, l0, ps, ls) = momenta(&sc, c0);
    let mut f = vec![[0.0f32; 3]; n];
    for _ in 0..steps {
        match sc.step() {
            Ok(st) => d.inverted = d.inverted.max(st.inverted),
            Err(_) => {
                d.failed = true;
                break;
            }
        }
        let (p, l, _, _) = momenta(&sc, c0);
        d.momentum = d.momentum.max(norm(sub(p, p0)) / ps);
        d.angular = d.angular.max(norm(sub(l, l0)) / ls);
        let (nf, nt) = net_force_torque(&mut sc, &mut f);
        d.force = d.force.max(nf);
        d.torque = d.torque.max(nt);
    }
    d
}

/// Momentum drift and net internal torque of free spinning bodies.
fn momentum(o: &Opts, md: &mut String) -> Res<()> {
    let steps = if o.quick { 100 } else { 200 };
    let dt = 2.0e-3f32;
    let cgs: [u32; 3] = [1, 2, 5];
    let mut files = vec![("liver", "sofa_liver.tetmesh", 0.03)];
    if !o.quick {
        files.push(("bunny", "bunny_ftw_1k.tetmesh", 1.0));
    }
    writeln!(
        md,
        "### Momentum drift and net internal torque (free body)\n"
    )?;
    writeln!(
        md,
        "No fixed nodes, no gravity, no damping; the body spins at 2.3 rad/s about a tilted \
         axis through its centre of mass, plus random deforming velocities of 20 % of the spin \
         speed; {steps} steps of {} ms. *Δp*: max over steps of |p − p₀| / Σ m|v₀|; *ΔL*: the \
         same for the angular momentum about the starting centre of mass, over \
         Σ m|x₀ − c||v₀|; *torque*: max over steps of the elastic forces' \
         |Σ (x − c) × f| / Σ |x − c||f| about the current centre of mass (*force*: |Σ f| / \
         Σ |f|, in the CSV).\n",
        dt * 1e3
    )?;
    let mut csv = String::from(
        "mesh,tets,method,cg_iterations,steps,dt_ms,rel_momentum_drift,rel_angular_momentum_drift,max_rel_net_force,max_rel_net_torque,max_inverted,failed\n",
    );
    write!(md, "| mesh | method |")?;
    for cg in cgs {
        write!(md, " Δp, {cg} CG | ΔL, {cg} CG |")?;
    }
    writeln!(
        md,
        " torque |\n|---|---|{}---|",
        "---|---|".repeat(cgs.len())
    )?;
    let mut notes = String::new();
    let mut defs = Vec::new();
    for (name, file, scale) in files {
        if let Some(p) = mesh_file(file, &mut notes)? {
            let mut def = scenes::from_file(name, &p, scale);
            def.fixed.clear();
            def.gravity = [0.0; 3];
            def.rayleigh_mass = 0.0;
            def.rayleigh_stiffness = 0.0;
            defs.push(def);
        }
    }
    let mut bar = Progress::new("metrics: momentum", defs.len() * METHODS.len() * cgs.len());
    for def in &defs {
        for (method, label) in METHODS {
            write!(md, "| {} ({} tets) | {label} |", def.name, def.tets.len())?;
            let mut torque = 0.0f64;
            for cg in cgs {
                let d = drift(def, method, cg, dt, steps);
                writeln!(
                    csv,
                    "{},{},{label},{cg},{steps},{},{:.4e},{:.4e},{:.4e},{:.4e},{},{}",
                    def.name,
                    def.tets.len(),
                    dt * 1e3,
                    d.momentum,
                    d.angular,
                    d.force,
                    d.torque,
                    d.inverted,
                    d.failed
                )?;
                if d.failed {
                    write!(md, " failed | failed |")?;
                } else {
                    write!(md, " {} | {} |", cell(d.momentum), cell(d.angular))?;
                }
                torque = torque.max(d.torque);
                bar.tick();
            }
            writeln!(md, " {} |", cell(torque))?;
        }
    }
    bar.finish();
    md.push('\n');
    md.push_str(&notes);
    std::fs::write(o.out.join("metrics_momentum.csv"), csv)?;
    writeln!(
        md,
        "How to read it: f32 rounds at ε = 1.2e-7, so drifts and torques of 1e-8 to 1e-7 \
         (up to ~1e-6 as a random walk over many steps) mean the law holds exactly in the \
         method and the truncated CG keeps it at any budget. Δp stays there for every \
         method: every method's forces sum to zero. Polar's forces are torque-free too, but \
         its stiffness is torque-free about the rotated rest shape, not the current one, so \
         its ΔL is small but above round-off; Linear (the unrotated rest stiffness) and \
         QrRestB (the rest shape's `B`) have net torques, so a spinning body gains or loses \
         spin.\n"
    )?;
    Ok(())
}

// ------------------------------------------------------------ anisotropy

/// Even permutations of each tetrahedron's `(a, b, c, d)`: a 3-cycle and two
/// double transpositions; they keep every element positively oriented.
const ORDERS: [[usize; 4]; 3] = [[1, 2, 0, 3], [1, 0, 3, 2], [3, 2, 1, 0]];

/// A static shape and how the solves that found it went.
struct Settled {
    /// Displacements (m).
    u: Vec<[f64; 3]>,
    /// Every Newton solve converged.
    converged: bool,
    /// Newton iterations, summed over the load increments.
    iterations: u32,
    /// Most inverted elements seen by a Newton iteration.
    inverted: u32,
}

/// Static shape of `def` under its gravity, the load applied in `increments`
/// equal steps (each a Newton solve from the last).
fn settled(def: &SceneDef, method: Method, increments: u32) -> Settled {
    let mut sc = def.core(method, 1e-3, 5);
    let mut r = Settled {
        u: Vec::new(),
        converged: true,
        iterations: 0,
        inverted: 0,
    };
    let cfg = StaticSettings {
        max_iterations: 40,
        cg_iterations: 1000,
        cg_tolerance: 1e-6,
        tolerance: 1e-6,
        update_tolerance: 1e-6,
        ..StaticSettings::default()
    };
    for k in 1..=increments {
        let mut s = *sc.settings();
        s.gravity = def.gravity.map(|g| g * k as f32 / increments as f32);
        if sc.set_settings(s).is_err() {
            r.converged = false;
            return r;
        }
        let mut inverted = 0;
        match sc.solve_static(&cfg, |st| inverted = inverted.max(st.inverted)) {
            Ok(st) => {
                r.converged &= st.converged;
                r.iterations += st.iteration + 1;
            }
            Err(_) => r.converged = false,
        }
        r.inverted = r.inverted.max(inverted);
    }
    r.u = displacements(&sc);
    r
}

/// RMS of `a − b` over RMS of `a`.
fn relative_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut diff, mut size) = (0.0, 0.0);
    for (p, q) in a.iter().zip(b) {
        diff += norm(sub(*p, *q)).powi(2);
        size += norm(*p).powi(2);
    }
    (diff / size).sqrt()
}

/// QR vertex-order anisotropy: static shapes of the same body with every
/// tetrahedron's nodes listed in other orders.
fn anisotropy(o: &Opts, md: &mut String) -> Res<()> {
    let increments = 4;
    let mut notes = String::new();
    let mut defs = Vec::new();
    let beam = if o.quick {
        "beam_10x2x2_h1_t6"
    } else {
        "beam_10x2x2_h05_t6"
    };
    if let Some(p) = mesh_file(&format!("{beam}.tetmesh"), &mut notes)? {
        let mut def = scenes::from_file(beam, &p, 1.0);
        def.young = 1.0e7;
        def.poisson = 0.3;
        def.gravity = [0.0, 0.0, -9.81];
        def.fixed = select(&def, |p| p[0] <= 1e-6);
        defs.push(def);
    }
    if let Some(p) = mesh_file("bunny_ftw_1k.tetmesh", &mut notes)? {
        // Softened tenfold so it bends far (its top moves about half of its
        // 0.15 m height) with no element inverted.
        let mut b = scenes::bunny(p.parent().unwrap_or(Path::new(".")));
        b.young = 1.0e4;
        defs.push(b);
    }
    writeln!(md, "### QR vertex-order anisotropy\n")?;
    writeln!(
        md,
        "The same body with every tetrahedron's nodes listed in three other \
         orientation-preserving orders (a 3-cycle, two double transpositions), solved to \
         static equilibrium under gravity ({increments} load increments, Newton to 1e-6); \
         *difference*: the largest relative RMS difference of the displacements from the \
         original order's. Scenes: the cantilever {beam} (10 m long, E = 1e7 Pa, clamped at \
         x = 0, gravity −z) and the 0.15 m tall bunny of the speed-against-error section \
         softened to E = 1e4 Pa (lowest 5 % held, gravity along −x), both bent far into the \
         nonlinear range (max displacement). *Newton iterations*: summed over the 4 orders × \
         {increments} increments; *inverted*: most inverted elements in any Newton iteration.\n"
    )?;
    let mut csv = String::from(
        "mesh,tets,method,max_displacement_m,rms_displacement_m,worst_order_rel_rms_diff,newton_iterations,converged,max_inverted\n",
    );
    writeln!(
        md,
        "| mesh | method | max displacement (m) | difference | Newton iterations | inverted |\n|---|---|---|---|---|---|"
    )?;
    let mut bar = Progress::new(
        "metrics: anisotropy",
        defs.len() * METHODS.len() * (1 + ORDERS.len()),
    );
    for def in &defs {
        for (method, label) in &METHODS {
            let first = settled(def, *method, increments);
            let base = &first.u;
            let (mut ok, mut iters, mut inverted) =
                (first.converged, first.iterations, first.inverted);
            bar.tick();
            let mut worst = 0.0f64;
            for order in ORDERS {
                let mut p = def.clone();
                for t in &mut p.tets {
                    *t = order.map(|k| t[k]);
                }
                let other = settled(&p, *method, increments);
                ok &= other.converged;
                iters += other.iterations;
                inverted = inverted.max(other.inverted);
                worst = worst.max(relative_rms(base, &other.u));
                bar.tick();
            }
            let max = base.iter().map(|u| norm(*u)).fold(0.0f64, f64::max);
            let rms =
                (base.iter().map(|u| norm(*u).powi(2)).sum::<f64>() / base.len() as f64).sqrt();
            writeln!(
                csv,
                "{},{},{label},{max:.5e},{rms:.5e},{worst:.4e},{iters},{ok},{inverted}",
                def.name,
                def.tets.len()
            )?;
            writeln!(
                md,
                "| {} ({} tets) | {label} | {max:.3} | {} | {iters}{} | {inverted} |",
                def.name,
                def.tets.len(),
                cell(worst),
                if ok { "" } else { " (not all converged)" }
            )?;
        }
    }
    bar.finish();
    md.push('\n');
    md.push_str(&notes);
    std::fs::write(o.out.join("metrics_anisotropy.csv"), csv)?;
    writeln!(
        md,
        "How to read it: Polar and Linear do not depend on the node order, so their \
         difference is the f32 round-off of other summation orders and the Newton stopping \
         rule — the floor; QR builds its frame from the edges a→b and a→c, so under large \
         rotation its answer depends on which node is `a`, and its figure above that floor is \
         the method's anisotropy (QrRestB uses the same frame).\n"
    )?;
    Ok(())
}
