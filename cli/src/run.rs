//! `corofem run`: builds the scene, steps it (or solves for static
//! equilibrium), records the history and writes the result.

use std::path::{Path, PathBuf};
use std::time::Instant;

use corofem::VecScene;
use corofem::{BuildOptions, StepStats};
use corofem_io::VtkSeries;

use crate::error::{CliError, CliResult};
use crate::mesh_input::{self, CoreMesh};
use crate::progress::Progress;
use crate::result::{
    self, Destination, FinalState, HistoryEntry, MeshCounts, RunResult, StaticOutcome, Timing,
};
use crate::scene_file::{self, ProbeSpec, SceneSpec, StaticSpec, ToolSpec};
use crate::select;
use crate::visual::Visual;

/// Command-line options of `corofem run`.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// Where the result JSON goes.
    pub out: Destination,
    /// Folder for a VTK time series (one frame per history record).
    pub vtk: Option<PathBuf>,
    /// No progress bar, notes or summary.
    pub quiet: bool,
}

/// Runs a scene file end to end. Nothing is written to the result destination
/// unless the whole run succeeds.
pub fn run(opts: &RunOptions) -> CliResult<()> {
    let spec = scene_file::load(&opts.scene)?;
    opts.out
        .check()
        .map_err(|e| CliError(format!("cannot write the result: {e}")))?;
    let mut notes = Vec::new();
    let mesh = mesh_input::load(&spec.mesh, &spec.file, &mut notes)?;
    if spec.static_solve.is_some() {
        static_notes(&spec, &mut notes);
    }
    if !opts.quiet {
        for n in &notes {
            eprintln!("note: {n}");
        }
    }
    let records = match spec.static_solve {
        Some(st) => u64::from(st.max_iterations),
        None => spec.steps / spec.every + 2,
    };
    let vtk_stride = records.div_ceil(MAX_VTK_FRAMES).max(1);
    if opts.vtk.is_some() && vtk_stride > 1 && !opts.quiet {
        eprintln!(
            "note: --vtk: the run records up to {} history entries ([solver] steps / [output] every); \
             writing a VTK frame every {} entries, at most {} frames (set [output] every to choose)",
            thousands(records),
            thousands(vtk_stride),
            thousands(MAX_VTK_FRAMES)
        );
    }
    let mut sim = Sim::build(&spec, &mesh)?;
    sim.vtk_stride = vtk_stride;
    sim.visual = Visual::load(&spec, &sim.scene)?;
    if let (Some(visual), Some(dir)) = (&mut sim.visual, &opts.vtk) {
        visual.start_vtk(dir)?;
    }
    let mut vtk = match &opts.vtk {
        None => None,
        Some(dir) => {
            let tets: Vec<[usize; 4]> = (0..sim.scene.element_count())
                .filter_map(|e| sim.scene.element_nodes(e))
                .map(|t| t.map(|i| i as usize))
                .collect();
            Some(VtkSeries::create(dir, &tets).map_err(|e| CliError(format!("--vtk: {e}")))?)
        }
    };
    let outcome = match spec.static_solve {
        Some(st) => sim.solve_static(&st, vtk.as_mut(), opts.quiet)?,
        None => sim.simulate(vtk.as_mut(), opts.quiet)?,
    };
    if let Some(series) = vtk {
        series
            .finish()
            .map_err(|e| CliError(format!("--vtk: {e}")))?;
    }
    let final_state = sim.final_state()?;
    let visual_summary = sim.visual.as_ref().map(Visual::summary);
    let surface_frames = sim.visual.as_ref().and_then(Visual::frames);
    let visual = match sim.visual.take() {
        Some(v) => Some(v.finish(&sim.scene)?),
        None => None,
    };
    let result = RunResult {
        format: result::FORMAT,
        scene: spec.file.clone(),
        mesh: MeshCounts {
            nodes: sim.scene.node_count(),
            tets: sim.scene.element_count(),
        },
        method: spec.settings.method.name(),
        steps: outcome.steps,
        static_solve: outcome.static_solve,
        timing: outcome.timing,
        final_state,
        history: outcome.history,
        visual,
    };
    opts.out
        .write(&result::to_json(&result))
        .map_err(|e| CliError(format!("cannot write the result: {e}")))?;
    if !opts.quiet {
        let vtk = opts.vtk.as_deref().map(|dir| VtkWritten {
            dir,
            frames: (result.history.len() as u64).div_ceil(vtk_stride),
            surface_frames,
        });
        eprintln!(
            "{}",
            summary(
                &spec,
                &mesh,
                &result,
                &outcome.extremes,
                &opts.out,
                vtk,
                visual_summary
            )
        );
    }
    Ok(())
}

/// Most VTK frames `--vtk` writes: beyond them it writes every n-th
/// history record (a frame of a 10k-node mesh is about 1 MB).
pub const MAX_VTK_FRAMES: u64 = 10_000;

/// Notes for scene parts that a static solve ignores.
fn static_notes(spec: &SceneSpec, notes: &mut Vec<String>) {
    let file = &spec.file;
    let mut ignored = Vec::new();
    if spec.steps > 0 {
        ignored.push("[solver] dt and steps");
    }
    if spec.initial.is_some() {
        ignored.push("[initial]");
    }
    if spec.ground.is_some() {
        ignored.push("[world] ground");
    }
    if !spec.material_changes.is_empty() {
        ignored.push("[[material_change]]");
    }
    if spec.tool.as_ref().is_some_and(|t| t.release.is_some()) {
        ignored.push("[tool] release");
    }
    if !ignored.is_empty() {
        notes.push(format!(
            "{file}: static = true: ignoring {} (the tool, if any, holds its target at the path's last point)",
            ignored.join(", ")
        ));
    }
}

/// What the run loop produced.
struct Outcome {
    steps: u64,
    static_solve: Option<StaticOutcome>,
    timing: Timing,
    history: Vec<HistoryEntry>,
    extremes: Extremes,
}

/// Largest values seen over every step, for the summary.
#[derive(Debug, Default, Clone, Copy)]
struct Extremes {
    inverted: u32,
    tool_force: f32,
    /// Energy the guard took out, summed over the steps (J), and the steps
    /// in which it did.
    energy_removed: f64,
    guarded_steps: u64,
}

/// The tool as set up at step 0.
struct Tool<'a> {
    spec: &'a ToolSpec,
    nodes: Vec<u32>,
    /// Grabbed nodes' centroid at step 0 (m).
    origin: [f64; 3],
    /// First step index whose start time is at or after `release`.
    release_step: Option<u64>,
}

impl Tool<'_> {
    /// Tool target at time `t` (s).
    fn target(&self, t: f64) -> [f32; 3] {
        let d = self.spec.path.offset(t);
        [0, 1, 2].map(|k| (self.origin[k] + d[k]) as f32)
    }
}

/// A probe's centre at time `t` (s): its position plus its path's offset.
fn probe_position(p: &ProbeSpec, t: f64) -> [f32; 3] {
    let d = p.path.offset(t);
    [0, 1, 2].map(|k| (p.position[k] + d[k]) as f32)
}

/// A built scene and what the run needs alongside it.
struct Sim<'a> {
    spec: &'a SceneSpec,
    scene: VecScene,
    tool: Option<Tool<'a>>,
    /// The `[[probe]]` entries, as the core steps them.
    probes: Vec<corofem::Probe>,
    /// Scratch for `elastic_forces`.
    forces: Vec<[f32; 3]>,
    /// The `[visual]` surface, bound after the build.
    visual: Option<Visual>,
    /// `--vtk` writes the frame of every `vtk_stride`-th history record.
    vtk_stride: u64,
}

impl<'a> Sim<'a> {
    /// Builds the scene and applies fixed nodes, forces, ground, initial
    /// motion and the tool grab.
    fn build(spec: &'a SceneSpec, mesh: &CoreMesh) -> CliResult<Sim<'a>> {
        let file = &spec.file;
        let mut scene = VecScene::with_capacity(mesh.nodes.len(), mesh.tets.len());
        let options = BuildOptions {
            reorient: spec.mesh.reorient,
        };
        scene
            .build(&mesh.nodes, &mesh.tets, &spec.material, options)
            .map_err(|e| {
                // The core's message suggests re-orientation in its own
                // terms; the scene file's key replaces that hint.
                let why = match e {
                    corofem::Error::InvertedElement { element } => format!(
                        "tetrahedron {element} is negatively oriented \
                         (set `reorient = true` in [mesh] to fix it)"
                    ),
                    e => e.to_string(),
                };
                CliError(format!(
                    "{file}: [mesh] {}: cannot build the scene: {why}",
                    mesh.name
                ))
            })?;
        scene
            .set_settings(spec.settings)
            .map_err(|e| CliError(format!("{file}: [solver]: {e}")))?;
        let rest = &mesh.nodes;
        for sel in &spec.fixed {
            let ids = select::resolve(sel, rest, file)?;
            scene
                .fix_nodes(&ids)
                .map_err(|e| CliError(format!("{file}: {}: {e}", sel.label)))?;
        }
        if !spec.forces.is_empty() {
            let mut per_node = vec![[0.0f64; 3]; rest.len()];
            for f in &spec.forces {
                let ids = select::resolve(&f.selection, rest, file)?;
                let share = 1.0 / ids.len() as f64;
                for &i in &ids {
                    for (acc, t) in per_node[i as usize].iter_mut().zip(f.total) {
                        *acc += f64::from(t) * share;
                    }
                }
            }
            // `as u32`: one entry per node of a built scene (at most 65 536).
            for (i, f) in (0u32..).zip(&per_node) {
                if *f != [0.0; 3] {
                    scene
                        .set_force(i, f.map(|x| x as f32))
                        .map_err(|e| CliError(format!("{file}: [[force]]: {e}")))?;
                }
            }
        }
        if let Some(plane) = spec.ground {
            scene
                .set_ground(Some(plane))
                .map_err(|e| CliError(format!("{file}: [world] ground: {e}")))?;
            scene.set_ground_friction(spec.ground_friction);
        }
        if let Some(init) = spec.initial {
            let v = initial_velocities(&scene, init.velocity, init.angular_velocity);
            scene
                .set_velocities(&v)
                .map_err(|e| CliError(format!("{file}: [initial]: {e}")))?;
        }
        let tool = match &spec.tool {
            None => None,
            Some(t) => {
                let nodes = select::resolve(&t.selection, rest, file)?;
                scene
                    .grab(&nodes, t.stiffness)
                    .map_err(|e| CliError(format!("{file}: [tool]: {e}")))?;
                let origin = scene.tool_target().map(f64::from);
                let release_step = t
                    .release
                    .map(|r| (r / spec.dt - 1e-9).ceil().max(0.0) as u64);
                Some(Tool {
                    spec: t,
                    nodes,
                    origin,
                    release_step,
                })
            }
        };
        let probes = spec
            .probes
            .iter()
            .map(|p| {
                let at = probe_position(p, 0.0);
                corofem::Probe::capsule(p.radius, p.half_length, at, p.axis)
                    .map(|probe| probe.with_friction(p.friction))
                    .map_err(|e| CliError(format!("{file}: {}: {e}", p.label)))
            })
            .collect::<CliResult<Vec<_>>>()?;
        let n = scene.node_count();
        Ok(Sim {
            spec,
            scene,
            tool,
            probes,
            forces: vec![[0.0; 3]; n],
            visual: None,
            vtk_stride: 1,
        })
    }

    /// Time steps with history records, material changes, the tool and the
    /// divergence checks.
    fn simulate(&mut self, mut vtk: Option<&mut VtkSeries>, quiet: bool) -> CliResult<Outcome> {
        let spec = self.spec;
        let steps = spec.steps;
        // Capacities are capped: a huge `steps` must not reserve memory up
        // front (it made `Vec::with_capacity` panic with "capacity overflow").
        let mut history = Vec::with_capacity((steps / spec.every + 2).min(1 << 16) as usize);
        let first = self.record(0, 0.0, &StepStats::default())?;
        self.push(&mut history, first, vtk.as_deref_mut())?;
        let mut ms = Vec::with_capacity(steps.min(1 << 20) as usize);
        let mut extremes = Extremes::default();
        let mut changes = spec.material_changes.iter().peekable();
        let mut progress = Progress::new(steps, "steps", quiet);
        let loop_start = Instant::now();
        for k in 0..steps {
            while let Some(c) = changes.next_if(|c| c.step == k) {
                self.scene.set_young_all(c.young).map_err(|e| {
                    CliError(format!(
                        "{}: [[material_change]] at step {k}: {e}",
                        spec.file
                    ))
                })?;
            }
            let t_end = time(k + 1, spec.dt);
            let target = match &self.tool {
                Some(tool) if self.scene.is_grabbing() => {
                    if tool.release_step.is_some_and(|r| k >= r) {
                        self.scene.release();
                        None
                    } else {
                        Some(tool.target(t_end))
                    }
                }
                _ => None,
            };
            for (probe, p) in self.probes.iter_mut().zip(&spec.probes) {
                // Checked by the scene file: finite, a unit axis.
                let _ = probe.move_to(probe_position(p, t_end), p.axis);
            }
            let start = Instant::now();
            let stepped = match (target, self.probes.is_empty()) {
                (Some(x), true) => self.scene.step_haptic(x),
                (None, true) => self.scene.step(),
                (target, false) => {
                    let aimed = match target {
                        Some(x) => self.scene.set_tool_target(x).map_err(|e| e.to_string()),
                        None => Ok(()),
                    };
                    match aimed {
                        Ok(()) => self.scene.step_with_probes(&mut self.probes),
                        Err(why) => {
                            return Err(CliError(format!("{}: [tool] path: {why}", spec.file)))
                        }
                    }
                }
            };
            ms.push(start.elapsed().as_secs_f64() * 1e3);
            let diverged = |why: String| {
                CliError(format!(
                    "{}: diverged at step {} of {steps} (t = {t_end} s): {why}",
                    spec.file,
                    k + 1
                ))
            };
            let stats = stepped.map_err(|e| match e {
                // Not a divergence: the scene placed a probe inside the body.
                corofem::StepError::ProbeInsideBody { probe, node } => {
                    let label = spec
                        .probes
                        .get(probe as usize)
                        .map_or_else(|| format!("probe {probe}"), |p| p.label.clone());
                    let what = match node {
                        Some(node) => format!("node {node} is inside it"),
                        None => "it lies inside the body".into(),
                    };
                    CliError(format!(
                        "{}: {label} starts inside the body at step {} (t = {t_end} s): \
                         {what}; move its `position` (or its `path`'s first point) so \
                         that it starts outside",
                        spec.file,
                        k + 1
                    ))
                }
                corofem::StepError::BelowGround { node } => below_ground(
                    &self.scene,
                    node,
                    &format!("{}: the body starts below [world] ground", spec.file),
                ),
                e => diverged(e.to_string()),
            })?;
            if !stats.cg_residual.is_finite() {
                return Err(diverged("the CG residual is not finite".into()));
            }
            if !stats.tool_force.iter().all(|x| x.is_finite()) {
                return Err(diverged("the tool force is not finite".into()));
            }
            extremes.inverted = extremes.inverted.max(stats.inverted);
            extremes.tool_force = extremes.tool_force.max(norm(stats.tool_force));
            if stats.energy_removed > 0.0 {
                extremes.energy_removed += f64::from(stats.energy_removed);
                extremes.guarded_steps += 1;
            }
            let done = k + 1;
            if done % spec.every == 0 || done == steps {
                let entry = self.record(done, t_end, &stats)?;
                extremes.inverted = extremes.inverted.max(entry.inverted);
                self.push(&mut history, entry, vtk.as_deref_mut())?;
            }
            progress.set(done);
        }
        progress.finish();
        Ok(Outcome {
            steps,
            static_solve: None,
            timing: Timing::from_samples(ms, loop_start.elapsed().as_secs_f64()),
            history,
            extremes,
        })
    }

    /// Newton iterations one at a time, each recorded.
    fn solve_static(
        &mut self,
        st: &StaticSpec,
        mut vtk: Option<&mut VtkSeries>,
        quiet: bool,
    ) -> CliResult<Outcome> {
        let file = &self.spec.file;
        self.check_static_supports()?;
        if let Some(tool) = &self.tool {
            let target = tool.target(tool.spec.path.end_time());
            self.scene
                .set_tool_target(target)
                .map_err(|e| CliError(format!("{file}: [tool] path: {e}")))?;
        }
        let mut history = Vec::new();
        let mut ms = Vec::new();
        let mut extremes = Extremes::default();
        let mut last = None;
        let mut progress = Progress::new(u64::from(st.max_iterations), "Newton iterations", quiet);
        let loop_start = Instant::now();
        for it in 1..=u64::from(st.max_iterations) {
            let start = Instant::now();
            let newton = self.scene.solve_static(&st.settings, |_| {}).map_err(|e| {
                CliError(format!(
                    "{file}: [solver] static = true: failed at Newton iteration {it}: {e}"
                ))
            })?;
            ms.push(start.elapsed().as_secs_f64() * 1e3);
            let stats = StepStats {
                cg_iterations: newton.cg_iterations,
                cg_residual: newton.cg_residual,
                inverted: newton.inverted,
                tool_force: self.static_tool_force(),
                ..StepStats::default()
            };
            let mut entry = self.record(it, 0.0, &stats)?;
            entry.newton_residual = Some(newton.residual);
            entry.newton_update = Some(newton.update);
            if let Some(what) = entry.non_finite() {
                return Err(CliError(format!(
                    "{file}: [solver] static = true: diverged at Newton iteration {it}: the {what} is not finite"
                )));
            }
            extremes.inverted = extremes.inverted.max(entry.inverted);
            extremes.tool_force = extremes.tool_force.max(norm(entry.tool_force));
            self.push(&mut history, entry, vtk.as_deref_mut())?;
            progress.set(it);
            last = Some(newton);
            if newton.converged {
                break;
            }
        }
        let set = &st.settings;
        // The out-of-balance force of the final shape: the last iteration
        // measured it before its update. A solve with an unbounded
        // tolerance measures it and makes no update (nor CG solve).
        let force = match last {
            Some(n) if !(n.converged && n.residual <= set.tolerance) => {
                let measure = corofem::StaticSettings {
                    max_iterations: 1,
                    tolerance: f32::INFINITY,
                    two_level: false,
                    ..*set
                };
                self.scene
                    .solve_static(&measure, |_| {})
                    .map(|m| m.residual)
                    .unwrap_or(n.residual)
            }
            Some(n) => n.residual,
            None => 0.0,
        };
        let outcome = last.map(|n| StaticOutcome {
            converged: force <= set.tolerance,
            met: if !n.converged {
                None
            } else if n.residual <= set.tolerance {
                Some("force")
            } else {
                Some("update")
            },
            residual: n.residual,
            force,
            tolerance: set.tolerance,
            update: n.update,
            update_tolerance: set.update_tolerance,
            cg_residual: n.cg_residual,
            cg_tolerance: set.cg_tolerance,
        });
        progress.finish();
        if let Some(o) = outcome.filter(|o| !o.converged && !quiet) {
            let kind = if o.met.is_some() { "note" } else { "warning" };
            eprintln!("{kind}: {file}: {}", static_warning(&o, st.max_iterations));
        }
        Ok(Outcome {
            steps: history.len() as u64,
            static_solve: outcome,
            timing: Timing::from_samples(ms, loop_start.elapsed().as_secs_f64()),
            history,
            extremes,
        })
    }

    /// A static solve needs supports that stop the body turning: fixed or
    /// grabbed nodes not all on one line. Held by one or two nodes (or a
    /// row of them), the stiffness is singular and Newton's first update
    /// is unbounded.
    fn check_static_supports(&self) -> CliResult<()> {
        let held: Vec<u32> = (0..self.scene.node_count() as u32)
            .filter(|&i| self.scene.is_fixed(i))
            .chain(self.tool.iter().flat_map(|t| t.nodes.iter().copied()))
            .collect();
        let points: Vec<[f64; 3]> = held
            .iter()
            .filter_map(|&i| self.scene.position(i))
            .map(|p| p.map(f64::from))
            .collect();
        if points.is_empty() || !on_one_line(&points) {
            // No support at all is the core's `Unconstrained` error.
            return Ok(());
        }
        let mut ids: Vec<u32> = held.clone();
        ids.sort_unstable();
        ids.dedup();
        let which = match ids.len() {
            1 => format!("1 node (node {})", ids[0]),
            2 => format!("2 nodes (nodes {} and {})", ids[0], ids[1]),
            n => format!("{n} nodes, all on one line"),
        };
        Err(CliError(format!(
            "{}: [solver] static = true: the body is held by {which} ([[fixed]] and [tool]), \
             which leaves it free to turn about them: it has no static equilibrium. Hold at \
             least 3 nodes that are not on one line, or run it in time steps",
            self.spec.file
        )))
    }

    /// Force the body exerts on the tool's spring in a static solve (N):
    /// `k (centroid − target)`.
    fn static_tool_force(&self) -> [f32; 3] {
        let Some(tool) = &self.tool else {
            return [0.0; 3];
        };
        let mut c = [0.0f64; 3];
        for &i in &tool.nodes {
            let p = self.scene.position(i).unwrap_or_default();
            for k in 0..3 {
                c[k] += f64::from(p[k]);
            }
        }
        let n = tool.nodes.len().max(1) as f64;
        let target = self.scene.tool_target();
        let k = f64::from(tool.spec.stiffness);
        [0, 1, 2].map(|j| (k * (c[j] / n - f64::from(target[j]))) as f32)
    }

    /// A history record of the current state.
    fn record(&mut self, step: u64, t: f64, stats: &StepStats) -> CliResult<HistoryEntry> {
        let inverted = self
            .scene
            .elastic_forces(&mut self.forces)
            .map_err(|e| CliError(format!("{}: diagnostics: {e}", self.spec.file)))?;
        let entry = HistoryEntry {
            step,
            t,
            kinetic_energy: self.scene.kinetic_energy(),
            elastic_energy: self.scene.elastic_energy(),
            momentum: self.scene.momentum(),
            angular_momentum: self.scene.angular_momentum(),
            inverted,
            cg_iterations: stats.cg_iterations,
            cg_residual: stats.cg_residual,
            tool_force: stats.tool_force,
            probe_forces: self.probes.iter().map(|p| p.force()).collect(),
            contacts: stats.contacts,
            support_force: stats.support_force,
            newton_residual: None,
            newton_update: None,
        };
        if let Some(what) = entry.non_finite() {
            let file = &self.spec.file;
            return Err(CliError(match self.spec.static_solve {
                Some(_) => format!(
                    "{file}: [solver] static = true: diverged at Newton iteration {step}: the {what} is not finite"
                ),
                None => format!(
                    "{file}: diverged at step {step} of {} (t = {t} s): the {what} is not finite",
                    self.spec.steps
                ),
            }));
        }
        Ok(entry)
    }

    /// Appends a record and writes its VTK frame.
    fn push(
        &mut self,
        history: &mut Vec<HistoryEntry>,
        entry: HistoryEntry,
        vtk: Option<&mut VtkSeries>,
    ) -> CliResult<()> {
        let due = history.len() as u64 % self.vtk_stride == 0;
        if let Some(series) = vtk.filter(|_| due) {
            let x: Vec<[f32; 3]> = self.scene.positions().collect();
            let v: Vec<[f32; 3]> = self.scene.velocities().collect();
            // Static solves have no time: the iteration number stands in.
            let t = if self.spec.static_solve.is_some() {
                entry.step as f64
            } else {
                entry.t
            };
            series
                .write_frame(t, &x, &v)
                .map_err(|e| CliError(format!("--vtk: {e}")))?;
            if let Some(visual) = &mut self.visual {
                visual.record(&self.scene, t)?;
            }
        }
        history.push(entry);
        Ok(())
    }

    /// Final positions, velocities and inverted count, all finite.
    fn final_state(&mut self) -> CliResult<FinalState> {
        let positions: Vec<[f32; 3]> = self.scene.positions().collect();
        let velocities: Vec<[f32; 3]> = self.scene.velocities().collect();
        let finite = |v: &[[f32; 3]]| v.iter().flatten().all(|x| x.is_finite());
        if !finite(&positions) || !finite(&velocities) {
            return Err(CliError(format!(
                "{}: the final state has non-finite positions or velocities",
                self.spec.file
            )));
        }
        let inverted = self
            .scene
            .elastic_forces(&mut self.forces)
            .map_err(|e| CliError(format!("{}: diagnostics: {e}", self.spec.file)))?;
        Ok(FinalState {
            positions,
            velocities,
            inverted,
        })
    }
}

/// Whether `points` lie on one line (or are one point), to 1e-9 of their
/// spread.
fn on_one_line(points: &[[f64; 3]]) -> bool {
    let a = points[0];
    let sub = |p: [f64; 3], q: [f64; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    // The point farthest from the first sets the line's direction.
    let far = points
        .iter()
        .copied()
        .max_by(|p, q| len(sub(*p, a)).total_cmp(&len(sub(*q, a))))
        .unwrap_or(a);
    let d = sub(far, a);
    let spread = len(d);
    if spread == 0.0 {
        return true;
    }
    points.iter().all(|&p| {
        let r = sub(p, a);
        let c = [
            r[1] * d[2] - r[2] * d[1],
            r[2] * d[0] - r[0] * d[2],
            r[0] * d[1] - r[1] * d[0],
        ];
        len(c) / spread <= 1e-9 * spread
    })
}

/// The note or warning for a static solve whose out-of-balance force
/// stayed above `newton_tolerance`: which rule stopped it, and what to
/// change.
fn static_warning(o: &StaticOutcome, max_iterations: u32) -> String {
    let force = format!(
        "the out-of-balance force is {:.2e} of the load (newton_tolerance {:.1e})",
        o.force, o.tolerance
    );
    match o.met {
        Some(_) => format!(
            "the static solve stopped when its updates no longer moved the body ({:.1e} of \
             the displacement, rule 1e-4, from CG solved to cg_tolerance): the shape has \
             converged, but {force}, so the result says \"converged\": false. That force is \
             the f32 round-off floor of this body: more Newton iterations do not lower it \
             (docs/scene-format.md, \"Static solve\")",
            o.update
        ),
        None => format!(
            "the static solve did NOT converge in {max_iterations} Newton iterations: {force}; \
             last update {:.3e} of the displacement (needs <= {:.1e}) from a CG solve that \
             reached {:.3e} (needs <= cg_tolerance {:.1e}). Raise [solver] newton_iterations, \
             or cg_iterations if the CG solves stop short",
            o.update, o.update_tolerance, o.cg_residual, o.cg_tolerance
        ),
    }
}

/// `v = v₀ + ω × (x − c)` for every node, `c` the mass-weighted centroid.
fn initial_velocities(scene: &VecScene, v0: [f64; 3], omega: [f64; 3]) -> Vec<[f32; 3]> {
    // `as u32`: a scene has at most 65 536 nodes.
    let n = scene.node_count() as u32;
    let (mut m_sum, mut c) = (0.0f64, [0.0f64; 3]);
    for i in 0..n {
        let m = f64::from(scene.mass(i).unwrap_or(0.0));
        let x = scene.position(i).unwrap_or_default();
        m_sum += m;
        for k in 0..3 {
            c[k] += m * f64::from(x[k]);
        }
    }
    let c = c.map(|x| x / m_sum.max(f64::MIN_POSITIVE));
    scene
        .positions()
        .map(|x| {
            let r = [0, 1, 2].map(|k| f64::from(x[k]) - c[k]);
            let w = [
                omega[1] * r[2] - omega[2] * r[1],
                omega[2] * r[0] - omega[0] * r[2],
                omega[0] * r[1] - omega[1] * r[0],
            ];
            [0, 1, 2].map(|k| (v0[k] + w[k]) as f32)
        })
        .collect()
}

/// `k · dt` (s), rounded to 12 significant digits so that `0.1` prints as `0.1`.
fn time(k: u64, dt: f64) -> f64 {
    let t = k as f64 * dt;
    format!("{t:.11e}").parse().unwrap_or(t)
}

fn norm(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Where the VTK frames went, for the summary.
struct VtkWritten<'a> {
    dir: &'a Path,
    frames: u64,
    /// Frames of the `[visual]` surface, if the scene has one.
    surface_frames: Option<usize>,
}

/// The summary printed on stderr: one labelled line per topic, values
/// aligned.
fn summary(
    spec: &SceneSpec,
    mesh: &CoreMesh,
    r: &RunResult,
    extremes: &Extremes,
    out: &Destination,
    vtk: Option<VtkWritten<'_>>,
    visual: Option<String>,
) -> String {
    let mut lines: Vec<(&str, String)> = Vec::new();
    lines.push((
        "scene",
        format!(
            "{} ({}, {}, {}, {})",
            spec.file,
            r.method,
            counted(r.mesh.nodes as u64, "node"),
            counted(r.mesh.tets as u64, "tet"),
            mesh.name
        ),
    ));
    let t = &r.timing;
    match r.static_solve {
        Some(s) => {
            let outcome = if s.converged {
                format!(
                    "converged: out-of-balance force {:.1e} of the load (newton_tolerance {:.0e})",
                    s.force, s.tolerance
                )
            } else if s.met.is_some() {
                format!(
                    "the shape converged (last update {:.1e} of the displacement); the \
                     out-of-balance force stays at {:.1e} of the load, f32's round-off floor, \
                     above newton_tolerance {:.0e}",
                    s.update, s.force, s.tolerance
                )
            } else {
                format!(
                    "NOT converged: out-of-balance force {:.1e} of the load (newton_tolerance {:.0e})",
                    s.force, s.tolerance
                )
            };
            lines.push((
                "static",
                format!("{} Newton iterations, {outcome}", r.steps),
            ));
            lines.push((
                "wall time",
                format!(
                    "{:.3} s; {} ms per iteration (median), {} ms min",
                    t.total_s,
                    sig(t.ms_per_step_median),
                    sig(t.ms_per_step_min)
                ),
            ));
        }
        None => lines.push((
            "ran",
            format!(
                "{} steps of {} s in {:.3} s; {} ms per step (median), {} ms min",
                thousands(r.steps),
                spec.dt,
                t.total_s,
                sig(t.ms_per_step_median),
                sig(t.ms_per_step_min)
            ),
        )),
    }
    let last = r.history.last();
    let ke = last.map_or(0.0, |h| h.kinetic_energy);
    let ee = last.map_or(0.0, |h| h.elastic_energy);
    let max_disp = r
        .final_state
        .positions
        .iter()
        .zip(&mesh.nodes)
        .map(|(x, x0)| norm([x[0] - x0[0], x[1] - x0[1], x[2] - x0[2]]))
        .fold(0.0f32, f32::max);
    lines.push((
        "final",
        format!(
            "kinetic {} J, elastic {} J, largest displacement {} m, {} inverted (at most {} during the run)",
            sig(f64::from(ke)),
            sig(f64::from(ee)),
            sig(f64::from(max_disp)),
            r.final_state.inverted,
            extremes.inverted
        ),
    ));
    if extremes.guarded_steps > 0 {
        lines.push((
            "energy guard",
            format!(
                "took out {} J made by {} steps (energy_guard in docs/scene-format.md)",
                sig(extremes.energy_removed),
                extremes.guarded_steps
            ),
        ));
    }
    if spec.tool.is_some() {
        lines.push((
            "tool",
            format!("max |force| {} N", sig(f64::from(extremes.tool_force))),
        ));
    }
    if let Some(v) = visual {
        lines.push(("surface", v));
    }
    lines.push((
        "result",
        match out {
            Destination::File(p) => p.display().to_string(),
            Destination::Stdout => "standard output".into(),
        },
    ));
    if let Some(v) = vtk {
        lines.push((
            "vtk",
            format!(
                "{} frames in {} (open series.pvd)",
                v.frames,
                v.dir.display()
            ),
        ));
        if let Some(n) = v.surface_frames {
            lines.push((
                "",
                format!("{n} surface frames beside them (open surface.pvd)"),
            ));
        }
    }
    let mut text = String::new();
    for (label, value) in lines {
        if !text.is_empty() {
            text.push('\n');
        }
        text.push_str(&format!("{label:<10} {value}"));
    }
    text
}

/// `1 tet`, `1,331 tets`: a count with its noun.
fn counted(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{} {noun}s", thousands(n))
    }
}

/// `1,331`: a count with thousands separators.
fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut s = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            s.push(',');
        }
        s.push(c);
    }
    s
}

/// `x` in 3 significant digits: plain decimals from 0.001 to 10,000
/// (`0.0123`, `412`), exponent notation outside (`1.23e-5`), `0` for zero.
fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor();
    if (-3.0..4.0).contains(&mag) {
        let decimals = (2.0 - mag).max(0.0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.2e}")
    }
}

/// The message for a body that starts below the ground: the node the step
/// named, its depth, and the largest `offset` that clears every free node.
fn below_ground(scene: &VecScene, node: u32, what: &str) -> CliError {
    let Some(g) = scene.ground() else {
        return CliError(format!("{what}: node {node} is below it"));
    };
    let height = |x: [f32; 3]| {
        f64::from(g.normal[0]) * f64::from(x[0])
            + f64::from(g.normal[1]) * f64::from(x[1])
            + f64::from(g.normal[2]) * f64::from(x[2])
    };
    let lowest = (0..scene.node_count() as u32)
        .filter(|&i| !scene.is_fixed(i))
        .filter_map(|i| scene.position(i))
        .map(height)
        .fold(f64::INFINITY, f64::min);
    let depth = scene
        .position(node)
        .map_or(0.0, |x| f64::from(g.offset) - height(x));
    CliError(format!(
        "{what}: node {node} is {depth:.3e} m below the plane; set the ground's \
         `offset` to at most {lowest:.6e} (the lowest free node's height along its \
         normal), or move the mesh above it"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1331), "1,331");
        assert_eq!(thousands(1_234_567), "1,234,567");
        assert_eq!(sig(0.0), "0");
        assert_eq!(sig(0.0123456), "0.0123");
        assert_eq!(sig(0.71234), "0.712");
        assert_eq!(sig(412.3), "412");
        assert_eq!(sig(1.5), "1.50");
        assert_eq!(sig(1.234e-5), "1.23e-5");
        assert_eq!(sig(-2.5e6), "-2.50e6");
    }

    #[test]
    fn times_print_cleanly() {
        assert_eq!(time(100, 0.001), 0.1);
        assert_eq!(time(3, 0.1), 0.3);
        assert_eq!(time(0, 0.001), 0.0);
    }
}
