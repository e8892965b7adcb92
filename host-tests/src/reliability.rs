//! Reliability runs shared by the `sweep` and `soak` binaries (the long
//! versions, reported in docs/reliability.md) and by tests/reliability.rs
//! (the short versions CI runs).
//!
//! * The **sweep** takes a body (the liver, the bunny, a beam, a beam with a
//!   layer of slivers), pulls a patch of it violently through itself with the
//!   haptic tool, holds, releases and lets it recover under damping, for
//!   extreme values of Young's modulus, Poisson ratio, time step and CG
//!   iterations. Each run must stay finite, keep its energy below the work
//!   the tool put in (no blow-up), and come back within 1% of its rest shape.
//! * The **soak** drags the liver around at random for a million steps, and
//!   every so often lets go and checks it recovers.

use std::time::Instant;

use corofem::{Material, Method, Settings, StepError};

use crate::{box_mesh, f64v, shared_mesh, CoreMesh, Rng};
use corofem::VecScene;

/// A body to torture: mesh, held nodes and the patch the tool pulls.
#[derive(Clone, Debug)]
pub struct Body {
    /// Short name for tables.
    pub name: &'static str,
    /// The mesh (m).
    pub mesh: CoreMesh,
    /// Fixed nodes.
    pub fixed: Vec<u32>,
    /// Nodes the tool grabs.
    pub grabbed: Vec<u32>,
    /// Diagonal of the rest bounding box (m).
    pub size: f64,
    /// Where the pull ends, relative to the grabbed centroid (m): through the
    /// body, past the fixed nodes.
    pub pull: [f32; 3],
    /// Smallest rest dihedral angle (degrees).
    pub min_dihedral: f64,
    /// Density (kg/m³).
    pub density: f32,
}

fn bbox_diagonal(mesh: &CoreMesh) -> f64 {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in &mesh.nodes {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    f64v::norm([hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]])
}

fn centroid(mesh: &CoreMesh, ids: &[u32]) -> [f64; 3] {
    let n = ids.len() as f64;
    ids.iter().fold([0.0; 3], |c, &i| {
        let p = f64v::up(mesh.nodes[i as usize]);
        [c[0] + p[0] / n, c[1] + p[1] / n, c[2] + p[2] / n]
    })
}

/// Smallest dihedral angle over all tetrahedra (degrees).
pub fn min_dihedral(mesh: &CoreMesh) -> f64 {
    mesh.tets
        .iter()
        .flat_map(|t| corofem_io::dihedral_angles_deg(&t.map(|i| f64v::up(mesh.nodes[i as usize]))))
        .fold(f64::MAX, f64::min)
}

/// Completes a body: the `count` nodes farthest from the fixed ones are
/// grabbed, and the pull goes `reach` times the distance between the two
/// centroids, through the body towards (and past) the fixed nodes.
fn body(name: &'static str, mesh: CoreMesh, fixed: Vec<u32>, count: usize, reach: f64) -> Body {
    let fc = centroid(&mesh, &fixed);
    let dist = |i: u32| {
        let p = f64v::up(mesh.nodes[i as usize]);
        f64v::norm([p[0] - fc[0], p[1] - fc[1], p[2] - fc[2]])
    };
    let mut order: Vec<u32> = (0..mesh.nodes.len() as u32).collect();
    order.sort_by(|&a, &b| dist(b).total_cmp(&dist(a)));
    let grabbed: Vec<u32> = order[..count].to_vec();
    let gc = centroid(&mesh, &grabbed);
    let pull = [0, 1, 2].map(|k| (reach * (fc[k] - gc[k])) as f32);
    Body {
        name,
        size: bbox_diagonal(&mesh),
        min_dihedral: min_dihedral(&mesh),
        mesh,
        fixed,
        grabbed,
        pull,
        density: 1000.0,
    }
}

/// SOFA's liver scaled to 0.2 m (as examples/scenes/liver_pull.toml), held
/// at SOFA's three nodes 3, 39 and 64. Needs the shared meshes
/// ([`shared_mesh`]).
pub fn liver() -> Body {
    let mut mesh = shared_mesh("sofa_liver.tetmesh");
    for p in &mut mesh.nodes {
        *p = p.map(|c| c * 0.03);
    }
    body("liver", mesh, vec![3, 39, 64], 10, 1.5)
}

/// The Stanford bunny (fTetWild, 1k tets, 0.155 m), held at its lowest
/// nodes. Needs the shared meshes ([`shared_mesh`]).
pub fn bunny() -> Body {
    let mesh = shared_mesh("bunny_ftw_1k.tetmesh");
    let zmin = mesh.nodes.iter().map(|p| p[2]).fold(f32::MAX, f32::min);
    let fixed = mesh.select(|p| p[2] < zmin + 0.01);
    body("bunny", mesh, fixed, 10, 1.5)
}

/// A 1 × 0.2 × 0.2 m beam of 10 × 2 × 2 cubes (240 tets), clamped at x = 0:
/// the shared `beam_10x2x2_h1_t6` scaled to 1 m, generated here.
pub fn beam() -> Body {
    let mesh = box_mesh([1.0, 0.2, 0.2], [10, 2, 2], 6);
    let fixed = mesh.select(|p| p[0] == 0.0);
    body("beam", mesh, fixed, 9, 1.5)
}

/// The beam with its sixth layer of cubes squashed from 0.1 m to 0.5 mm
/// thick: 24 tetrahedra with rest dihedral angles under 1°.
pub fn sliver_beam() -> Body {
    let mut mesh = box_mesh([1.0, 0.2, 0.2], [10, 2, 2], 6);
    let thin = 0.0005f32;
    for p in &mut mesh.nodes {
        // x = 0.6 moves to 0.5 + thin, everything beyond shifts with it.
        let i = (p[0] * 10.0).round() as i32;
        if i >= 6 {
            p[0] = 0.5 + thin + 0.1 * (i - 6) as f32;
        }
    }
    let fixed = mesh.select(|p| p[0] == 0.0);
    body("sliver beam", mesh, fixed, 9, 1.5)
}

/// One sweep case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    /// Young's modulus (Pa).
    pub young: f32,
    /// Poisson ratio.
    pub poisson: f32,
    /// Time step (s).
    pub dt: f32,
    /// CG iterations per step.
    pub cg: u32,
}

/// What one sweep run measured.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The element method.
    pub method: Method,
    /// Steps taken.
    pub steps: u64,
    /// Steps refused with `StepError::Diverged` (state kept).
    pub refused: u64,
    /// Every position and velocity stayed finite.
    pub finite: bool,
    /// Largest fraction of inverted elements.
    pub inverted: f64,
    /// Largest body energy (kinetic + elastic) over the largest work the tool
    /// had done: above 1 the step made energy.
    pub energy_ratio: f64,
    /// Body energy at the end over body energy at the release.
    pub decay: f64,
    /// Largest node displacement at the end, over the bounding-box diagonal.
    pub recovery: f64,
    /// Simulated time of the recovery phase (s).
    pub recovery_time: f64,
    /// Wall-clock seconds.
    pub wall: f64,
    /// The run met every criterion.
    pub passed: bool,
    /// Why not, if it did not.
    pub note: String,
}

/// Recovery target: within 1% of the bounding-box diagonal (the criterion of
/// the paper's liver test, as in tests/robustness.rs).
pub const RECOVERED: f64 = 0.01;

/// Stiffness-proportional damping of the sweep (s): none, so that the
/// elastic forces alone must bring the body back.
pub const ALPHA_K: f32 = 0.0;

/// Runs one case: pull the grabbed patch `pull` away in 0.1 s (a violent
/// drag that inverts elements), hold 0.1 s, release, and damp until the body
/// is back within [`RECOVERED`] or `max_recovery_steps` have passed.
///
/// The tool spring is 20·E·L (at least 1e3 N/m) so it overpowers the body at
/// any stiffness. Damping is Rayleigh: `α_M = 2 ω₁` with
/// `ω₁ ≈ ½ √(E/ρ) / L` (at least 2/s), so every mode decays at least as
/// fast as the fundamental would critically, and `α_K =` [`ALPHA_K`]. With E = 0 nothing can pull the
/// body back; there the recovery phase first raises E to 3e4 Pa over 0.1 s,
/// as the paper does with its crushed rabbit.
///
/// The energy guard is on (the default) unless `COROFEM_SWEEP_ENERGY_GUARD=0`.
pub fn run_case(body: &Body, case: Case, method: Method, max_recovery_steps: u64) -> Outcome {
    let guard = std::env::var("COROFEM_SWEEP_ENERGY_GUARD").map_or(true, |g| g != "0");
    run_case_guarded(body, case, method, max_recovery_steps, guard)
}

/// [`run_case`] with the energy guard on or off.
pub fn run_case_guarded(
    body: &Body,
    case: Case,
    method: Method,
    max_recovery_steps: u64,
    energy_guard: bool,
) -> Outcome {
    let start = Instant::now();
    let mut scene: VecScene =
        corofem::VecScene::with_capacity(body.mesh.nodes.len(), body.mesh.tets.len());
    let material = Material {
        young: case.young,
        poisson: case.poisson,
        density: body.density,
    };
    let mut outcome = Outcome {
        case,
        method,
        steps: 0,
        refused: 0,
        finite: true,
        inverted: 0.0,
        energy_ratio: 0.0,
        decay: 0.0,
        recovery: f64::NAN,
        recovery_time: 0.0,
        wall: 0.0,
        passed: false,
        note: String::new(),
    };
    if let Err(e) = scene.build(
        &body.mesh.nodes,
        &body.mesh.tets,
        &material,
        corofem::BuildOptions::default(),
    ) {
        outcome.note = format!("build refused: {e}");
        return outcome;
    }
    let length = body.size;
    let e_eff = f64::from(if case.young > 0.0 { case.young } else { 3.0e4 });
    let omega = (0.5 * (e_eff / f64::from(body.density)).sqrt() / length).max(1.0);
    // `COROFEM_SWEEP_PRECONDITIONER=mass` (or `block-jacobi`) runs the sweep
    // with another preconditioner than the default, with that
    // preconditioner's own warm-start default. A name that is not one is an
    // error, not a silent default.
    let preconditioner = std::env::var("COROFEM_SWEEP_PRECONDITIONER").map_or(
        corofem::Preconditioner::DEFAULT,
        |p| {
            corofem::Preconditioner::from_name(&p)
                .unwrap_or_else(|| panic!("COROFEM_SWEEP_PRECONDITIONER: no preconditioner {p:?}"))
        },
    );
    let defaults = Settings::with_preconditioner(preconditioner);
    let settings = Settings {
        method,
        dt: case.dt,
        cg_iterations: case.cg,
        rayleigh_mass: (2.0 * omega) as f32,
        // Without stiffness damping, QR blows up on soft bodies with many
        // inverted elements (docs/reliability.md); `COROFEM_SWEEP_ALPHA_K=0`
        // shows it.
        rayleigh_stiffness: std::env::var("COROFEM_SWEEP_ALPHA_K")
            .ok()
            .and_then(|a| a.parse().ok())
            .unwrap_or(ALPHA_K),
        gravity: [0.0; 3],
        // `COROFEM_SWEEP_WARM_START=0` (or `1`) overrides the default.
        warm_start: std::env::var("COROFEM_SWEEP_WARM_START")
            .map_or(defaults.warm_start, |w| w != "0"),
        energy_guard,
        ..defaults
    };
    if let Err(e) = scene.set_settings(settings) {
        outcome.note = format!("settings refused: {e}");
        return outcome;
    }
    scene.fix_nodes(&body.fixed).unwrap();
    let k = (20.0 * f64::from(case.young) * length).max(1.0e3) as f32;
    scene.grab(&body.grabbed, k).unwrap();
    let origin = scene.tool_target();
    let offsets: Vec<[f32; 3]> = body
        .grabbed
        .iter()
        .map(|&i| {
            let p = scene.position(i).unwrap();
            [0, 1, 2].map(|c| p[c] - origin[c])
        })
        .collect();
    let k_node = k / body.grabbed.len() as f32;
    let n_tets = body.mesh.tets.len() as f64;
    let dt = f64::from(case.dt);
    let pull_steps = ((0.1 / dt).ceil() as u64).max(2);
    let hold_steps = pull_steps;
    // Work done by the tool on the body (J), and the body's energy (J).
    let mut work = 0.0f64;
    let mut max_work = 0.0f64;
    let mut max_energy = 0.0f64;
    let energy = |s: &mut VecScene| f64::from(s.kinetic_energy()) + f64::from(s.elastic_energy());
    let every = (pull_steps / 50).max(1);
    for step in 0..pull_steps + hold_steps {
        let a = ((step + 1) as f32 / pull_steps as f32).min(1.0);
        let target = [0, 1, 2].map(|c| origin[c] + a * body.pull[c]);
        let before: Vec<[f32; 3]> = body
            .grabbed
            .iter()
            .map(|&i| scene.position(i).unwrap())
            .collect();
        match scene.step_haptic(target) {
            Ok(stats) => {
                outcome.inverted = outcome.inverted.max(f64::from(stats.inverted) / n_tets);
                // W += Σ fᵢ·Δxᵢ with the spring force at the end of the step
                // (implicit Euler's force).
                for ((&i, x0), o) in body.grabbed.iter().zip(&before).zip(&offsets) {
                    let x1 = scene.position(i).unwrap();
                    for c in 0..3 {
                        let f = f64::from(k_node) * f64::from(target[c] + o[c] - x1[c]);
                        work += f * f64::from(x1[c] - x0[c]);
                    }
                }
                max_work = max_work.max(work);
            }
            Err(StepError::Diverged) => outcome.refused += 1,
            Err(e) => panic!("finite target refused: {e}"),
        }
        outcome.steps += 1;
        if step % every == 0 || step + 1 == pull_steps + hold_steps {
            outcome.finite &= all_finite(&scene);
            max_energy = max_energy.max(energy(&mut scene));
        }
    }
    scene.release();
    let released = energy(&mut scene);
    max_energy = max_energy.max(released);
    if case.young == 0.0 {
        // Stiffen to 3e4 Pa over 0.1 s.
        let ramp = ((0.1 / dt).ceil() as u64).max(1);
        for step in 1..=ramp {
            scene
                .set_young_all(3.0e4 * step as f32 / ramp as f32)
                .unwrap();
            if scene.step().is_err() {
                outcome.refused += 1;
            }
            outcome.steps += 1;
        }
    }
    let check_every = ((0.05 / dt).ceil() as u64).max(1);
    let mut recovery_steps = 0u64;
    let mut last_energy;
    let (mut best, mut best_at) = (f64::MAX, 0u64);
    loop {
        for _ in 0..check_every {
            match scene.step() {
                Ok(stats) => {
                    outcome.inverted = outcome.inverted.max(f64::from(stats.inverted) / n_tets);
                }
                Err(_) => outcome.refused += 1,
            }
            recovery_steps += 1;
        }
        outcome.steps += check_every;
        outcome.finite &= all_finite(&scene);
        last_energy = energy(&mut scene);
        if case.young > 0.0 {
            max_energy = max_energy.max(last_energy);
        }
        let err = shape_error(&scene, &body.mesh, length);
        outcome.recovery = err;
        if verbose() {
            eprintln!(
                "  t = {:.3} s after release: shape error {err:.2e}, {} inverted, energy {last_energy:.3e} J",
                recovery_steps as f64 * dt,
                scene.inverted_count()
            );
        }
        // Blown up (ten times its size away, or refusing to step), or stuck
        // (no 0.1% progress in 2 s of simulated time): stop.
        let blown = err > 10.0 || outcome.refused > 100;
        if err < 0.999 * best {
            best = err;
            best_at = recovery_steps;
        }
        let stuck = (recovery_steps - best_at) as f64 * dt > 2.0;
        if (err < RECOVERED && scene.inverted_count() == 0)
            || recovery_steps >= max_recovery_steps
            || blown
            || stuck
        {
            break;
        }
    }
    outcome.recovery_time = recovery_steps as f64 * dt;
    outcome.energy_ratio = max_energy / max_work.max(f64::MIN_POSITIVE);
    outcome.decay = last_energy / released.max(f64::MIN_POSITIVE);
    outcome.wall = start.elapsed().as_secs_f64();
    let mut why = Vec::new();
    if !outcome.finite {
        why.push("non-finite state".to_owned());
    }
    if outcome.refused > 0 {
        why.push(format!("{} steps refused (Diverged)", outcome.refused));
    }
    // The body cannot hold more energy than the tool put in. The work is
    // summed from f32 spring stretches, which a stiff spring makes tiny
    // (1e-7 m against a 1.5e-8 m resolution at 0.2 m), and the co-rotational
    // energy is not exactly the potential of the linearised step: ratios up
    // to ~3 are measured on runs that settle normally. A blow-up reaches 1e12
    // and more, so 10 separates the two.
    if case.young > 0.0 && (outcome.energy_ratio.is_nan() || outcome.energy_ratio > 10.0) {
        why.push(format!(
            "energy blow-up: {:.1e}× the tool's work",
            outcome.energy_ratio
        ));
    }
    if outcome.recovery.is_nan() || outcome.recovery >= RECOVERED {
        why.push(format!(
            "not back within 1% after {:.3} s",
            outcome.recovery_time
        ));
    }
    outcome.passed = why.is_empty();
    outcome.note = why.join("; ");
    outcome
}

/// `COROFEM_SWEEP_VERBOSE` is set: print the recovery as it goes.
fn verbose() -> bool {
    std::env::var_os("COROFEM_SWEEP_VERBOSE").is_some()
}

/// Whether every position and velocity is finite.
pub fn all_finite(scene: &VecScene) -> bool {
    scene
        .positions()
        .chain(scene.velocities())
        .all(|v| v.iter().all(|x| x.is_finite()))
}

/// Largest node displacement from rest over `size`.
pub fn shape_error(scene: &VecScene, mesh: &CoreMesh, size: f64) -> f64 {
    (0..mesh.nodes.len() as u32)
        .map(|i| f64v::norm(f64v::up(scene.displacement(i).unwrap())))
        .fold(0.0, f64::max)
        / size
}

/// The sweep's cases for one body: each parameter alone across its range
/// around the nominal case, then every corner of the extreme values.
pub fn sweep_cases() -> Vec<(&'static str, Case)> {
    let nominal = Case {
        young: 3.0e4,
        poisson: 0.45,
        dt: 1.0e-3,
        cg: 10,
    };
    let mut cases = vec![("nominal", nominal)];
    for young in [0.0, 1.0e2, 1.0e3, 1.0e5, 1.0e6, 1.0e7, 1.0e8, 1.0e9, 1.0e10] {
        cases.push(("E", Case { young, ..nominal }));
    }
    for poisson in [0.0, 0.1, 0.3, 0.49, 0.499] {
        cases.push(("ν", Case { poisson, ..nominal }));
    }
    for dt in [1.0e-5, 1.0e-4, 5.0e-3, 1.0e-2, 2.0e-2, 5.0e-2] {
        cases.push(("dt", Case { dt, ..nominal }));
    }
    for cg in [1, 2, 5, 25, 50, 100, 200] {
        cases.push(("CG", Case { cg, ..nominal }));
    }
    for young in [1.0e2, 1.0e10] {
        for poisson in [0.0, 0.499] {
            for dt in [1.0e-5, 5.0e-2] {
                for cg in [1, 200] {
                    cases.push((
                        "corner",
                        Case {
                            young,
                            poisson,
                            dt,
                            cg,
                        },
                    ));
                }
            }
        }
    }
    cases
}

/// One row of the sweep: the run of the swept method, and the polar run of
/// the same case when it failed.
pub type Row = (&'static str, Outcome, Option<Outcome>);

fn result(o: &Outcome) -> String {
    if o.passed {
        "pass".to_owned()
    } else {
        format!("**{}**", o.note)
    }
}

/// A markdown table of sweep outcomes.
pub fn table(body: &Body, rows: &[Row]) -> String {
    let mut s = String::new();
    let passed = rows.iter().filter(|r| r.1.passed).count();
    let rescued = rows
        .iter()
        .filter(|r| r.2.as_ref().is_some_and(|p| p.passed))
        .count();
    let worst = rows
        .iter()
        .filter(|r| r.1.passed)
        .map(|r| r.1.recovery)
        .fold(0.0, f64::max);
    let m = rows.first().map_or("qr", |r| r.1.method.name());
    s.push_str(&format!(
        "**{}** ({} nodes, {} tets, smallest rest dihedral angle {:.2}°, {} fixed and {} grabbed nodes, pulled {:.2} m): \
         {} cases, {} passed with `{m}` (worst recovery error {:.1e}); of the {} others, {} pass with the polar method\n\n",
        body.name,
        body.mesh.nodes.len(),
        body.mesh.tets.len(),
        body.min_dihedral,
        body.fixed.len(),
        body.grabbed.len(),
        f64v::norm(f64v::up(body.pull)),
        rows.len(),
        passed,
        worst,
        rows.len() - passed,
        rescued,
    ));
    s.push_str(&format!("| varied | E (Pa) | ν | dt (s) | CG | steps | max inverted | energy / tool work | recovery error | recovery time (s) | wall (s) | {m} | polar, if {m} failed |\n"));
    s.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (what, o, polar) in rows {
        let c = o.case;
        let polar = match polar {
            None => String::new(),
            Some(p) => format!(
                "{} (error {:.1e}, energy {:.2}, {:.0}% inverted)",
                result(p),
                p.recovery,
                p.energy_ratio,
                100.0 * p.inverted
            ),
        };
        s.push_str(&format!(
            "| {what} | {:.0e} | {} | {:.0e} | {} | {} | {:.0}% | {:.2e} | {:.1e} | {:.2} | {:.1} | {} | {polar} |\n",
            c.young,
            c.poisson,
            c.dt,
            c.cg,
            o.steps,
            100.0 * o.inverted,
            o.energy_ratio,
            o.recovery,
            o.recovery_time,
            o.wall,
            result(o),
        ));
    }
    s
}

/// Replaces the text between `<!-- NAME:begin -->` and `<!-- NAME:end -->` in
/// `doc` (appending the section if it is not there).
pub fn replace_section(doc: &str, name: &str, body: &str) -> String {
    let begin = format!("<!-- {name}:begin -->");
    let end = format!("<!-- {name}:end -->");
    let section = format!("{begin}\n{body}\n{end}");
    match (doc.find(&begin), doc.find(&end)) {
        (Some(b), Some(e)) if e > b => {
            format!("{}{}{}", &doc[..b], section, &doc[e + end.len()..])
        }
        _ => format!("{doc}\n{section}\n"),
    }
}

/// What the soak measured.
#[derive(Clone, Debug, Default)]
pub struct Soak {
    /// Steps taken.
    pub steps: u64,
    /// Steps refused (`Diverged`); the state was kept each time.
    pub refused: u64,
    /// Drags (grab, move, release).
    pub drags: u64,
    /// Every checked state was finite.
    pub finite: bool,
    /// Largest fraction of inverted elements.
    pub inverted: f64,
    /// Largest tool force (N).
    pub max_force: f64,
    /// Largest kinetic energy (J).
    pub max_kinetic: f64,
    /// Recovery checks done.
    pub checks: u64,
    /// Worst shape error over the recovery checks (fraction of the diagonal).
    pub worst_recovery: f64,
    /// Wall-clock seconds.
    pub wall: f64,
    /// Median wall time of one step (µs), sampled.
    pub step_us: f64,
}

/// The soak: `steps` steps of the liver with `method` (E = 3e4 Pa, ν = 0.45, dt = 1 ms,
/// 10 CG iterations, α_M = 2/s, α_K = 0.01 s, gravity on) dragged by a tool
/// that grabs a random patch, moves it along random paths up to 0.3 m away
/// (1.5 times the liver) at up to 15 m/s with a spring of 1e2 to 1e6 N/m,
/// and lets go; every `check_every`
/// steps it releases and checks the liver settles back within 1% of its
/// hanging shape. `seed` fixes the random choices.
pub fn soak(body: &Body, method: Method, steps: u64, check_every: u64, seed: u64) -> Soak {
    let start = Instant::now();
    let mut rng = Rng::new(seed);
    let material = Material {
        young: 3.0e4,
        poisson: 0.45,
        density: body.density,
    };
    let mut scene = corofem::VecScene::with_capacity(body.mesh.nodes.len(), body.mesh.tets.len());
    scene
        .build(
            &body.mesh.nodes,
            &body.mesh.tets,
            &material,
            corofem::BuildOptions::default(),
        )
        .unwrap();
    let settings = Settings {
        method,
        dt: 1.0e-3,
        cg_iterations: 10,
        rayleigh_mass: 2.0,
        rayleigh_stiffness: 0.01,
        gravity: [0.0, -9.81, 0.0],
        ..Settings::default()
    };
    scene.set_settings(settings).unwrap();
    scene.fix_nodes(&body.fixed).unwrap();
    // The hanging rest shape: settle once, long, and keep it as reference.
    let settle = |s: &mut VecScene, n: u64| -> u64 {
        let mut refused = 0;
        for _ in 0..n {
            if s.step().is_err() {
                refused += 1;
            }
        }
        refused
    };
    let mut out = Soak {
        finite: true,
        ..Soak::default()
    };
    out.refused += settle(&mut scene, 20_000);
    let hanging: Vec<[f32; 3]> = scene.positions().collect();
    let n = body.mesh.nodes.len();
    let n_tets = body.mesh.tets.len() as f64;
    let mut samples = Vec::new();
    let mut next_check = check_every;
    while out.steps < steps {
        // A drag: grab a node and its nearest neighbours.
        let centre = (rng.next_f64() * n as f64) as u32 % n as u32;
        let c = scene.position(centre).unwrap();
        let mut near: Vec<(f32, u32)> = (0..n as u32)
            .map(|i| {
                let p = scene.position(i).unwrap();
                let d = (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f32>();
                (d, i)
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        let count = 1 + (rng.next_f64() * 8.0) as usize;
        let ids: Vec<u32> = near[..count].iter().map(|x| x.1).collect();
        let k = 10f64.powf(rng.range(2.0, 6.0)) as f32;
        scene.grab(&ids, k).unwrap();
        out.drags += 1;
        let origin = scene.tool_target();
        let mut from = [0.0f32; 3];
        for _ in 0..1 + (rng.next_f64() * 4.0) as usize {
            let reach = rng.range(0.0, 0.3);
            let dir = rng.unit();
            let to = [0, 1, 2].map(|k| (dir[k] * reach) as f32);
            let dur = rng.range(0.02, 0.5);
            let segment = (dur / 1e-3).ceil() as u64;
            for s in 1..=segment {
                let a = s as f32 / segment as f32;
                let target = [0, 1, 2].map(|k| origin[k] + from[k] + a * (to[k] - from[k]));
                let t0 = Instant::now();
                match scene.step_haptic(target) {
                    Ok(stats) => {
                        out.inverted = out.inverted.max(f64::from(stats.inverted) / n_tets);
                        let f = f64v::norm(f64v::up(stats.tool_force));
                        out.finite &= f.is_finite() && stats.cg_residual.is_finite();
                        out.max_force = out.max_force.max(f);
                    }
                    Err(_) => out.refused += 1,
                }
                if out.steps % 97 == 0 {
                    samples.push(t0.elapsed().as_secs_f64() * 1e6);
                }
                out.steps += 1;
                if out.steps % 1000 == 0 {
                    out.finite &= all_finite(&scene);
                    out.max_kinetic = out.max_kinetic.max(f64::from(scene.kinetic_energy()));
                }
            }
            from = to;
        }
        scene.release();
        // Idle up to 0.5 s.
        let idle = (rng.range(0.0, 0.5) / 1e-3) as u64;
        out.refused += settle(&mut scene, idle);
        out.steps += idle;
        if out.steps >= next_check || out.steps >= steps {
            next_check += check_every;
            // Let go and wait 10 s (α_M = 2/s: the slowest swing decays as
            // e^{-t}); the liver must hang as before, within 1%.
            out.refused += settle(&mut scene, 10_000);
            out.steps += 10_000;
            out.finite &= all_finite(&scene);
            let err = scene
                .positions()
                .zip(&hanging)
                .map(|(p, h)| {
                    f64v::norm([
                        f64::from(p[0] - h[0]),
                        f64::from(p[1] - h[1]),
                        f64::from(p[2] - h[2]),
                    ])
                })
                .fold(0.0, f64::max)
                / body.size;
            out.worst_recovery = out.worst_recovery.max(err);
            out.checks += 1;
            eprintln!(
                "soak check {} at step {}: shape error {err:.2e}, {} inverted, kinetic {:.2e} J, elastic {:.2e} J, {} drags, {} refused",
                out.checks,
                out.steps,
                scene.inverted_count(),
                scene.kinetic_energy(),
                scene.elastic_energy(),
                out.drags,
                out.refused
            );
        }
    }
    samples.sort_by(f64::total_cmp);
    out.step_us = samples.get(samples.len() / 2).copied().unwrap_or(0.0);
    out.wall = start.elapsed().as_secs_f64();
    out
}
