//! `corofem-bench [bench] [--quick] [--out DIR] [--page FILE]`: writes the
//! speed-against-error report (CSV, SVG, summary.md) to `target/bench-report/`
//! by default; with `--page docs/bench.md`, also that page's generated
//! section and its SVGs. See docs/bench.md.

mod metrics;
mod plot;

use corofem::{
    ElementBlock, Method, Node, NodeEntry, NodeWork, Preconditioner, ELEMENTS_PER_BLOCK,
};
use corofem_bench::page;
use corofem_bench::reference::{Model, RefMethod, Trajectory};
use corofem_bench::scenes::{self, SceneDef};
use plot::{loglog, Legend, Series};
use std::fmt::Write as _;
use std::io::Write as _;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// A one-line progress bar on stderr.
struct Progress {
    label: String,
    total: usize,
    done: usize,
    start: Instant,
}

impl Progress {
    fn new(label: &str, total: usize) -> Self {
        let p = Self {
            label: label.into(),
            total,
            done: 0,
            start: Instant::now(),
        };
        p.draw();
        p
    }
    fn tick(&mut self) {
        self.done += 1;
        self.draw();
    }
    fn draw(&self) {
        let w = 30;
        let f = if self.total == 0 {
            1.0
        } else {
            self.done as f64 / self.total as f64
        };
        let k = (f * w as f64) as usize;
        let el = self.start.elapsed().as_secs_f64();
        let eta = if self.done > 0 { el / f - el } else { 0.0 };
        eprint!(
            "\r{:<22} [{}{}] {}/{} {:5.1}s eta {:4.0}s ",
            self.label,
            "#".repeat(k),
            "-".repeat(w - k),
            self.done,
            self.total,
            el,
            eta
        );
        let _ = std::io::stderr().flush();
    }
    fn finish(self) {
        eprintln!();
    }
}

/// The command line: `[bench] [--quick] [--out DIR]`.
use corofem_bench::args::ReportArgs as Opts;

fn main() -> Res<()> {
    let Some(o) = corofem_bench::args::report_args(
        "corofem-bench [bench] [--quick] [--out DIR] [--page FILE]",
        &["bench"],
        true,
    )?
    else {
        return Ok(());
    };
    // Figure 7 and the speed-against-error section read the shared meshes:
    // say so up front rather than fail in the middle of the run.
    let meshes = scenes::meshes_dir();
    if !meshes.is_dir() {
        return Err(format!(
            "the report reads the shared meshes (liver, bunny, beams) from {}, which is not \
             a folder: set COROFEM_MESHES to where they are",
            meshes.display()
        )
        .into());
    }
    let quick = o.quick;
    let t0 = Instant::now();
    let mut md = String::new();
    writeln!(
        md,
        "# Benchmark report{}\n",
        if quick { " (quick run)" } else { "" }
    )?;
    writeln!(md, "{}", page::provenance(&o.words))?;
    writeln!(
        md,
        "Generated in {{TOTAL}} s of running. Times are wall-clock, on one core, the fastest \
         of three rounds; on a shared machine compare ratios within this report rather than \
         times across reports. docs/bench.md says how each figure is measured.\n"
    )?;
    memory(&o, &mut md)?;
    isa(&o, &mut md)?;
    fig7(&o, &mut md)?;
    fig4(&o, &mut md)?;
    pareto(&o, &mut md)?;
    metrics::metrics(&o, &mut md)?;
    let total = t0.elapsed().as_secs_f64();
    let md = md.replace("{TOTAL}", &format!("{total:.0}"));
    std::fs::write(o.out.join("summary.md"), &md)?;
    eprintln!("report in {} ({total:.0} s)", o.out.display());
    if let Some(p) = &o.page {
        page::write_page(p, &md, &o.out)?;
        eprintln!("figures written into {}", p.display());
    }
    Ok(())
}

/// Steps `scene` in three rounds of at least `min_s / 3` seconds each (after
/// 2 warm-up steps) and returns (ms per step of the fastest round, mean CG
/// iterations). The fastest round filters out other processes on a shared
/// machine.
fn time_steps(scene: &mut corofem::VecScene, min_s: f64, max_steps: usize) -> (f64, f64) {
    time_steps_with(scene, min_s, max_steps, |s| s.step())
}

/// [`time_steps`] with a given stepping function.
fn time_steps_with(
    scene: &mut corofem::VecScene,
    min_s: f64,
    max_steps: usize,
    step: Stepper,
) -> (f64, f64) {
    for _ in 0..2 {
        let _ = step(scene);
    }
    let mut best = (f64::MAX, 0.0);
    for _ in 0..3 {
        let r = time_round(scene, min_s / 3.0, max_steps, step);
        if r.0 < best.0 {
            best = r;
        }
    }
    best
}

/// One step of a heap scene.
type Stepper = fn(&mut corofem::VecScene) -> Result<corofem::StepStats, corofem::StepError>;

/// The 10 368-tet cube (`cube_13n_t6`'s grid), Qr, 5 CG iterations, dt 1 ms:
/// the step with the baseline instruction set against the best the CPU
/// supports (what `Scene::step` uses), in the same run, and the bits of both.
fn isa(o: &Opts, md: &mut String) -> Res<()> {
    let def = scenes::boxed("cube10k", [1.0, 1.0, 1.0], [12, 12, 12], 1.0e6);
    let min_s = if o.quick { 0.6 } else { 3.0 };
    let isa = corofem::InstructionSet::best().name();
    let baseline = |mut s: corofem::VecScene| {
        s.set_instruction_set(Some(corofem::InstructionSet::Baseline))
            .map(|()| s)
    };
    let mut base = baseline(def.core(Method::Qr, 1e-3, 5))?;
    let mut fast = def.core(Method::Qr, 1e-3, 5);
    let (t_base, _) = time_steps_with(&mut base, min_s, 100_000, |s| s.step());
    let (t_fast, _) = time_steps_with(&mut fast, min_s, 100_000, |s| s.step());
    // Same number of steps on both, then compare the bits.
    let mut a = baseline(def.core(Method::Qr, 1e-3, 5))?;
    let mut b = def.core(Method::Qr, 1e-3, 5);
    for _ in 0..50 {
        let _ = a.step();
        let _ = b.step();
    }
    let same = a.state_hash() == b.state_hash();
    writeln!(md, "## Instruction sets (10 368 tets, Qr, 5 CG, dt 1 ms)\n")?;
    writeln!(md, "| build | ms/step |\n|---|---|")?;
    writeln!(md, "| baseline (SSE2) | {t_base:.3} |")?;
    writeln!(md, "| best supported: {isa} | {t_fast:.3} |")?;
    writeln!(
        md,
        "\nSame bits after 50 steps: {}. Every other timing in this report uses the \
         best supported instruction set ({isa}).\n",
        if same { "yes" } else { "**no**" }
    )?;
    eprintln!("isa: baseline {t_base:.3} ms, {isa} {t_fast:.3} ms, same bits: {same}");
    if !same {
        return Err("the best instruction set changed the bits".into());
    }
    Ok(())
}

fn time_round(
    scene: &mut corofem::VecScene,
    min_s: f64,
    max_steps: usize,
    step: Stepper,
) -> (f64, f64) {
    let (mut n, mut it) = (0usize, 0u64);
    let start = Instant::now();
    while n < 3 || (start.elapsed().as_secs_f64() < min_s && n < max_steps) {
        if let Ok(s) = step(scene) {
            it += u64::from(s.cg_iterations);
        }
        n += 1;
    }
    (
        start.elapsed().as_secs_f64() * 1e3 / n as f64,
        it as f64 / n as f64,
    )
}

// ---------------------------------------------------------------- memory

fn memory(o: &Opts, md: &mut String) -> Res<()> {
    let (node, work, elem, entry) = (
        std::mem::size_of::<Node>(),
        std::mem::size_of::<NodeWork>(),
        std::mem::size_of::<ElementBlock>() / ELEMENTS_PER_BLOCK,
        std::mem::size_of::<NodeEntry>(),
    );
    let mut csv = String::from("item,bytes,note\n");
    writeln!(csv, "Node,{node},state per node (features: full)")?;
    writeln!(csv, "NodeWork,{work},CG scratch per node")?;
    writeln!(
        csv,
        "Element,{elem},per element: ElementBlock / ELEMENTS_PER_BLOCK (features: full)"
    )?;
    writeln!(csv, "per_node,{},Node + NodeWork", node + work)?;
    writeln!(
        csv,
        "NodeEntry,{entry},per grab slot or load slot (sized per scene)"
    )?;
    std::fs::write(o.out.join("memory.csv"), csv)?;
    let cube = (12u64 * 12 * 12 * 6, 13u64 * 13 * 13);
    writeln!(md, "## Memory (size_of, features `full`)\n")?;
    writeln!(md, "| item | bytes |\n|---|---|")?;
    writeln!(
        md,
        "| `Node` (state) | {node} |\n| `NodeWork` (CG scratch) | {work} |"
    )?;
    writeln!(
        md,
        "| **per node** | **{}** |\n| **per element** (`ElementBlock` / {ELEMENTS_PER_BLOCK}) | **{elem}** |\n\
         | `NodeEntry`, per grab or load slot (only the nodes the tool holds or a force acts on) | {entry} |",
        node + work
    )?;
    writeln!(
        md,
        "\nPer-feature breakdown (from the layouts documented in core/src/storage.rs and \
         element/mod.rs; a single binary can only measure one feature set; the core unit test \
         `storage_sizes_per_feature` checks the sums): an element is 72 bytes with `qr` alone, \
         +36 with `polar` or `linear` (rest gradients), +16 with `polar` (rotation); `Node` is \
         44 bytes and `NodeWork` 52, 68 with `ground` (its push-out keeps the step's velocity \
         change and contact impulse): the tool's grab offsets and the constant loads are \
         16-byte slots in lists sized per scene, one per grabbed or loaded node. A `qr` scene \
         therefore keeps 72 bytes per element and 96 per node; with every feature 124 and \
         112, plus 16 per grabbed or loaded node.\n"
    )?;
    writeln!(
        md,
        "Example: a 12×12×12-cell cube ({} tets, {} nodes) takes {:.0} kB here.\n",
        cube.0,
        cube.1,
        (cube.0 * elem as u64 + cube.1 * (node + work) as u64) as f64 / 1e3
    )?;
    Ok(())
}

// ---------------------------------------------------------------- Figure 7

fn methods() -> [(Method, &'static str); 4] {
    [
        (Method::Linear, "Linear"),
        (Method::Polar, "Polar"),
        (Method::Qr, "Qr"),
        (Method::QrRestB, "QrRestB"),
    ]
}

/// A mesh file held at its lowest 5 % in y (for timing only).
fn timing_mesh(name: &str, file: &str, scale: f64) -> SceneDef {
    let mut s = scenes::from_file(name, &scenes::meshes_dir().join(file), scale);
    let (lo, hi) = s
        .nodes
        .iter()
        .fold((f32::MAX, f32::MIN), |(l, h), p| (l.min(p[1]), h.max(p[1])));
    let cut = lo + 0.05 * (hi - lo);
    s.fixed = (0..s.nodes.len() as u32)
        .filter(|&i| s.nodes[i as usize][1] <= cut)
        .collect();
    s
}

fn fig7(o: &Opts, md: &mut String) -> Res<()> {
    let ks: &[u32] = if o.quick {
        &[6, 8, 10, 12]
    } else {
        &[6, 8, 10, 12, 14, 16, 18, 20]
    };
    let mut defs: Vec<(SceneDef, bool)> = ks
        .iter()
        .map(|&k| {
            (
                scenes::boxed(&format!("box{k}"), [1.0, 1.0, 1.0], [k, k, k], 1.0e6),
                true,
            )
        })
        .collect();
    let mut files = vec![
        ("sofa_liver", "sofa_liver.tetmesh", 0.03),
        ("bunny_1k", "bunny_ftw_1k.tetmesh", 1.0),
        ("bunny_3k", "bunny_ftw_3k.tetmesh", 1.0),
        ("liver_3k", "liver_ftw_3k.tetmesh", 1.0),
    ];
    if !o.quick {
        files.push(("beam_h025_t6", "beam_10x2x2_h025_t6.tetmesh", 0.1));
    }
    for (n, f, s) in files {
        defs.push((timing_mesh(n, f, s), false));
    }
    let min_s = if o.quick { 0.06 } else { 0.25 };
    let mut csv = String::from("mesh,kind,tets,nodes,method,cg_iterations,ms_per_step\n");
    let mut res: Vec<(String, bool, usize, usize, ms4)> = Vec::new();
    #[allow(non_camel_case_types)]
    type ms4 = [f64; 4];
    let mut bar = Progress::new("Figure 7", defs.len() * 4);
    for (d, generated) in &defs {
        let mut ms = [0.0; 4];
        for (k, (m, name)) in methods().iter().enumerate() {
            let mut sc = d.core(*m, 1.0e-3, 5);
            let (t, it) = time_steps(&mut sc, min_s, 100_000);
            ms[k] = t;
            writeln!(
                csv,
                "{},{},{},{},{name},{it:.1},{t:.5}",
                d.name,
                if *generated { "box" } else { "mesh" },
                d.tets.len(),
                d.nodes.len()
            )?;
            bar.tick();
        }
        res.push((d.name.clone(), *generated, d.tets.len(), d.nodes.len(), ms));
    }
    bar.finish();
    std::fs::write(o.out.join("fig7_time_vs_tets.csv"), csv)?;
    let mut series = Vec::new();
    for (k, (_, name)) in methods().iter().enumerate() {
        series.push(Series {
            name: format!("{name} (boxes)"),
            points: res
                .iter()
                .filter(|r| r.1)
                .map(|r| (r.2 as f64, r.4[k]))
                .collect(),
            line: true,
            labels: Vec::new(),
            color: k,
            marker: 0,
        });
    }
    series.push(Series {
        name: "Qr (shared meshes)".into(),
        points: res
            .iter()
            .filter(|r| !r.1)
            .map(|r| (r.2 as f64, r.4[2]))
            .collect(),
        line: false,
        labels: res.iter().filter(|r| !r.1).map(|r| r.0.clone()).collect(),
        color: 7,
        marker: 1,
    });
    loglog(
        &o.out.join("fig7_time_vs_tets.svg"),
        "Figure 7: time per step, 5 CG iterations, dt = 1 ms",
        "tetrahedra",
        "ms per step",
        &series,
        Legend::UpperLeft,
    )?;
    writeln!(
        md,
        "## Figure 7: time per step against tetrahedra (5 CG iterations)\n"
    )?;
    writeln!(md, "![](fig7_time_vs_tets.svg)\n")?;
    writeln!(md, "| mesh | tets | nodes | Linear ms | Polar ms | Qr ms | QrRestB ms | Polar/Qr |\n|---|---|---|---|---|---|---|---|")?;
    for r in &res {
        writeln!(
            md,
            "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} |",
            r.0,
            r.2,
            r.3,
            r.4[0],
            r.4[1],
            r.4[2],
            r.4[3],
            r.4[1] / r.4[2]
        )?;
    }
    writeln!(md)?;
    Ok(())
}

// ---------------------------------------------------------------- Figure 4

fn fig4(o: &Opts, md: &mut String) -> Res<()> {
    let k = if o.quick { 8 } else { 12 };
    // Stiff and a long step so CG does not reach its f32 floor by 100 iterations.
    let d = scenes::boxed("cube", [1.0, 1.0, 1.0], [k, k, k], 1.0e9);
    let dt = 8.0e-3;
    let ns: &[u32] = &[1, 2, 3, 5, 10, 20, 50, 100];
    let min_s = if o.quick { 0.1 } else { 0.4 };
    let mut mf = Vec::new();
    let mut bar = Progress::new("Figure 4", ns.len() + 2);
    for &n in ns {
        let mut sc = d.core(Method::Qr, dt, n);
        let (t, it) = time_steps(&mut sc, min_s, 100_000);
        mf.push((it, t));
        bar.tick();
    }
    // Matrix-free cost per CG iteration: least-squares slope of t against iterations.
    let m = mf.len() as f64;
    let (sx, sy) = mf.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (sxx, sxy) = mf
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 * p.0, a.1 + p.0 * p.1));
    let slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
    let base = mf[0].1 - slope * mf[0].0; // step without CG iterations
                                          // Assembled f32 block-CSR stiffness on the host, same kernel as the reference.
    let mut asm: Model<f32> = Model::new(&d.nodes, &d.tets, 1.0e9, 0.3, 1000.0, &d.fixed);
    let reps = if o.quick { 5 } else { 20 };
    let t = Instant::now();
    for _ in 0..reps {
        asm.assemble();
    }
    let t_asm = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    bar.tick();
    let x: Vec<[f32; 3]> = (0..asm.nodes())
        .map(|i| [i as f32 * 1e-3, 1.0, -0.5])
        .collect();
    let mut y = vec![[0.0f32; 3]; asm.nodes()];
    let reps = if o.quick { 50 } else { 300 };
    let t = Instant::now();
    for _ in 0..reps {
        asm.k.mul(std::hint::black_box(&x), &mut y);
        std::hint::black_box(&y);
    }
    // SpMV plus the same per-node vector work the matrix-free CG does
    // (~the slope minus the element pass): counted in `slope` for both.
    let t_spmv = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
    bar.tick();
    bar.finish();
    let assembled = |n: f64| base + t_asm + n * t_spmv;
    let mut csv = String::from("cg_iterations,matrix_free_ms,assembled_model_ms\n");
    for &(it, t) in &mf {
        writeln!(csv, "{it:.2},{t:.5},{:.5}", assembled(it))?;
    }
    std::fs::write(o.out.join("fig4_cg_iterations.csv"), csv)?;
    let crossover = if slope > t_spmv {
        Some(t_asm / (slope - t_spmv))
    } else {
        None
    };
    let series = vec![
        Series {
            name: "matrix-free (core, measured)".into(),
            points: mf.iter().map(|&(i, t)| (i, t)).collect(),
            line: true,
            labels: Vec::new(),
            color: 0,
            marker: 0,
        },
        Series {
            name: "assembled block-CSR (host model)".into(),
            points: mf.iter().map(|&(i, _)| (i, assembled(i))).collect(),
            line: true,
            labels: Vec::new(),
            color: 3,
            marker: 1,
        },
    ];
    loglog(
        &o.out.join("fig4_cg_iterations.svg"),
        &format!(
            "Figure 4: time per step against CG iterations ({} tets, Qr)",
            d.tets.len()
        ),
        "CG iterations per step",
        "ms per step",
        &series,
        Legend::UpperLeft,
    )?;
    writeln!(
        md,
        "## Figure 4: matrix-free against an assembled stiffness\n"
    )?;
    writeln!(md, "![](fig4_cg_iterations.svg)\n")?;
    writeln!(
        md,
        "Cube of {} tets, {} nodes, Qr, dt 8 ms, E = 1e9 Pa (CG does not converge early). \
         Matrix-free: the core's step, measured; one CG iteration costs **{slope:.3} ms** \
         (least-squares slope), the rest of the step {base:.3} ms. Assembled: the same step \
         with the 3×3-block CSR stiffness assembled on the host in f32 ({} blocks, \
         {:.0} kB) — assembly **{t_asm:.3} ms** per step, one product **{t_spmv:.3} ms** — \
         modelled as `rest + assembly + n × product`.\n",
        d.tets.len(),
        d.nodes.len(),
        asm.k.blocks(),
        asm.k.blocks() as f64 * 36.0 / 1e3
    )?;
    match crossover {
        Some(c) => writeln!(
            md,
            "Assembly pays off above **{c:.0} CG iterations** per step.\n"
        )?,
        None => writeln!(
            md,
            "The assembled product is not faster per iteration here: assembly never pays off.\n"
        )?,
    }
    Ok(())
}

// ---------------------------------------------------------------- Pareto

/// Relative errors of one core run: (solve error against the same-dt
/// reference over every step, total error against the fine reference at the
/// sample times).
struct Run {
    method: &'static str,
    dt_ms: f64,
    cg: String,
    iters: f64,
    ms_step: f64,
    err_solve: f64,
    err_total: f64,
    diverged: bool,
}

/// The speed-against-error grid: time steps, CG budgets and horizons.
struct Grid {
    /// Time steps (ms).
    dts_ms: [f64; 6],
    /// CG budgets and their labels.
    cgs: [(u32, &'static str); 7],
    /// Length of each run (ms).
    horizon_ms: f64,
    /// Time step of the fine reference (ms).
    fine_ms: f64,
    /// Interval at which runs are compared with the fine reference (ms).
    sample_ms: f64,
}

impl Grid {
    /// Steps of `dt_ms` between two samples.
    fn sample_every(&self, dt_ms: f64) -> usize {
        (self.sample_ms / dt_ms).round() as usize
    }
}

fn pareto(o: &Opts, md: &mut String) -> Res<()> {
    let meshes = scenes::meshes_dir();
    let mut defs = vec![scenes::beam(), scenes::liver(&meshes)];
    if !o.quick {
        defs.push(scenes::bunny(&meshes));
    }
    let grid = Grid {
        dts_ms: [0.25, 0.5, 1.0, 2.0, 4.0, 8.0],
        cgs: [
            (1, "1"),
            (2, "2"),
            (3, "3"),
            (5, "5"),
            (10, "10"),
            (20, "20"),
            (2000, "conv"),
        ],
        horizon_ms: if o.quick { 80.0 } else { 200.0 },
        fine_ms: if o.quick { 0.25 } else { 0.125 },
        sample_ms: 8.0,
    };
    let Grid {
        horizon_ms,
        fine_ms,
        sample_ms,
        ..
    } = grid;
    // Each method against the reference of its own rotation, with the
    // paper's CG.
    let methods = [
        (Method::Qr, RefMethod::Qr, "Qr"),
        (Method::Polar, RefMethod::Polar, "Polar"),
    ];
    // The default solver (`qr-invertible`, `two-level`, warm start),
    // against the QR reference: its budgets include the default, 4.
    let default_grid = Grid {
        cgs: [
            (1, "1"),
            (2, "2"),
            (3, "3"),
            (4, "4"),
            (5, "5"),
            (10, "10"),
            (2000, "conv"),
        ],
        ..grid
    };
    let mut csv = String::from(
        "scene,tets,method,dt_ms,cg,mean_cg_iterations,ms_per_step,ms_per_simulated_s,err_vs_same_dt_reference,err_vs_fine_reference,diverged\n",
    );
    writeln!(md, "## Speed against error (Qr and Polar)\n")?;
    writeln!(
        md,
        "Each run starts at rest and lasts {horizon_ms} ms. *Solve error*: relative RMS of the \
         node-position difference to the f64 reference of the same method with the same dt \
         (linear systems solved to 1e-12), over every step, divided by the RMS reference \
         displacement — the cost of truncated f32 CG. *Total error*: the same against an f64 \
         reference of the same method at dt = {fine_ms} ms, at every {sample_ms} ms — adds the \
         time-discretisation error. The QR and polar references are the same scheme with the \
         element rotation of each method (bench/src/reference.rs).\n"
    )?;
    let mut defaults = String::new();
    for d in &defs {
        let mut all_runs = Vec::new();
        let solver = (Method::QrInvertible, RefMethod::Qr, DEFAULT_SOLVER);
        let default_runs =
            method_runs(&default_grid, d, solver, Preconditioner::TwoLevel, &mut csv)?;
        for &(method, ref_method, mname) in &methods {
            let runs = method_runs(
                &grid,
                d,
                (method, ref_method, mname),
                Preconditioner::Mass,
                &mut csv,
            )?;
            // The default solver beside the paper's CG, on QR's plots.
            let overlay = if method == Method::Qr {
                &default_runs[..]
            } else {
                &[]
            };
            method_report(o, md, &grid, d, method, &runs, overlay)?;
            dt1_row(&mut defaults, d, mname, &runs, "5")?;
            all_runs.extend(runs);
        }
        writeln!(
            md,
            "### {} ({} tets), {DEFAULT_SOLVER}\n\n{DEFAULT_SETTINGS}, against the QR \
             reference (drawn on the Qr plots above at dt 1 ms).\n",
            d.name,
            d.tets.len()
        )?;
        solve_table(md, &default_grid, &default_runs)?;
        let label = format!("{DEFAULT_SOLVER}, 4 iterations");
        dt1_row(&mut defaults, d, &label, &default_runs, "4")?;
        all_runs.extend(default_runs);
        methods_plot(o, md, d, &all_runs, fine_ms)?;
    }
    std::fs::write(o.out.join("pareto.csv"), csv)?;
    writeln!(
        md,
        "### The paper's CG (lumped mass, 5 iterations) and the default solver, dt 1 ms\n\n\
         The default solver's time against the paper's CG, interleaved in one process, is in \
         docs/bench.md, \"Preconditioners\".\n"
    )?;
    writeln!(
        md,
        "| scene | tets | method | ms/step | solve error | total error |\n|---|---|---|---|---|---|\n{defaults}"
    )?;
    Ok(())
}

/// Every (dt, CG) run of one scene and method against the f64 references of
/// that method (one per dt, and a fine one), each run's row appended to
/// `csv`.
fn method_runs(
    grid: &Grid,
    d: &SceneDef,
    (method, ref_method, mname): (Method, RefMethod, &'static str),
    pre: Preconditioner,
    csv: &mut String,
) -> Res<Vec<Run>> {
    let total = 1 + grid.dts_ms.len() * (1 + grid.cgs.len());
    let mut bar = Progress::new(&format!("error: {} {mname}", d.name), total);
    // Fine reference at the sample times.
    let mut fine = d.reference().with_method(ref_method);
    let fs = d.ref_settings(grid.fine_ms * 1e-3);
    let mut fine_samples = Trajectory::default();
    let every = grid.sample_every(grid.fine_ms);
    let samples = (grid.horizon_ms / grid.sample_ms).round() as usize;
    for s in 1..=samples * every {
        fine.step(&fs);
        if s % every == 0 {
            fine_samples.push(&fine.u);
        }
    }
    bar.tick();
    let mut runs = Vec::new();
    for &dt_ms in &grid.dts_ms {
        let steps = (grid.horizon_ms / dt_ms).round() as usize;
        let mut r = d.reference().with_method(ref_method);
        let rs = d.ref_settings(dt_ms * 1e-3);
        let mut traj = Trajectory::default();
        for _ in 0..steps {
            r.step(&rs);
            traj.push(&r.u);
        }
        bar.tick();
        let every = grid.sample_every(dt_ms);
        for &(cg, label) in &grid.cgs {
            let mut sc = d.core_with(method, (dt_ms * 1e-3) as f32, cg, pre);
            let (mut e_s, mut e_t, mut secs, mut its) = (0.0f64, 0.0f64, 0.0f64, 0u64);
            let mut diverged = false;
            for s in 0..steps {
                let t = Instant::now();
                let st = sc.step();
                // The first step, which prepares a preconditioner's
                // aggregates and coarse inverse, is not timed: a loop takes
                // it once, before it runs in real time.
                if s > 0 {
                    secs += t.elapsed().as_secs_f64();
                }
                match st {
                    Ok(st) => its += u64::from(st.cg_iterations),
                    Err(_) => {
                        diverged = true;
                        break;
                    }
                }
                let u = || {
                    (0..sc.node_count() as u32)
                        .map(|i| sc.displacement(i).unwrap_or([f32::NAN; 3]).map(f64::from))
                };
                e_s += traj.sq_err(s, u());
                if (s + 1) % every == 0 {
                    e_t += fine_samples.sq_err((s + 1) / every - 1, u());
                }
            }
            let run = Run {
                method: mname,
                dt_ms,
                cg: label.into(),
                iters: its as f64 / steps as f64,
                ms_step: secs * 1e3 / steps.saturating_sub(1).max(1) as f64,
                err_solve: traj.relative(e_s),
                err_total: fine_samples.relative(e_t),
                diverged,
            };
            writeln!(
                csv,
                "{},{},{mname},{},{},{:.2},{:.5},{:.3},{:.4e},{:.4e},{}",
                d.name,
                d.tets.len(),
                dt_ms,
                run.cg,
                run.iters,
                run.ms_step,
                run.ms_step * 1e3 / dt_ms,
                run.err_solve,
                run.err_total,
                run.diverged
            )?;
            runs.push(run);
            bar.tick();
        }
    }
    bar.finish();
    Ok(runs)
}

/// The name of the default solver's runs in the report, and its settings.
const DEFAULT_SOLVER: &str = "default solver";
const DEFAULT_SETTINGS: &str = "`qr-invertible`, `two-level`, warm start";

/// The row of the dt 1 ms table for the run of `runs` with the CG budget
/// `cg`, if there is one.
fn dt1_row(table: &mut String, d: &SceneDef, label: &str, runs: &[Run], cg: &str) -> Res<()> {
    if let Some(r) = runs.iter().find(|r| r.dt_ms == 1.0 && r.cg == cg) {
        writeln!(
            table,
            "| {} | {} | {label} | {:.3} | {:.2e} | {:.2e} |",
            d.name,
            d.tets.len(),
            r.ms_step,
            r.err_solve,
            r.err_total
        )?;
    }
    Ok(())
}

/// The plots and the solve-error table of one scene and method, with the
/// runs `overlay` (another solver against the same reference) drawn beside
/// them with another marker.
fn method_report(
    o: &Opts,
    md: &mut String,
    grid: &Grid,
    d: &SceneDef,
    method: Method,
    runs: &[Run],
    overlay: &[Run],
) -> Res<()> {
    let Some(mname) = runs.first().map(|r| r.method) else {
        return Ok(());
    };
    let ok = |r: &&Run| !r.diverged && r.err_solve.is_finite();
    let mut s1 = Vec::new();
    let mut s2 = Vec::new();
    // One line per dt of the method's runs (circles), and of the overlay's
    // at dt 1 ms (triangles): the default dt, where the solvers compare.
    let lines = grid
        .dts_ms
        .iter()
        .enumerate()
        .map(|(k, &dt)| (k, dt, runs, mname, 0))
        .chain(
            grid.dts_ms
                .iter()
                .position(|&dt| dt == 1.0)
                .filter(|_| !overlay.is_empty())
                .map(|k| (k, 1.0, overlay, DEFAULT_SOLVER, 1)),
        );
    for (k, dt_ms, runs, name, marker) in lines {
        let rs: Vec<&Run> = runs
            .iter()
            .filter(|r| r.dt_ms == dt_ms)
            .filter(ok)
            .collect();
        let labels = if dt_ms == 1.0 {
            rs.iter().map(|r| r.cg.clone()).collect()
        } else {
            Vec::new()
        };
        let name = if marker == 0 && overlay.is_empty() {
            format!("dt {dt_ms} ms")
        } else {
            format!("{name}, dt {dt_ms} ms")
        };
        s1.push(Series {
            name: name.clone(),
            points: rs
                .iter()
                .map(|r| (r.ms_step, r.err_solve.max(1e-9)))
                .collect(),
            line: true,
            labels: labels.clone(),
            color: k,
            marker,
        });
        s2.push(Series {
            name,
            points: rs
                .iter()
                .map(|r| (r.ms_step * 1e3 / dt_ms, r.err_total.max(1e-9)))
                .collect(),
            line: true,
            labels,
            color: k,
            marker,
        });
    }
    // Qr's plots have no suffix: docs link to those names.
    let suffix = if method == Method::Qr { "" } else { "_polar" };
    loglog(
        &o.out.join(format!("pareto_solve_{}{suffix}.svg", d.name)),
        &format!(
            "{} ({} tets): truncated-CG error, {mname} (labels: CG iterations)",
            d.name,
            d.tets.len()
        ),
        "ms per step",
        "relative RMS position error vs f64 reference, same dt",
        &s1,
        Legend::UpperRight,
    )?;
    loglog(
        &o.out.join(format!("pareto_total_{}{suffix}.svg", d.name)),
        &format!(
            "{} ({} tets): total error, {mname} (labels: CG iterations)",
            d.name,
            d.tets.len()
        ),
        "ms of computation per simulated second",
        &format!(
            "relative RMS error vs f64 reference, dt {} ms",
            grid.fine_ms
        ),
        &s2,
        Legend::UpperRight,
    )?;
    writeln!(
        md,
        "### {} ({} tets, {} nodes), {mname}\n",
        d.name,
        d.tets.len(),
        d.nodes.len()
    )?;
    writeln!(
        md,
        "![](pareto_solve_{0}{suffix}.svg)\n![](pareto_total_{0}{suffix}.svg)\n",
        d.name
    )?;
    if !overlay.is_empty() {
        writeln!(
            md,
            "Triangles: the {DEFAULT_SOLVER} ({DEFAULT_SETTINGS}) at dt 1 ms, against the \
             same QR reference.\n"
        )?;
    }
    solve_table(md, grid, runs)
}

/// The solve-error table of one scene's runs of one solver.
fn solve_table(md: &mut String, grid: &Grid, runs: &[Run]) -> Res<()> {
    let Some(mname) = runs.first().map(|r| r.method) else {
        return Ok(());
    };
    writeln!(
        md,
        "Solve error, {mname} (rows: dt in ms; columns: CG iterations):\n"
    )?;
    write!(md, "| dt \\ CG |")?;
    for (_, l) in &grid.cgs {
        write!(md, " {l} |")?;
    }
    writeln!(md, "\n|---|{}", "---|".repeat(grid.cgs.len()))?;
    for &dt_ms in &grid.dts_ms {
        write!(md, "| {dt_ms} |")?;
        for r in runs.iter().filter(|r| r.dt_ms == dt_ms) {
            if r.diverged {
                write!(md, " diverged |")?;
            } else {
                write!(md, " {:.1e} |", r.err_solve)?;
            }
        }
        writeln!(md)?;
    }
    writeln!(md)?;
    Ok(())
}

/// The Pareto front across methods: every (dt, CG) run of each method of
/// one scene, cost per simulated second against total error, a marker per
/// run and a colour per method, to `pareto_methods_<scene>.svg`.
fn methods_plot(o: &Opts, md: &mut String, d: &SceneDef, runs: &[Run], fine_ms: f64) -> Res<()> {
    let mut names: Vec<&str> = runs.iter().map(|r| r.method).collect();
    names.dedup();
    let series: Vec<Series> = names
        .iter()
        .enumerate()
        .map(|(k, &m)| Series {
            name: m.to_string(),
            points: runs
                .iter()
                .filter(|r| r.method == m && !r.diverged && r.err_total.is_finite())
                .map(|r| (r.ms_step * 1e3 / r.dt_ms, r.err_total.max(1e-9)))
                .collect(),
            line: false,
            labels: Vec::new(),
            color: k,
            marker: k as u8,
        })
        .collect();
    loglog(
        &o.out.join(format!("pareto_methods_{}.svg", d.name)),
        &format!(
            "{} ({} tets): total error of every dt and CG budget, per method",
            d.name,
            d.tets.len()
        ),
        "ms of computation per simulated second",
        &format!("relative RMS error vs f64 reference, dt {fine_ms} ms"),
        &series,
        Legend::UpperRight,
    )?;
    writeln!(
        md,
        "Both methods with the paper's CG, and the {DEFAULT_SOLVER}, of {0} on one plot (each \
         point a dt and CG budget; the lower-left envelope is the Pareto front):\n\n\
         ![](pareto_methods_{0}.svg)\n",
        d.name
    )?;
    Ok(())
}
