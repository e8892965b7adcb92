//! The firmware example's scene, defined once. Three programs run this very
//! module and print the hash of the final state: the firmware on a Cortex-M4F
//! (`examples/firmware`, in QEMU), the wasm module of `examples/wasm-hash`
//! (under node) and the host test `host-tests/tests/firmware_hash.rs`; CI
//! compares the three.
//!
//! A beam of `cx × cy × cz` cubes of 0.1 m (6 tetrahedra each) is held at
//! `x = 0`. A haptic tool grabs the nodes of the far face `x = 0.1 cx` with a
//! spring and pokes: each step the device's position goes in
//! ([`tool_target`]) and the force the body exerts on the tool comes out
//! (`StepStats::tool_force`), as in a 1 kHz haptic loop.
//!
//! `no_std`, no allocation, no panicking code: only `corofem` and `core`.

use corofem::{
    BoxMesh, BuildOptions, Error, Material, Method, Preconditioner, Scene, Settings, StepError,
    StepStats, Storage, Vec3,
};

/// Edge of one cubic cell (m).
pub const CELL: f32 = 0.1;
/// Tetrahedra per cell (Kuhn split).
pub const TETS_PER_CELL: u8 = 6;
/// The scene sizes measured (cells along x, y, z): 48, 96, 240 and 480
/// tetrahedra.
pub const SIZES: [[u32; 3]; 4] = [[2, 2, 2], [4, 2, 2], [10, 2, 2], [20, 2, 2]];
/// The reference scene: a 1 m × 0.2 m × 0.2 m beam, 99 nodes, 240 tetrahedra.
pub const REFERENCE: [u32; 3] = [10, 2, 2];
/// Haptic steps of 1 ms each.
pub const STEPS: u32 = 500;
/// Most nodes on one end face, `(cy + 1)(cz + 1)`.
pub const MAX_FACE_NODES: usize = 64;

/// A soft rubber.
pub const MATERIAL: Material = Material {
    young: 2.0e6,
    poisson: 0.35,
    density: 1000.0,
};
/// Stiffness of the tool's spring (N/m): a typical haptic device renders
/// 1–3 kN/m.
pub const TOOL_STIFFNESS: f32 = 2.0e3;
/// How deep the tool pokes (m).
pub const POKE_DEPTH: f32 = 0.03;

/// Qr, 1 ms steps, 5 CG iterations, light Rayleigh damping. No gravity:
/// the beam starts at rest in equilibrium, so every newton on the tool comes
/// from the poke.
#[must_use]
pub const fn settings() -> Settings {
    settings_with(Preconditioner::Mass)
}

/// The scene's settings with preconditioner `pre`: the lumped mass with 5
/// CG iterations (the paper's CG), or a stiffness-aware preconditioner
/// with 4 iterations from the last step's solution (warm start), which
/// costs about as much on a host.
#[must_use]
pub const fn settings_with(pre: Preconditioner) -> Settings {
    Settings {
        method: Method::Qr,
        dt: 1.0e-3,
        rayleigh_mass: 1.0,
        rayleigh_stiffness: 1.0e-3,
        gravity: [0.0; 3],
        // Firmware images leave the feature out (its energy sum costs
        // ~48 instructions per tetrahedron-step).
        energy_guard: false,
        // The beam is clamped: free rotation never applies (and firmware
        // images leave the feature out).
        free_rotation: false,
        // The budget (5 or 4), tolerance 0 and warm start (off for the
        // mass) of the preconditioner.
        ..Settings::with_preconditioner(pre)
    }
}

/// Aggregates of the two-level preconditioner for the beam of `cells`:
/// what [`corofem::aggregates_for`] gives its free nodes (all but the
/// held face), the storage's aggregate slots.
#[cfg(feature = "two-level")]
#[must_use]
pub const fn aggregates(cells: [u32; 3]) -> usize {
    let nodes = mesh(cells).node_count();
    corofem::aggregates_for(nodes.saturating_sub(grabbed_nodes(cells)), usize::MAX)
}

/// The beam of `cells` cubes.
#[must_use]
pub const fn mesh(cells: [u32; 3]) -> BoxMesh {
    BoxMesh {
        size: [
            CELL * cells[0] as f32,
            CELL * cells[1] as f32,
            CELL * cells[2] as f32,
        ],
        cells,
        tets_per_cell: TETS_PER_CELL,
    }
}

/// Nodes the tool grabs on the beam of `cells`, its end face:
/// `(cy + 1)(cz + 1)` (the storage's grab slots, `G`).
#[must_use]
pub const fn grabbed_nodes(cells: [u32; 3]) -> usize {
    (cells[1] as usize + 1).saturating_mul(cells[2] as usize + 1)
}

/// Nodes of the face `x = i · CELL` of the beam, written into `out`
/// (node `(i, j, k)` has index `i + (cx+1)(j + (cy+1) k)`, see `BoxMesh`).
fn face(cells: [u32; 3], i: u32, out: &mut [u32; MAX_FACE_NODES]) -> &[u32] {
    let [cx, cy, cz] = cells;
    let mut slots = out.iter_mut();
    let mut n = 0;
    for k in 0..=cz {
        for j in 0..=cy {
            if let Some(slot) = slots.next() {
                *slot = i + (cx + 1) * (j + (cy + 1) * k);
                n += 1;
            }
        }
    }
    out.get(..n).unwrap_or(&[])
}

/// Builds the scene of `cells` into `scene`, using `nodes` and `tets` as
/// scratch for the generated mesh: held at `x = 0`, the far face grabbed by
/// the tool. Returns where the tool starts (m).
pub fn setup<S: Storage>(
    scene: &mut Scene<S>,
    cells: [u32; 3],
    nodes: &mut [Vec3],
    tets: &mut [[u32; 4]],
) -> Result<Vec3, Error> {
    setup_with(scene, cells, nodes, tets, Preconditioner::Mass)
}

/// [`setup`] with the settings of [`settings_with`]`(pre)`.
pub fn setup_with<S: Storage>(
    scene: &mut Scene<S>,
    cells: [u32; 3],
    nodes: &mut [Vec3],
    tets: &mut [[u32; 4]],
    pre: Preconditioner,
) -> Result<Vec3, Error> {
    if grabbed_nodes(cells) > MAX_FACE_NODES {
        return Err(Error::TooManyGrabbed {
            count: grabbed_nodes(cells),
            capacity: MAX_FACE_NODES,
        });
    }
    let (n, t) = mesh(cells).generate(nodes, tets)?;
    let nodes = nodes.get(..n).unwrap_or(&[]);
    let tets = tets.get(..t).unwrap_or(&[]);
    scene.build(nodes, tets, &MATERIAL, BuildOptions::default())?;
    scene.set_settings(settings_with(pre))?;
    let mut ids = [0u32; MAX_FACE_NODES];
    scene.fix_nodes(face(cells, 0, &mut ids))?;
    scene.grab(face(cells, cells[0], &mut ids), TOOL_STIFFNESS)?;
    Ok(scene.tool_target())
}

/// Where the haptic device holds the tool at step `k` (m): a smooth poke
/// down (and a little sideways) and back up,
/// `start + depth · b(s) · (0, ½, −1)` with `b(s) = 16 s² (1 − s)²`,
/// `s = k / STEPS`: zero at both ends, 1 half way.
#[must_use]
pub fn tool_target(start: Vec3, k: u32) -> Vec3 {
    let s = k as f32 * (1.0 / STEPS as f32);
    let r = s * (1.0 - s);
    let b = 16.0 * r * r;
    let d = POKE_DEPTH * b;
    [start[0], start[1] + 0.5 * d, start[2] - d]
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outcome {
    /// `Scene::state_hash` after the last step.
    pub hash: u64,
    /// Steps run.
    pub steps: u32,
    /// Fewest CG iterations of a step.
    pub min_cg_iterations: u32,
    /// CG iterations of all the steps.
    pub cg_iterations: u32,
    /// Most inverted elements at the start of a step.
    pub max_inverted: u32,
    /// Largest upward force on the tool (N): the beam pushing back.
    pub peak_push: f32,
    /// Force on the tool after the last step (N).
    pub final_force: Vec3,
    /// Most nodes the ground and probes held in one step
    /// (`StepStats::contacts`).
    pub max_contacts: u32,
    /// Steps in which the ground or a probe held a node.
    pub contact_steps: u32,
}

/// Runs [`STEPS`] haptic steps from the tool's start: `step(scene, target)`
/// must move the tool to `target` and step (the firmware times it; the
/// others call `Scene::step_haptic`).
pub fn run<S: Storage>(
    scene: &mut Scene<S>,
    start: Vec3,
    mut step: impl FnMut(&mut Scene<S>, Vec3) -> Result<StepStats, StepError>,
) -> Result<Outcome, StepError> {
    let mut out = Outcome {
        min_cg_iterations: u32::MAX,
        ..Outcome::default()
    };
    for k in 1..=STEPS {
        let stats = step(scene, tool_target(start, k))?;
        out.steps += 1;
        out.min_cg_iterations = out.min_cg_iterations.min(stats.cg_iterations);
        out.cg_iterations = out.cg_iterations.saturating_add(stats.cg_iterations);
        out.max_inverted = out.max_inverted.max(stats.inverted);
        out.peak_push = out.peak_push.max(stats.tool_force[2]);
        out.final_force = stats.tool_force;
        out.max_contacts = out.max_contacts.max(stats.contacts);
        out.contact_steps += u32::from(stats.contacts > 0);
    }
    out.hash = scene.state_hash();
    Ok(out)
}

/// Whether a run's results are plausible, whatever the target: every step
/// ran, each with the full 5 CG iterations, no element inverted, the beam
/// pushed the tool back up by more than 1 N, and it ends finite.
pub fn check(out: &Outcome) -> Result<(), &'static str> {
    check_with(out, Preconditioner::Mass)
}

/// [`check`] for a run with [`settings_with`]`(pre)`: every step ran at
/// least that budget of CG iterations.
pub fn check_with(out: &Outcome, pre: Preconditioner) -> Result<(), &'static str> {
    if out.steps != STEPS {
        return Err("not every step ran");
    }
    if out.min_cg_iterations < settings_with(pre).cg_iterations {
        return Err("a step stopped CG early");
    }
    if out.max_inverted != 0 {
        return Err("an element inverted");
    }
    if !(out.peak_push > 1.0 && out.peak_push < 1.0e3) {
        return Err("implausible tool force");
    }
    if !out.final_force.iter().all(|f| f.is_finite()) {
        return Err("non-finite tool force");
    }
    Ok(())
}

/// Which obstacles the scene in contact has (see [`Contacts`]). An
/// obstacle whose feature of this crate is off is left out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContactSet {
    /// The ground plane `z ≥ 0`, on which the beam rests (feature `ground`).
    pub ground: bool,
    /// A sphere probe pressing into the beam from above (feature `probe`).
    pub probe: bool,
    /// Coulomb friction ([`FRICTION`]) on the ground and the probe
    /// (feature `friction`).
    pub friction: bool,
}

impl ContactSet {
    /// No obstacle: the scene of [`setup`] and [`run`].
    pub const NONE: Self = Self {
        ground: false,
        probe: false,
        friction: false,
    };
    /// The beam on the ground.
    pub const GROUND: Self = Self {
        ground: true,
        ..Self::NONE
    };
    /// The beam on the ground, the probe pressing into it.
    pub const PROBE: Self = Self {
        probe: true,
        ..Self::GROUND
    };
    /// The same with friction on the ground and the probe.
    pub const PROBE_FRICTION: Self = Self {
        friction: true,
        ..Self::PROBE
    };
    /// The sets the host computes and the firmware's features build.
    pub const ALL: [Self; 3] = [Self::GROUND, Self::PROBE, Self::PROBE_FRICTION];
    /// What this crate's features compile in (what the firmware runs).
    pub const COMPILED: Self = Self {
        ground: cfg!(feature = "ground"),
        probe: cfg!(feature = "probe"),
        friction: cfg!(feature = "friction"),
    };

    /// Whether any obstacle is there.
    #[must_use]
    pub const fn any(&self) -> bool {
        self.ground || self.probe
    }

    /// A short name: `none`, `ground`, `ground-probe`,
    /// `ground-probe-friction`, ... (the hash lines' label).
    #[must_use]
    pub const fn name(&self) -> &'static str {
        match (self.ground, self.probe, self.friction) {
            (false, false, false) => "none",
            (true, false, false) => "ground",
            (true, true, false) => "ground-probe",
            (true, true, true) => "ground-probe-friction",
            (true, false, true) => "ground-friction",
            (false, true, false) => "probe",
            (false, true, true) => "probe-friction",
            (false, false, true) => "friction",
        }
    }
}

/// Height of the ground plane (m): the beam's bottom face `z = 0` lies on
/// it.
pub const GROUND_Z: f32 = 0.0;
/// Radius of the sphere probe (m): large enough that, pressed in, it holds
/// several nodes of the 0.1 m cells.
pub const PROBE_RADIUS: f32 = 0.3;
/// Gap between the probe and the beam's top face at the start (m).
pub const PROBE_GAP: f32 = 0.01;
/// How far the probe moves down at its deepest, half way (m): 1 cm into the
/// beam's top face.
pub const PROBE_DEPTH: f32 = 0.03;
/// The static and kinetic friction coefficients of the ground and the probe.
pub const FRICTION: [f32; 2] = [0.6, 0.4];

/// The obstacles of the scene in contact and the probe's state. The beam
/// of [`setup`] rests on the ground `z ≥ 0` (its bottom face lies on it),
/// the tool pokes its far end down into it, and a sphere probe of
/// [`PROBE_RADIUS`] over the middle of the beam's top face moves down by
/// [`PROBE_DEPTH`] (1 cm into the beam) and back up on the tool's profile
/// ([`probe_position`]), squeezing the beam against the ground.
#[derive(Clone, Copy, Debug)]
pub struct Contacts {
    set: ContactSet,
    /// Steps taken by [`Contacts::step`].
    steps: u32,
    #[cfg(feature = "probe")]
    probe: [corofem::Probe; 1],
    #[cfg(feature = "probe")]
    probe_start: Vec3,
    /// Largest upward force of the body on the probe (N).
    pub probe_peak_force: f32,
    /// Most nodes the probe held in one step.
    pub probe_max_contacts: u32,
}

impl Contacts {
    /// Sets the obstacles of `set` up in the scene of [`setup`] for the
    /// beam of `cells`: the ground and its friction; the probe, outside the
    /// body.
    pub fn setup<S: Storage>(
        scene: &mut Scene<S>,
        cells: [u32; 3],
        set: ContactSet,
    ) -> Result<Self, Error> {
        let set = ContactSet {
            ground: set.ground && ContactSet::COMPILED.ground,
            probe: set.probe && ContactSet::COMPILED.probe,
            friction: set.friction && ContactSet::COMPILED.friction,
        };
        #[cfg(feature = "ground")]
        if set.ground {
            scene.set_ground(Some(corofem::Plane {
                normal: [0.0, 0.0, 1.0],
                offset: GROUND_Z,
            }))?;
            #[cfg(feature = "friction")]
            if set.friction {
                scene.set_ground_friction(friction()?);
            }
        }
        #[cfg(not(feature = "ground"))]
        let _ = scene;
        let size = mesh(cells).size;
        let probe_start = [
            0.5 * size[0],
            0.5 * size[1],
            size[2] + PROBE_RADIUS + PROBE_GAP,
        ];
        #[cfg(not(feature = "probe"))]
        let _ = probe_start;
        Ok(Self {
            set,
            steps: 0,
            #[cfg(feature = "probe")]
            probe: [probe(probe_start, set)?],
            #[cfg(feature = "probe")]
            probe_start,
            probe_peak_force: 0.0,
            probe_max_contacts: 0,
        })
    }

    /// The obstacles in the scene.
    #[must_use]
    pub fn set(&self) -> ContactSet {
        self.set
    }

    /// One haptic step with the obstacles: the tool's target to `target`,
    /// the probe to its pose of the next step ([`probe_position`]), then
    /// `Scene::step_with_probes` (with a probe) or `Scene::step_haptic`.
    pub fn step<S: Storage>(
        &mut self,
        scene: &mut Scene<S>,
        target: Vec3,
    ) -> Result<StepStats, StepError> {
        let k = self.steps.saturating_add(1);
        let stats = self.step_at(scene, k, target)?;
        self.steps = k;
        Ok(stats)
    }

    /// [`Contacts::step`] with the probe at its pose of step `k` (not
    /// counted as a step of the run).
    pub fn step_at<S: Storage>(
        &mut self,
        scene: &mut Scene<S>,
        k: u32,
        target: Vec3,
    ) -> Result<StepStats, StepError> {
        #[cfg(feature = "probe")]
        if self.set.probe {
            let [probe] = &mut self.probe;
            probe
                .move_to(probe_position(self.probe_start, k), [0.0, 0.0, 1.0])
                .map_err(|_| StepError::NonFiniteInput)?;
            scene
                .set_tool_target(target)
                .map_err(|_| StepError::NonFiniteInput)?;
            let stats = scene.step_with_probes(&mut self.probe)?;
            let [probe] = &self.probe;
            self.probe_peak_force = self.probe_peak_force.max(probe.force()[2]);
            self.probe_max_contacts = self.probe_max_contacts.max(probe.contacts());
            return Ok(stats);
        }
        let _ = k;
        scene.step_haptic(target)
    }
}

/// The friction of the ground and the probe ([`FRICTION`]).
#[cfg(feature = "friction")]
pub fn friction() -> Result<corofem::Friction, Error> {
    corofem::Friction::new(FRICTION[0], FRICTION[1])
}

/// The sphere probe at `centre`, with friction if `set` has it.
#[cfg(feature = "probe")]
fn probe(centre: Vec3, set: ContactSet) -> Result<corofem::Probe, Error> {
    let p = corofem::Probe::sphere(PROBE_RADIUS, centre)?;
    #[cfg(feature = "friction")]
    if set.friction {
        return Ok(p.with_friction(friction()?));
    }
    let _ = set;
    Ok(p)
}

/// Where the probe's centre is at the end of step `k`: `start − (0, 0,
/// PROBE_DEPTH · b(s))`, the tool's profile `b` ([`tool_target`]).
#[must_use]
pub fn probe_position(start: Vec3, k: u32) -> Vec3 {
    let s = k as f32 * (1.0 / STEPS as f32);
    let r = s * (1.0 - s);
    let b = 16.0 * r * r;
    [start[0], start[1], start[2] - PROBE_DEPTH * b]
}

/// [`check_with`] for a run of the scene in contact, and that the
/// obstacles touched the body: some step held nodes, and the probe (if
/// there) held some. A step may end its solve before the CG budget here:
/// with the frictionless probe, a step whose residual reaches exactly zero
/// stops (`StepStats::cg_residual` 0); [`Outcome::cg_iterations`] counts
/// what ran.
pub fn check_contacts(
    out: &Outcome,
    contacts: &Contacts,
    pre: Preconditioner,
) -> Result<(), &'static str> {
    let full = Outcome {
        min_cg_iterations: out.min_cg_iterations.max(settings_with(pre).cg_iterations),
        ..*out
    };
    if out.min_cg_iterations == 0 {
        return Err("a step ran no CG iteration");
    }
    check_with(&full, pre)?;
    if contacts.set.any() && out.contact_steps == 0 {
        return Err("no contact");
    }
    if contacts.set.probe && !(contacts.probe_max_contacts > 0 && contacts.probe_peak_force > 0.0) {
        return Err("the probe touched nothing");
    }
    Ok(())
}
