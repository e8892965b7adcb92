//! Plain configuration structs with documented units and defaults, and the
//! statistics a step returns.

use crate::element::Method;
use crate::math::Vec3;

/// What preconditions the step's conjugate gradients.
///
/// Every variant exists in every build; `BlockJacobi` and `TwoLevel` need
/// the feature `two-level` and storage for their data, else the scene
/// refuses them ([`Error::PreconditionerUnavailable`](crate::Error::PreconditionerUnavailable)).
// `Mass` is 0: an all-zero `Settings` (a `static` scene's header) holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Preconditioner {
    /// The lumped mass (the paper's CG): one scalar per node, nearly free,
    /// and every iterate keeps the momentum of an isolated body. Blind to
    /// stiffness: soft or finely meshed bodies need many iterations.
    Mass = 0,
    /// The 3×3 node blocks of the system matrix: sees small and sliver
    /// elements.
    BlockJacobi = 1,
    /// Node blocks plus a coarse space of rigid-body modes per aggregate of
    /// nodes, turned with the body: carries bending and sagging across the
    /// body in one iteration.
    TwoLevel = 2,
}

impl Preconditioner {
    /// Every preconditioner, in a fixed order.
    pub const VARIANTS: [Preconditioner; 3] = [
        Preconditioner::Mass,
        Preconditioner::BlockJacobi,
        Preconditioner::TwoLevel,
    ];

    /// The preconditioner of this build's defaults ([`Settings::compiled`]
    /// of [`Settings::new`]): `TwoLevel` where the feature `two-level` is
    /// compiled in, else `Mass`, the paper's CG.
    pub const DEFAULT: Preconditioner = if cfg!(feature = "two-level") {
        Preconditioner::TwoLevel
    } else {
        Preconditioner::Mass
    };

    /// The scene-file name: `"mass"`, `"block-jacobi"` or `"two-level"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Preconditioner::Mass => "mass",
            Preconditioner::BlockJacobi => "block-jacobi",
            Preconditioner::TwoLevel => "two-level",
        }
    }

    /// The preconditioner with this scene-file name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Preconditioner> {
        Self::VARIANTS.into_iter().find(|p| p.name() == name)
    }

    /// Whether this build has it.
    #[must_use]
    pub const fn is_compiled(self) -> bool {
        matches!(self, Preconditioner::Mass) || cfg!(feature = "two-level")
    }
}

impl Default for Preconditioner {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How the scene is stepped.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// Element method; one that is not compiled in is refused
    /// ([`Error::MethodNotCompiled`](crate::Error::MethodNotCompiled)).
    /// Default `QrInvertible` ([`Method::DEFAULT`] in a build without it).
    pub method: Method,
    /// Time step `h` (s, `> 0`). Default 0.001.
    pub dt: f32,
    /// Conjugate-gradient iterations per step (`≥ 1`): the budget. Default 4
    /// with `TwoLevel`, 5 with `Mass` ([`Settings::with_preconditioner`]).
    ///
    /// A solve stops at the budget only where its truncation adds no energy
    /// to the body (the step's energy certificate, checked with one pass
    /// over the nodes); otherwise it goes on, up to
    /// [`Settings::iteration_cap`], and a solve that still has no
    /// certificate there ends with a Galerkin step on the span of its
    /// solution and the current velocity, which has one (three products with
    /// the system matrix). [`StepStats::cg_iterations`] reports what ran.
    pub cg_iterations: u32,
    /// Relative residual at which CG stops early (`≥ 0`; 0 = no early stop,
    /// except at the f32 round-off floor, a squared norm of `ε²` of the
    /// initial one, below which iterating only makes slow subnormal
    /// numbers). Default 0. Measured for every preconditioner in the
    /// lumped-mass norm `sqrt(rᵀ M'⁻¹ r)` over the free directions
    /// (`M' = (1 + h α_M) M`, plus the tool's spring on grabbed nodes): the
    /// residual force as the velocity error it would make, the norm the
    /// `Mass` preconditioner works in; [`StepStats::cg_residual`] reports it.
    pub cg_tolerance: f32,
    /// Mass-proportional Rayleigh damping `α_M` (1/s, `≥ 0`). Default 0.
    pub rayleigh_mass: f32,
    /// Stiffness-proportional Rayleigh damping `α_K` (s, `≥ 0`). Default 0.
    pub rayleigh_stiffness: f32,
    /// The stiffness-proportional damping (s, `≥ 0`) a body has while the
    /// ground has friction (feature `friction`): the step damps with
    /// `max(rayleigh_stiffness, friction_damping)` then, a Kelvin–Voigt
    /// viscosity `friction_damping · E`. An undamped elastic body under
    /// Coulomb friction has no well-posed motion at large μ (Renardy 1992,
    /// Martins et al. 1995): it flutters, with a growth that finer meshes
    /// and shorter steps make faster, and a block below its friction angle
    /// walks down the slope. Under a Kelvin–Voigt viscosity dynamic
    /// frictional contact is well posed. With 3 ms every judged case of
    /// the slope sweep holds Coulomb's law, with 1 ms 12 of 468 do not
    /// (docs/contact.md); 3 ms is 34 % of critical at the 10 × 10 × 5 cm,
    /// 100 kPa block's 36 Hz bounce. 0 keeps the body undamped. Default
    /// `3e-3`.
    pub friction_damping: f32,
    /// Start CG from the previous step's velocity change (with its net linear
    /// and angular momentum removed when nothing holds the body). The guess
    /// costs no extra pass over the elements: the force pass's stiffness
    /// product takes the velocity plus the guess. Steps with ground
    /// contacts start cold. A guess cannot add energy: the energy
    /// certificate of [`Settings::cg_iterations`] holds for every start.
    /// Default on with `TwoLevel`, off with `Mass`.
    pub warm_start: bool,
    /// What preconditions CG. Default `TwoLevel` ([`Preconditioner::DEFAULT`]
    /// in a build or a storage without it).
    pub preconditioner: Preconditioner,
    /// Gravity (m/s²). Default `(0, 0, −9.81)`.
    pub gravity: Vec3,
    /// The energy guard: a step whose start finds the body with more energy
    /// (kinetic, elastic, the potential of gravity and the loads, and the
    /// tool spring's) than the previous step left it, less the work of
    /// moving the tool's target since, while nothing else did work on it
    /// and elements were inverted, first takes the excess out of the
    /// velocity's deformation part, keeping the linear and angular momentum
    /// ([`StepStats::energy_removed`]). Nothing else does work in a step in
    /// which no ground holds the body (the ground's held nodes, its impact
    /// and its projection do work) and after which no call changed the
    /// scene (grabbing and releasing forget the reference; moving the
    /// target does not). It stops the energy that `Qr`'s forces feed in once
    /// elements invert (they are not the gradient of an energy there).
    /// Steps without inverted elements are left as the implicit step makes
    /// them: the energy measured is not one the co-rotational step conserves
    /// exactly, and taking out what it gains there would take the motion
    /// away from the implicit step's (a hanging liver's swing by 11 %,
    /// docs/bench.md). It costs the elastic energy's sum in the
    /// force pass and one pass over the nodes; a correction, which a step
    /// that makes no energy never needs, one pass more. Needs the feature
    /// `energy-guard` (`true` without it is refused). Default on.
    pub energy_guard: bool,
    /// Free rotation: a body that nothing holds (no fixed node, tool or
    /// contact) and that moves as one over a step (a pressure wave crosses
    /// it within the step: stiff, or a long step) turns by a rigid
    /// rotation, the implicit midpoint rule of its rotation, instead of
    /// moving along its tangents, which stretches a body spinning at `ω`
    /// by `(h |ω|)²/2` a step. Keeps the linear and angular momentum and the
    /// rigid kinetic energy; the body's deformation turns with it. Softer
    /// bodies and shorter steps keep the tangent update, and so does
    /// `Method::Linear`, whose elements are not invariant under rotations.
    /// It costs a pass over the nodes (two with a turn) in the steps of a
    /// free body. Needs the feature `free-rotation` (`true` without it is
    /// refused). Default on.
    pub free_rotation: bool,
    /// Most rounds of the contact state in a step (with the feature
    /// `friction`; nothing without it). After the solve, each held node's
    /// friction is made Coulomb's for the impulse the solve computed: a
    /// sticking node whose impulse leaves the static cone slides, a
    /// sliding node's kinetic force follows its normal impulse, one that
    /// its force turned back sticks, and a free node that the solve takes
    /// below a ground with friction is caught there (held from that round
    /// on; not for a body a pressure wave crosses within the step, whose
    /// landing is stopped whole after the solve). While a round changes a
    /// node the solve goes on from where it stopped, with `cg_iterations`
    /// more, twice that for a body a pressure wave crosses within the step
    /// (a change at one contact moves all of it). 0 keeps
    /// the state the step started with (each node's decided after the last
    /// step): one solve, but a node that lands or starts to stick is
    /// stopped by whatever impulse that takes. Default 4.
    pub contact_rounds: u32,
}

/// [`Settings::friction_damping`]'s default (s).
const FRICTION_DAMPING: f32 = 3e-3;

impl Settings {
    /// The documented defaults, the same in every build: `QrInvertible`,
    /// the two-level preconditioner with 4 CG iterations from a warm start,
    /// the energy guard and free rotation on
    /// ([`Settings::with_preconditioner`] of `TwoLevel`).
    ///
    /// A build without a feature they need refuses them
    /// ([`Error::MethodNotCompiled`](crate::Error::MethodNotCompiled),
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter)), and a
    /// storage without the two-level preconditioner's slots (a
    /// [`StaticScene`](crate::StaticScene) whose capacity leaves out
    /// `preconditioner`) refuses the preconditioner
    /// ([`Error::PreconditionerUnavailable`](crate::Error::PreconditionerUnavailable)).
    /// [`Settings::compiled`] gives the nearest settings a build runs, and
    /// [`Scene::default_settings`](crate::Scene::default_settings) those
    /// a scene's storage runs: start a scene's settings from it.
    #[must_use]
    pub const fn new() -> Self {
        Self::with_preconditioner(Preconditioner::TwoLevel)
    }

    /// These settings with what this build lacks replaced by what it has: a
    /// method that is not compiled in by [`Method::DEFAULT`], a
    /// preconditioner that is not by the lumped mass (with its budget,
    /// [`Settings::with_preconditioner`]), and the energy guard and free
    /// rotation off where their features are. Settings the build runs are
    /// returned unchanged.
    #[must_use]
    pub const fn compiled(self) -> Self {
        let mut s = self;
        if !s.method.is_compiled() {
            s.method = Method::DEFAULT;
        }
        if !s.preconditioner.is_compiled() {
            let mass = Self::with_preconditioner(Preconditioner::Mass);
            s.preconditioner = mass.preconditioner;
            s.cg_iterations = mass.cg_iterations;
            s.warm_start = mass.warm_start;
        }
        s.energy_guard &= cfg!(feature = "energy-guard");
        s.free_rotation &= cfg!(feature = "free-rotation");
        s
    }

    /// The documented defaults with preconditioner `pre` and its budget:
    /// 5 CG iterations from a cold start for `Mass` (the paper's CG), 4 from
    /// a warm start for the preconditioners that see stiffness (within 1 %
    /// of converged implicit steps on the benchmark scenes, at about the
    /// cost of the paper's 5: docs/bench.md).
    #[must_use]
    pub const fn with_preconditioner(pre: Preconditioner) -> Self {
        let stiffness_aware = !matches!(pre, Preconditioner::Mass);
        Self {
            method: Method::QrInvertible,
            dt: 1.0e-3,
            cg_iterations: if stiffness_aware { 4 } else { 5 },
            cg_tolerance: 0.0,
            rayleigh_mass: 0.0,
            rayleigh_stiffness: 0.0,
            friction_damping: FRICTION_DAMPING,
            warm_start: stiffness_aware,
            preconditioner: pre,
            gravity: [0.0, 0.0, -9.81],
            energy_guard: true,
            free_rotation: true,
            contact_rounds: 4,
        }
    }

    /// All zero bits (`dt = 0`, not valid settings): what an empty scene's
    /// header holds in their place, so that it can be zero-initialised
    /// (`state::Header`). `Qr` is the method whose discriminant is 0.
    pub(crate) const ZERO: Self = Self {
        method: Method::Qr,
        dt: 0.0,
        cg_iterations: 0,
        cg_tolerance: 0.0,
        rayleigh_mass: 0.0,
        rayleigh_stiffness: 0.0,
        friction_damping: 0.0,
        warm_start: false,
        preconditioner: Preconditioner::Mass,
        gravity: [0.0; 3],
        energy_guard: false,
        free_rotation: false,
        contact_rounds: 0,
    };

    /// The most CG iterations one solve of a step runs: `2 cg_iterations +
    /// 16`. The extra iterations only run while the energy certificate
    /// fails, which takes a truncated solve that injects energy; the cap
    /// keeps a solve's worst case known: `iteration_cap() + 3` products with
    /// the system matrix. A step with friction solves again in each round
    /// of [`Settings::contact_rounds`] that changes a node (one product more
    /// where a node sticks again): at worst `1 + contact_rounds` solves.
    #[must_use]
    pub const fn iteration_cap(&self) -> u32 {
        self.cg_iterations.saturating_mul(2).saturating_add(16)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self::new()
    }
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepStats {
    /// CG iterations run: the budget [`Settings::cg_iterations`], fewer
    /// where the tolerance stopped the solve, more (up to
    /// [`Settings::iteration_cap`]) where the energy certificate needed them,
    /// and those of the solves the friction's rounds ran
    /// ([`Settings::contact_rounds`]).
    pub cg_iterations: u32,
    /// Whether the step ended with the Galerkin step of a solve that had no
    /// energy certificate at the iteration cap.
    pub galerkin: bool,
    /// Final CG residual relative to the initial one, in the lumped-mass
    /// norm of [`Settings::cg_tolerance`]: of the step's last solve (after a
    /// round of [`Settings::contact_rounds`], relative to where that solve
    /// started).
    pub cg_residual: f32,
    /// Elements with negative current volume, at the start of the step.
    pub inverted: u32,
    /// Nodes held by the ground or a probe during the step; for a body
    /// whose ground contact is solved whole (a stiff body only the ground
    /// holds), the nodes that end the step on the plane.
    pub contacts: u32,
    /// Force the body exerts on the tool at the end of the step (N): what a
    /// haptic device renders. Zero without a tool.
    pub tool_force: Vec3,
    /// Force that the supports exert on the body during the step (N): the
    /// fixed nodes' constraint forces and the ground's (its held nodes'
    /// contact forces, and the impulses that stop landing nodes), the
    /// impulse over the step's length. It is what a force plate under the
    /// body reads, with the sign of the force on the body: a body resting
    /// in equilibrium has `support_force = −(m g + loads + probe forces on
    /// it)`. Probes' forces are not in it ([`crate::Probe::force`]).
    pub support_force: Vec3,
    /// Elastic energy of the body at the start of the step (J), summed in
    /// element order by the force pass that computes the forces anyway (no
    /// extra pass over the elements), with the feature `diagnostics`.
    /// Without it the field is NaN (so such statistics never compare
    /// equal) and the sum is left out: it costs ~48
    /// instructions per element and step on a Cortex-M4F (3.5% of a step).
    /// (NaN rather than an `Option`, whose larger statistics cost another
    /// 0.4 instructions per tetrahedron-step there.) `Qr`'s forces are not
    /// the gradient of an energy: with many inverted elements and light
    /// damping they can feed energy in while every value stays finite
    /// (docs/reliability.md); [`Settings::energy_guard`] takes it out
    /// again ([`StepStats::energy_removed`]). Energy that grows while
    /// nothing does work on the body, or a guard that keeps acting, is the
    /// signal to switch to `Polar` or add stiffness damping.
    pub elastic_energy: f32,
    /// Energy the guard took out of the body's deformation before this
    /// step (J, [`Settings::energy_guard`]): what the previous step made.
    /// Zero for a step that made none, and without the guard.
    pub energy_removed: f32,
}
