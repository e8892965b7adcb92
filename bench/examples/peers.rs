//! `cargo run --release -p corofem-bench --example peers -- [--quick] [--out DIR]`:
//! the corofem core and rapier3d's FEM soft bodies (`SoftBodySolver::Fem`) side
//! by side on the same meshes, material, pins, gravity and time step, with the
//! f64 reference integrator as the judge. Writes `peers.csv`, `peers.md`,
//! `peers_tip.csv` (tip deflection after every step) and `peers_tip_<scene>.svg`
//! to `target/bench-report/` by default and prints the table. See docs/bench.md
//! ("Peers: rapier3d's FEM soft bodies").
//!
//! rapier3d is a dev-dependency of the benchmark crate only: the core and the
//! report binary never link it.

use corofem::Method;
use corofem_bench::reference::Trajectory;
use corofem_bench::scenes::{self, SceneDef};
use rapier3d::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// The time step of every run (s).
const DT: f32 = 1.0e-3;
/// corofem's CG budget (and rapier's, in the matched configuration).
const CG: u32 = 5;
/// Timing rounds per engine; each round steps the same trajectory from rest.
const ROUNDS: usize = 3;
/// corofem's CG budgets tried, in order, for the comparison at equal
/// accuracy: the first whose error is at most rapier's with its defaults is
/// timed against them.
const BUDGETS: [u32; 14] = [5, 6, 8, 10, 12, 15, 20, 25, 30, 40, 60, 80, 120, 160];

/// How rapier is configured.
#[derive(Clone, Copy, PartialEq)]
enum RapierCfg {
    /// As close to corofem's step as rapier's settings allow: one implicit
    /// step per dt (no substeps), 5 CG iterations with no early stop, no
    /// damping.
    Matched,
    /// rapier's own solver defaults (4 substeps, up to 20 CG iterations to a
    /// relative residual of 1e-5) with the same undamped material: what a
    /// rapier user gets without tuning, for scale.
    Defaults,
}

impl RapierCfg {
    fn name(self) -> &'static str {
        match self {
            RapierCfg::Matched => "rapier",
            RapierCfg::Defaults => "rapier_defaults",
        }
    }
}

/// One engine's run of one scene.
struct Run {
    /// Mean ms per step over steps 2..N of the fastest round.
    ms_best: f64,
    /// Median ms per step over every timed step of every round.
    ms_median: f64,
    /// Tip z displacement after each step (m).
    tips: Vec<f64>,
    /// Relative RMS position error against the reference over every step
    /// ([`Trajectory`]).
    traj_err: f64,
    /// Node displacements at the end (m).
    u: Vec<[f64; 3]>,
}

/// The peer scenes: the report's beam, the same beam at 8× the elements, and
/// the 10k-tet cube of the shared meshes clamped at x = min.
fn peer_scenes(quick: bool) -> Vec<SceneDef> {
    let mut v = vec![scenes::beam()];
    if !quick {
        v.push(scenes::boxed(
            "beam_fine",
            [1.0, 0.2, 0.2],
            [40, 8, 8],
            1.0e7,
        ));
    }
    let path = scenes::meshes_dir().join("cube_13n_t6.tetmesh");
    if path.exists() {
        let mut c = scenes::from_file("cube10k", &path, 1.0);
        // The material of examples/scenes/timing_cube10k.toml (its grid), undamped,
        // clamped at x = min and sagging along −z like the beams.
        c.young = 1.0e6;
        c.poisson = 0.3;
        c.density = 1000.0;
        c.rayleigh_mass = 0.0;
        c.rayleigh_stiffness = 0.0;
        c.gravity = [0.0, 0.0, -9.81];
        let xmin = c.nodes.iter().map(|p| p[0]).fold(f32::MAX, f32::min);
        c.fixed = (0..c.nodes.len() as u32)
            .filter(|&i| c.nodes[i as usize][0] <= xmin + 1.0e-6)
            .collect();
        v.push(c);
    } else {
        eprintln!(
            "{} not found: skipping the 10k-tet cube (set COROFEM_MESHES)",
            path.display()
        );
    }
    v
}

/// The nodes of the free end (x = max).
fn tip_nodes(d: &SceneDef) -> Vec<usize> {
    let xmax = d.nodes.iter().map(|p| p[0]).fold(f32::MIN, f32::max);
    (0..d.nodes.len())
        .filter(|&i| d.nodes[i][0] >= xmax - 1.0e-6)
        .collect()
}

/// Mean z displacement of the tip nodes.
fn tip(u: &[[f64; 3]], tip: &[usize]) -> f64 {
    tip.iter().map(|&i| u[i][2]).sum::<f64>() / tip.len() as f64
}

/// Relative RMS position error against the reference at the end:
/// `sqrt(Σ|u − u_ref|²) / sqrt(Σ|u_ref|²)`.
fn rel_err(u: &[[f64; 3]], r: &[[f64; 3]]) -> f64 {
    let (mut e, mut n) = (0.0, 0.0);
    for (a, b) in u.iter().zip(r) {
        for c in 0..3 {
            e += (a[c] - b[c]).powi(2);
            n += b[c] * b[c];
        }
    }
    (e / n).sqrt()
}

/// The largest sag (most negative z) of a tip trajectory.
fn peak(tips: &[f64]) -> f64 {
    tips.iter().copied().fold(0.0, f64::min)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One engine holding one scene.
trait Engine {
    fn step(&mut self);
    /// Node displacements (m).
    fn displacements(&self) -> Vec<[f64; 3]>;
    /// Mean z displacement of `nodes` (m).
    fn tip(&self, nodes: &[usize]) -> f64;
}

/// One round: `steps` steps from rest, every step timed but the first (where
/// rapier builds its FEM system's sparsity pattern), the tip recorded after
/// each step outside the timing.
struct Round {
    /// ms per timed step.
    times: Vec<f64>,
    /// Tip z displacement after each step (m).
    tips: Vec<f64>,
    /// Relative RMS position error over every step ([`Trajectory`]).
    traj_err: f64,
    /// Displacements at the end (m).
    u: Vec<[f64; 3]>,
}

fn round(mut e: impl Engine, steps: usize, tip_nodes: &[usize], r: &Trajectory) -> Round {
    let mut times = Vec::with_capacity(steps);
    let mut tips = Vec::with_capacity(steps);
    let mut err2 = 0.0;
    for k in 0..steps {
        let t = Instant::now();
        e.step();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if k > 0 {
            times.push(ms);
        }
        tips.push(e.tip(tip_nodes));
        err2 += r.sq_err(k, e.displacements());
    }
    Round {
        times,
        tips,
        traj_err: r.relative(err2),
        u: e.displacements(),
    }
}

// ---------------------------------------------------------------- corofem

struct Corofem(corofem::VecScene);

impl Corofem {
    /// The scene with `Qr`, dt and a CG budget of `cg` iterations.
    fn new(d: &SceneDef, cg: u32) -> Self {
        Self(d.core(Method::Qr, DT, cg))
    }
}

impl Engine for Corofem {
    fn step(&mut self) {
        self.0.step().expect("corofem step");
    }
    fn displacements(&self) -> Vec<[f64; 3]> {
        (0..self.0.node_count() as u32)
            .map(|i| self.0.displacement(i).expect("node").map(f64::from))
            .collect()
    }
    fn tip(&self, nodes: &[usize]) -> f64 {
        nodes
            .iter()
            .map(|&i| f64::from(self.0.displacement(i as u32).expect("node")[2]))
            .sum::<f64>()
            / nodes.len() as f64
    }
}

// ---------------------------------------------------------------- rapier3d

struct Rapier {
    world: PhysicsWorld,
    body: SoftBodyHandle,
    rest: Vec<[f32; 3]>,
}

impl Rapier {
    /// A rapier world holding the scene as one FEM soft body, configured by `cfg`.
    fn new(d: &SceneDef, cfg: RapierCfg) -> Self {
        let mut world = PhysicsWorld::new();
        let g = d.gravity;
        world.gravity = Vector::new(g[0], g[1], g[2]);
        let ip = &mut world.integration_parameters;
        ip.dt = DT;
        let fem = &mut ip.soft_bodies.fem;
        if cfg == RapierCfg::Matched {
            // Substeps: one implicit step per dt, as corofem (rapier's default is 4).
            ip.num_solver_iterations = 1;
            // A fixed CG budget with no early stop, as corofem's cg_tolerance = 0.
            fem.max_linear_iterations = CG as usize;
            fem.linear_tolerance = 0.0;
        }
        // The same lumped masses ρ V₀ / 4 per element node as the core and the
        // reference (rapier would otherwise give every particle the same mass).
        let masses: Vec<f32> = d.reference().mass.iter().map(|&m| m as f32).collect();
        let builder = SoftBodyBuilder::new(
            d.nodes
                .iter()
                .map(|p| Vector::new(p[0], p[1], p[2]))
                .collect(),
        )
        .cells(d.tets.clone())
        .masses(masses)
        .pinned_particles(d.fixed.iter().copied())
        .cell_model(SoftBodyCellModel::Corotational)
        .material(SoftBodyMaterial {
            young_modulus: d.young,
            poisson_ratio: d.poisson,
            // Undamped, as the scenes (rapier's default is a damping ratio of 1).
            elastic_damping_ratio: 0.0,
            deformation_damping: 0.0,
            ..Default::default()
        })
        .solver(SoftBodySolver::Fem)
        .linear_damping(0.0)
        // corofem has no collision detection: neither does this body.
        .no_surface_collider()
        .can_sleep(false);
        let body = world.insert_soft_body(builder);
        assert_eq!(
            world.soft_bodies[body].particles().len(),
            d.nodes.len(),
            "rapier keeps the nodes"
        );
        Self {
            world,
            body,
            rest: d.nodes.clone(),
        }
    }

    fn u(&self, i: usize) -> [f64; 3] {
        let p = self.world.soft_bodies[self.body].particle_position(i);
        let x = self.rest[i];
        [
            f64::from(p.x - x[0]),
            f64::from(p.y - x[1]),
            f64::from(p.z - x[2]),
        ]
    }
}

impl Engine for Rapier {
    fn step(&mut self) {
        self.world.step();
    }
    fn displacements(&self) -> Vec<[f64; 3]> {
        (0..self.rest.len()).map(|i| self.u(i)).collect()
    }
    fn tip(&self, nodes: &[usize]) -> f64 {
        nodes.iter().map(|&i| self.u(i)[2]).sum::<f64>() / nodes.len() as f64
    }
}

// ---------------------------------------------------------------- main

struct Row {
    scene: String,
    tets: usize,
    nodes: usize,
    steps: usize,
    reference_tip: f64,
    reference_tips: Vec<f64>,
    static_tip: Option<f64>,
    corofem: Run,
    rapier: Run,
    defaults: Run,
    /// corofem at the smallest budget of [`BUDGETS`] as accurate as rapier's
    /// defaults; `None` if none of them is.
    equal: Option<Equal>,
    tip: Vec<usize>,
    reference_u: Vec<[f64; 3]>,
}

/// The rounds of one engine: the fastest round's mean, the median step, and
/// the last round's trajectory (every round steps the same trajectory; the
/// rounds are checked to agree).
fn collect(rounds: Vec<Round>) -> Run {
    let ms_best = rounds
        .iter()
        .map(|r| r.times.iter().sum::<f64>() / r.times.len() as f64)
        .fold(f64::MAX, f64::min);
    let mut all: Vec<f64> = rounds
        .iter()
        .flat_map(|r| r.times.iter().copied())
        .collect();
    let ms_median = median(&mut all);
    let last = rounds.last().expect("a round");
    for r in &rounds {
        assert_eq!(
            r.tips, last.tips,
            "rounds differ: an engine is not deterministic"
        );
    }
    let last = rounds.into_iter().last().expect("a round");
    Run {
        ms_best,
        ms_median,
        tips: last.tips,
        traj_err: last.traj_err,
        u: last.u,
    }
}

/// corofem at rapier's default accuracy, and rapier with its defaults timed
/// again beside it.
struct Equal {
    /// corofem's CG budget.
    cg: u32,
    /// corofem with that budget.
    corofem: Run,
    /// rapier with its defaults, in rounds interleaved with `corofem`'s.
    rapier: Run,
}

/// corofem with the smallest CG budget of [`BUDGETS`] whose error over the
/// trajectory against `reference` is at most `target`, timed over
/// [`ROUNDS`] rounds interleaved with as many of rapier with its defaults
/// (so that a burst of load hits both); `None` if even the largest budget
/// errs more.
fn equal_accuracy(
    d: &SceneDef,
    steps: usize,
    tip: &[usize],
    reference: &Trajectory,
    target: f64,
) -> Option<Equal> {
    let cg = BUDGETS
        .into_iter()
        .find(|&cg| round(Corofem::new(d, cg), steps, tip, reference).traj_err <= target)?;
    let (mut c, mut f) = (Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        c.push(round(Corofem::new(d, cg), steps, tip, reference));
        f.push(round(
            Rapier::new(d, RapierCfg::Defaults),
            steps,
            tip,
            reference,
        ));
    }
    Some(Equal {
        cg,
        corofem: collect(c),
        rapier: collect(f),
    })
}

/// Euler–Bernoulli static tip deflection of a clamped prism of length `l`,
/// width `b` and height `h` under its own weight: `ρ g A l⁴ / (8 E I)`.
fn euler_bernoulli(d: &SceneDef) -> f64 {
    let ext = |c: usize| {
        let (lo, hi) = d
            .nodes
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), p| (l.min(p[c]), h.max(p[c])));
        f64::from(hi - lo)
    };
    let (l, b, h) = (ext(0), ext(1), ext(2));
    let g = f64::from(d.gravity[2]).abs();
    let i = b * h.powi(3) / 12.0;
    -f64::from(d.density) * g * b * h * l.powi(4) / (8.0 * f64::from(d.young) * i)
}

fn main() -> Res<()> {
    let Some(args) = corofem_bench::args::report_args("peers [--quick] [--out DIR]", &[], false)?
    else {
        return Ok(());
    };
    let (quick, out) = (args.quick, args.out);
    let steps = if quick { 50 } else { 200 };
    let t0 = Instant::now();
    let mut rows = Vec::new();
    for d in peer_scenes(quick) {
        eprint!(
            "{} ({} tets, {} nodes, {steps} steps): reference",
            d.name,
            d.tets.len(),
            d.nodes.len()
        );
        let tip = tip_nodes(&d);
        let mut r = d.reference();
        let rs = d.ref_settings(f64::from(DT));
        let mut reference_tips = Vec::with_capacity(steps);
        // The reference after every step: the trajectory error's yardstick
        // (less sensitive to the phase of an oscillation than the end).
        let mut traj = Trajectory::default();
        for _ in 0..steps {
            r.step(&rs);
            reference_tips.push(self::tip(&r.u, &tip));
            traj.push(&r.u);
        }
        let reference_u = r.u.clone();
        let (mut c, mut m, mut f) = (Vec::new(), Vec::new(), Vec::new());
        // Rounds interleaved, so a burst of load on the shared machine hits all three.
        for k in 0..ROUNDS {
            eprint!(", round {}", k + 1);
            c.push(round(Corofem::new(&d, CG), steps, &tip, &traj));
            m.push(round(
                Rapier::new(&d, RapierCfg::Matched),
                steps,
                &tip,
                &traj,
            ));
            f.push(round(
                Rapier::new(&d, RapierCfg::Defaults),
                steps,
                &tip,
                &traj,
            ));
        }
        let defaults = collect(f);
        eprint!(", corofem at rapier's default accuracy");
        let equal = equal_accuracy(&d, steps, &tip, &traj, defaults.traj_err);
        eprintln!();
        let is_beam = d.name.starts_with("beam");
        rows.push(Row {
            scene: d.name.clone(),
            tets: d.tets.len(),
            nodes: d.nodes.len(),
            steps,
            reference_tip: self::tip(&reference_u, &tip),
            reference_tips,
            static_tip: is_beam.then(|| euler_bernoulli(&d)),
            corofem: collect(c),
            rapier: collect(m),
            defaults,
            equal,
            tip,
            reference_u,
        });
    }
    let total = t0.elapsed().as_secs_f64();
    let csv = csv(&rows)?;
    std::fs::write(out.join("peers.csv"), csv)?;
    std::fs::write(out.join("peers_tip.csv"), tip_csv(&rows)?)?;
    for r in &rows {
        plot_tip(&out.join(format!("peers_tip_{}.svg", r.scene)), r)?;
    }
    let md = markdown(&rows, quick, total)?;
    std::fs::write(out.join("peers.md"), &md)?;
    println!("{md}");
    eprintln!("peers.csv and peers.md in {} ({total:.0} s)", out.display());
    Ok(())
}

fn csv(rows: &[Row]) -> Res<String> {
    let mut s = String::from(
        "scene,tets,nodes,steps,engine,ms_per_step_best_round,ms_per_step_median,tip_z_m,reference_tip_z_m,peak_tip_z_m,reference_peak_tip_z_m,rel_rms_err_vs_reference,rel_rms_err_trajectory\n",
    );
    for r in rows {
        let equal = r
            .equal
            .as_ref()
            .map(|e| (format!("corofem_cg{}", e.cg), &e.corofem));
        let runs = [
            ("corofem".to_string(), &r.corofem),
            (RapierCfg::Matched.name().to_string(), &r.rapier),
            (RapierCfg::Defaults.name().to_string(), &r.defaults),
        ];
        for (name, run) in runs.into_iter().chain(equal) {
            writeln!(
                s,
                "{},{},{},{},{name},{:.5},{:.5},{:.6e},{:.6e},{:.6e},{:.6e},{:.4e},{:.4e}",
                r.scene,
                r.tets,
                r.nodes,
                r.steps,
                run.ms_best,
                run.ms_median,
                tip(&run.u, &r.tip),
                r.reference_tip,
                peak(&run.tips),
                peak(&r.reference_tips),
                rel_err(&run.u, &r.reference_u),
                run.traj_err
            )?;
        }
    }
    Ok(s)
}

/// The tip z displacement of every engine after every step.
fn tip_csv(rows: &[Row]) -> Res<String> {
    let mut s = String::from("scene,step,t_s,reference_m,corofem_m,rapier_m,rapier_defaults_m\n");
    for r in rows {
        for k in 0..r.steps {
            writeln!(
                s,
                "{},{},{:.4},{:.6e},{:.6e},{:.6e},{:.6e}",
                r.scene,
                k + 1,
                (k + 1) as f64 * f64::from(DT),
                r.reference_tips[k],
                r.corofem.tips[k],
                r.rapier.tips[k],
                r.defaults.tips[k]
            )?;
        }
    }
    Ok(s)
}

/// Tip deflection against time, every engine and the reference, to
/// `path` (SVG).
fn plot_tip(path: &Path, r: &Row) -> Res<()> {
    use plotters::prelude::*;
    let lines: [(&str, &[f64], RGBColor); 4] = [
        (
            "f64 reference (exact solves)",
            &r.reference_tips,
            RGBColor(0, 0, 0),
        ),
        (
            "corofem (Qr, 5 CG)",
            &r.corofem.tips,
            RGBColor(31, 119, 180),
        ),
        (
            "rapier matched (1 substep, 5 CG)",
            &r.rapier.tips,
            RGBColor(214, 39, 40),
        ),
        (
            "rapier defaults (4 substeps, <= 20 CG)",
            &r.defaults.tips,
            RGBColor(44, 160, 44),
        ),
    ];
    let t = |k: usize| (k + 1) as f64 * f64::from(DT) * 1e3;
    let (lo, hi) = lines
        .iter()
        .flat_map(|l| l.1.iter())
        .fold((0.0f64, 0.0f64), |(l, h), &v| {
            (l.min(v * 1e3), h.max(v * 1e3))
        });
    let pad = 0.08 * (hi - lo).max(1e-3);
    let root = SVGBackend::new(path, (960, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{} ({} tets): tip deflection, dt 1 ms", r.scene, r.tets),
            ("sans-serif", 24),
        )
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t(r.steps - 1), (lo - pad)..(hi + pad))?;
    chart
        .configure_mesh()
        .x_desc("time (ms)")
        .y_desc("mean z displacement of the free end (mm)")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(WHITE)
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()?;
    for (name, tips, c) in lines {
        chart
            .draw_series(LineSeries::new(
                tips.iter().enumerate().map(|(k, v)| (t(k), v * 1e3)),
                c.stroke_width(2),
            ))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()?;
    root.present()?;
    Ok(())
}

fn mm(x: f64) -> String {
    format!("{:.3}", x * 1e3)
}

fn markdown(rows: &[Row], quick: bool, total: f64) -> Res<String> {
    let mut md = String::new();
    writeln!(md, "# corofem and rapier3d's FEM soft bodies\n")?;
    writeln!(
        md,
        "Generated by `cargo run --release -p corofem-bench --example peers{}` in {total:.0} s \
         (rapier3d 0.36, feature `fem`). Both engines step the same mesh, lumped masses, \
         E, ν, pins, gravity and dt = 1 ms from rest for {} steps; the reference is the f64 \
         integrator of corofem's scheme with every step solved exactly (bench/src/reference.rs). \
         ms/step: mean over steps 2..N of the fastest of {ROUNDS} interleaved rounds, one core, \
         wall clock (the first step is not timed: rapier builds its sparsity pattern there). \
         Tip: mean z displacement of the nodes at x = max, in mm. Error: relative RMS \
         node-position difference to the reference at the last step, over the RMS reference \
         displacement; trajectory error: the same over every step (the report's metric). \
         The reference's rotation is QR: rapier's polar rotation adds a method difference \
         to its error. One run on a shared 2-core machine: read the ratios as ±20 %. \
         Tip trajectories: peers_tip.csv and peers_tip_<scene>.svg.\n",
        if quick { " -- --quick" } else { "" },
        rows.first().map_or(0, |r| r.steps)
    )?;
    writeln!(
        md,
        "| scene | tets | corofem ms/step | rapier ms/step | rapier / corofem | tip corofem | tip rapier | tip reference | error corofem | error rapier | trajectory error corofem | trajectory error rapier |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    )?;
    for r in rows {
        writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} | **{:.1}×** | {} | {} | {} | {:.1e} | {:.1e} | {:.1e} | {:.1e} |",
            r.scene,
            r.tets,
            r.corofem.ms_best,
            r.rapier.ms_best,
            r.rapier.ms_best / r.corofem.ms_best,
            mm(tip(&r.corofem.u, &r.tip)),
            mm(tip(&r.rapier.u, &r.tip)),
            mm(r.reference_tip),
            rel_err(&r.corofem.u, &r.reference_u),
            rel_err(&r.rapier.u, &r.reference_u),
            r.corofem.traj_err,
            r.rapier.traj_err,
        )?;
    }
    writeln!(
        md,
        "\nrapier with its own solver defaults (4 substeps of 0.25 ms, CG to a relative \
         residual of 1e-5 or at most 20 iterations per substep), same undamped material:\n"
    )?;
    writeln!(
        md,
        "| scene | rapier defaults ms/step | / corofem | tip | error | trajectory error |\n|---|---|---|---|---|---|"
    )?;
    for r in rows {
        writeln!(
            md,
            "| {} | {:.3} | {:.1}× | {} | {:.1e} | {:.1e} |",
            r.scene,
            r.defaults.ms_best,
            r.defaults.ms_best / r.corofem.ms_best,
            mm(tip(&r.defaults.u, &r.tip)),
            rel_err(&r.defaults.u, &r.reference_u),
            r.defaults.traj_err,
        )?;
    }
    writeln!(
        md,
        "\ncorofem at rapier's default accuracy: the smallest CG budget of {BUDGETS:?} \
         whose trajectory error is at most that of rapier with its defaults (above), timed \
         in {ROUNDS} more rounds interleaved with rapier's defaults (whose time here is \
         from those rounds):\n"
    )?;
    writeln!(
        md,
        "| scene | rapier defaults trajectory error | corofem CG budget | corofem trajectory error | corofem ms/step | rapier defaults ms/step | rapier defaults / corofem |\n|---|---|---|---|---|---|---|"
    )?;
    for r in rows {
        let target = r.defaults.traj_err;
        match &r.equal {
            Some(e) => writeln!(
                md,
                "| {} | {:.1e} | {} | {:.1e} | {:.3} | {:.3} | **{:.1}×** |",
                r.scene,
                target,
                e.cg,
                e.corofem.traj_err,
                e.corofem.ms_best,
                e.rapier.ms_best,
                e.rapier.ms_best / e.corofem.ms_best,
            )?,
            None => writeln!(
                md,
                "| {} | {:.1e} | none of {BUDGETS:?} | — | — | {:.3} | — |",
                r.scene, target, r.defaults.ms_best,
            )?,
        }
    }
    writeln!(
        md,
        "\nLargest sag of the tip over the run (mm; less sensitive to the phase of the \
         oscillation than the value at the end):\n"
    )?;
    writeln!(
        md,
        "| scene | corofem | rapier | rapier defaults | reference |\n|---|---|---|---|---|"
    )?;
    for r in rows {
        writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            r.scene,
            mm(peak(&r.corofem.tips)),
            mm(peak(&r.rapier.tips)),
            mm(peak(&r.defaults.tips)),
            mm(peak(&r.reference_tips)),
        )?;
    }
    let statics: Vec<String> = rows
        .iter()
        .filter_map(|r| r.static_tip.map(|s| format!("{} {} mm", r.scene, mm(s))))
        .collect();
    if !statics.is_empty() {
        writeln!(
            md,
            "\nEuler–Bernoulli static tip deflection (the undamped beams oscillate about it): {}.\n",
            statics.join(", ")
        )?;
    }
    for r in rows {
        writeln!(md, "![](peers_tip_{}.svg)", r.scene)?;
    }
    writeln!(md)?;
    md.push_str(SETTINGS);
    Ok(md)
}

/// What rapier is set to and where it cannot match corofem (read from the
/// rapier3d 0.36.1 source).
const SETTINGS: &str = "\
## Settings

| | corofem | rapier3d (matched) |
|---|---|---|
| element | co-rotational linear, rotation from the QR frame of the current edges (Nesme et al. 2005) | `SoftBodyCellModel::Corotational`: linear elasticity in the frame of the polar rotation of F (iterated, warm-started per cell) |
| material | E, ν, ρ | `young_modulus` E, `poisson_ratio` ν (Lamé μ = E/2(1+ν), λ = Eν/((1+ν)(1−2ν)), as corofem) |
| mass | lumped ρ V₀ / 4 per element node | the same per-particle masses (`SoftBodyBuilder::masses`) |
| damping | none | `elastic_damping_ratio` 0, `deformation_damping` 0, `linear_damping` 0 |
| clamp | fixed nodes, Δv = 0 | `pinned_particles` (Dirichlet rows) |
| time step | one linearised implicit Euler step per dt = 1 ms | `num_solver_iterations` = 1 (no substeps), `dt` 1 ms: gravity first added to v (v′ = v + h g), then one `(M + h²K) Δv = h f − h²K v′` solve: the same step as corofem's `(M + h²K) Δv = h (f + M g) − h²K v` when solved exactly, not when truncated |
| linear solve | matrix-free CG, 5 iterations, lumped-mass preconditioner, from Δv = 0 | `SoftFemParameters`: `max_linear_iterations` 5, `linear_tolerance` 0 (no early stop); assembled block-sparse `A`, block-Jacobi PCG from Δv = 0, solution then scaled by its energy minimiser clamped to [0, 1] |
| collisions, sleeping | none | `no_surface_collider()`, `can_sleep(false)` |
| per step, besides | — | `PhysicsWorld::step`: island and broad-phase bookkeeping (no colliders), a step-start copy of `A` for constraint responses (none here), every cell's principal strains for the tear test (no tearing here) |

What cannot match: rapier's rotation is polar, not QR (the same small-strain \
stiffness, a different large-rotation response), its CG has a block-Jacobi \
preconditioner and a final rescaling, and it assembles `A` every substep where \
corofem stays matrix-free. rapier's `fem` solver factorises `A` directly only \
up to `max_dense_dofs` = 600 unknowns (200 particles), below every mesh here. \
With a truncated CG the two splits of the step err in opposite directions: \
rapier gives every free node the whole free-fall increment h g and lets CG take \
back what the elasticity resists, so a short CG leaves the body falling too \
fast; corofem lets CG build the gravity response, so a short CG lags behind it \
(see peers_tip_*.svg).\n";
