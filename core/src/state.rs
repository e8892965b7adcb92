//! The scene's state that is not per node or per element ([`Header`]), and
//! the view of every slot array that the step and the solvers work on
//! ([`View`]). Below both the scene (which owns them) and the step (which
//! reads and writes them).

use crate::element::ElementBlock;
use crate::material::lame_per_young;
#[cfg(feature = "tool")]
use crate::math::Vec3;
use crate::settings::Settings;
use crate::storage::{Node, NodeWork};
use crate::InstructionSet;

#[cfg(feature = "ground")]
use crate::contact::ground::Plane;
#[cfg(feature = "tool")]
use crate::tool::ToolState;

/// Everything about a scene that is not per node or per element.
///
/// [`Header::EMPTY`], and with it an empty [`StaticScene`](crate::StaticScene), is all zero
/// bits, so that a `static` scene lands in `.bss` and costs no flash (an
/// initial value with one non-zero byte puts the whole scene in `.data`,
/// whose image is stored in flash as well: 27 kB more for the firmware
/// example's 240 tetrahedra). `.ci/firmware.sh` checks it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Header {
    pub(crate) n_nodes: usize,
    pub(crate) n_elems: usize,
    pub(crate) poisson: f32,
    pub(crate) density: f32,
    /// The step settings when `settings_valid`; the step and the solvers
    /// read them through a [`View`], which makes them valid.
    pub(crate) settings: Settings,
    /// Whether `settings` holds the scene's settings. When not (an empty
    /// header, where they are [`Settings::ZERO`]) the defaults apply: the
    /// non-zero defaults are written on first use instead of being part of
    /// the initial value.
    pub(crate) settings_valid: bool,
    pub(crate) time: f64,
    pub(crate) inverted: u32,
    /// Some node is fixed (kept by `fix_nodes`/`unfix_all` so the step need
    /// not scan the flags).
    pub(crate) any_fixed: bool,
    #[cfg(feature = "ground")]
    pub(crate) ground: Option<Plane>,
    /// The friction between the body and the ground.
    #[cfg(feature = "friction")]
    pub(crate) ground_friction: crate::Friction,
    /// The ground or the body was placed (the ground set, the scene built,
    /// positions or the state set, nodes freed) and the next step has not
    /// yet checked that no node starts below the ground.
    #[cfg(feature = "ground")]
    pub(crate) ground_unchecked: bool,
    #[cfg(feature = "tool")]
    pub(crate) tool: ToolState,
    /// Entries used in the storage's load list (nodes flagged `LOADED`).
    #[cfg(feature = "loads")]
    pub(crate) n_loads: usize,
    /// The instruction set asked for ([`Scene::set_instruction_set`](crate::Scene::set_instruction_set)).
    pub(crate) isa: IsaChoice,
    /// Aggregates of the two-level preconditioner in use.
    #[cfg(feature = "two-level")]
    pub(crate) n_aggs: usize,
    /// Whether the preconditioner's aggregates and coarse factor match the
    /// scene (cleared by whatever changes the rest system matrix; the next
    /// step prepares them).
    #[cfg(feature = "two-level")]
    pub(crate) coarse_ready: bool,
    /// The last step's solve needed more than its budget (its truncation
    /// had no energy certificate): its solution is no guess for the next
    /// step, which starts cold (the guess stage).
    pub(crate) guess_stale: bool,
    /// The energy guard's reference (J): the body's energy after the last
    /// step's check, valid while `energy_known` (`guard::Correction`).
    #[cfg(feature = "energy-guard")]
    pub(crate) energy_ref: f32,
    #[cfg(feature = "energy-guard")]
    pub(crate) energy_known: bool,
    /// The tool's target when the reference was taken (m): the guard
    /// credits the work of moving it since.
    #[cfg(all(feature = "energy-guard", feature = "tool"))]
    pub(crate) energy_target: crate::math::Vec3,
}

/// The instruction set a scene is asked to step with: `Best` is zero, so
/// that a scene made by `const fn new` stays all zeros (a `static` in
/// `.bss`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum IsaChoice {
    /// The best the CPU supports ([`InstructionSet::best`]).
    Best = 0,
    /// The baseline.
    Baseline = 1,
    /// AVX2 (checked supported when chosen).
    Avx2 = 2,
}

impl IsaChoice {
    /// What to ask the step for: `None` for the best.
    pub(crate) fn asked(self) -> Option<InstructionSet> {
        match self {
            IsaChoice::Best => None,
            IsaChoice::Baseline => Some(InstructionSet::Baseline),
            IsaChoice::Avx2 => Some(InstructionSet::Avx2),
        }
    }
}

impl Header {
    /// The tool's spring, as the step takes it.
    #[inline(always)]
    pub(crate) fn spring(&self) -> Spring {
        Spring {
            #[cfg(feature = "tool")]
            tool: self.tool,
        }
    }

    /// The ground and its friction, as the contact stages take them.
    #[inline(always)]
    pub(crate) fn ground(&self) -> crate::contact::Ground {
        crate::contact::Ground {
            #[cfg(feature = "ground")]
            plane: self.ground,
            #[cfg(feature = "friction")]
            friction: self.ground_friction,
            #[cfg(feature = "ground")]
            h: self.settings.dt,
            #[cfg(feature = "ground")]
            settle: crate::math::sqrt(crate::math::dot(
                self.settings.gravity,
                self.settings.gravity,
            )) * self.settings.dt,
        }
    }

    /// The body's `[λ/E, μ/E]`, which turn each element's `E/(36 V₀)` into
    /// the kernels' `[λ', μ']`.
    #[inline(always)]
    pub(crate) fn per_young(&self) -> [f32; 2] {
        lame_per_young(self.poisson)
    }

    /// Makes the default settings the scene's own. Out of line: it runs at
    /// most once per scene, and every caller of `Scene::view` (the step
    /// among them) keeps only the test.
    #[cold]
    #[inline(never)]
    pub(crate) fn write_default_settings(&mut self, settings: Settings) {
        self.settings = settings;
        self.settings_valid = true;
    }

    /// The coefficients of the step's system `A = mass_coef M + k_coef K`:
    /// `1 + h α_M` and `h (α_K + h)`, with the stiffness damping `α_K`
    /// [`Settings::friction_damping`](crate::Settings::friction_damping)
    /// at least while the ground has friction. The coarse factor is built
    /// with them: whatever changes them makes it again.
    #[inline(always)]
    pub(crate) fn coefficients(&self) -> (f32, f32) {
        let s = &self.settings;
        let h = s.dt;
        #[allow(unused_mut)] // raised only with friction
        let mut damping = s.rayleigh_stiffness;
        #[cfg(feature = "friction")]
        if self.ground.is_some() && self.ground_friction.sticks() {
            damping = damping.max(s.friction_damping);
        }
        (1.0 + h * s.rayleigh_mass, h * (damping + h))
    }

    /// Forgets the coarse factor where the system's
    /// [`coefficients`](Self::coefficients) are no longer `before`, the
    /// ones it may have been built with.
    #[inline(always)]
    pub(crate) fn coefficients_changed(&mut self, before: (f32, f32)) {
        let after = self.coefficients();
        if (after.0.to_bits(), after.1.to_bits()) != (before.0.to_bits(), before.1.to_bits()) {
            self.invalidate_coarse();
        }
    }

    /// Forgets the preconditioner's aggregates and coarse factor: the next
    /// step prepares them again.
    #[inline(always)]
    pub(crate) fn invalidate_coarse(&mut self) {
        #[cfg(feature = "two-level")]
        {
            self.coarse_ready = false;
        }
    }

    /// Marks the body or the ground as placed: the next step checks that
    /// no node starts below the ground.
    #[inline(always)]
    pub(crate) fn placed(&mut self) {
        #[cfg(feature = "ground")]
        {
            self.ground_unchecked = true;
        }
    }

    /// Forgets the energy guard's reference: after a change through the
    /// API (state, material, constraints, loads, settings) the next step's
    /// energy is the new reference, not a gain.
    #[inline(always)]
    pub(crate) fn forget_energy(&mut self) {
        #[cfg(feature = "energy-guard")]
        {
            self.energy_known = false;
        }
    }

    pub(crate) const EMPTY: Self = Self {
        n_nodes: 0,
        n_elems: 0,
        poisson: 0.0,
        density: 0.0,
        settings: Settings::ZERO,
        settings_valid: false,
        time: 0.0,
        inverted: 0,
        any_fixed: false,
        #[cfg(feature = "ground")]
        ground: None,
        #[cfg(feature = "friction")]
        ground_friction: crate::Friction::NONE,
        #[cfg(feature = "ground")]
        ground_unchecked: false,
        #[cfg(feature = "tool")]
        tool: ToolState::NONE,
        #[cfg(feature = "loads")]
        n_loads: 0,
        isa: IsaChoice::Best,
        #[cfg(feature = "two-level")]
        n_aggs: 0,
        #[cfg(feature = "two-level")]
        coarse_ready: false,
        guess_stale: false,
        #[cfg(feature = "energy-guard")]
        energy_ref: 0.0,
        #[cfg(feature = "energy-guard")]
        energy_known: false,
        #[cfg(all(feature = "energy-guard", feature = "tool"))]
        energy_target: [0.0; 3],
    };
}

/// Mutable access to the used part of every slot array.
pub(crate) struct View<'a> {
    pub(crate) hdr: &'a mut Header,
    pub(crate) nodes: &'a mut [Node],
    pub(crate) work: &'a mut [NodeWork],
    /// The blocks holding the scene's elements.
    pub(crate) elems: &'a mut [ElementBlock],
    /// Number of elements (the last block may be partly used).
    pub(crate) n_elems: usize,
    /// The lists of what only some nodes carry.
    pub(crate) lists: Lists<'a>,
    /// The preconditioner's slots.
    pub(crate) pre: PreSlots<'a>,
    /// The probes of `step_with_probes` (none for `step`).
    pub(crate) probes: crate::contact::Probes<'a>,
}

/// The grab offsets and constant loads, in node order (nothing without the
/// features `tool` and `loads`).
pub(crate) struct Lists<'a> {
    /// The grab offsets of the nodes the tool holds.
    #[cfg(feature = "tool")]
    pub(crate) grabs: &'a [crate::storage::NodeEntry],
    /// The constant external forces.
    #[cfg(feature = "loads")]
    pub(crate) loads: &'a [crate::storage::NodeEntry],
    pub(crate) _life: core::marker::PhantomData<&'a ()>,
}

/// The preconditioner's slots: a node block per node (or none), and every
/// aggregate and coarse slot of the storage (nothing without `two-level`).
pub(crate) struct PreSlots<'a> {
    #[cfg(feature = "two-level")]
    pub(crate) parts: crate::slots::Parts<'a>,
    pub(crate) _life: core::marker::PhantomData<&'a mut ()>,
}

/// The haptic tool's spring as the step sees it (nothing without the
/// feature `tool`): `k/n` between each grabbed node and the tool's target
/// plus its offset.
#[derive(Clone, Copy)]
pub(crate) struct Spring {
    #[cfg(feature = "tool")]
    pub(crate) tool: ToolState,
}

impl Spring {
    /// Whether the tool holds the body.
    #[inline(always)]
    pub(crate) fn active(&self) -> bool {
        #[cfg(feature = "tool")]
        return self.tool.active();
        #[cfg(not(feature = "tool"))]
        false
    }

    /// Whether the tool's spring pulls node `n`.
    #[inline(always)]
    pub(crate) fn holds(&self, n: &Node) -> bool {
        #[cfg(feature = "tool")]
        return n.flags & crate::storage::GRABBED != 0 && self.tool.active();
        #[cfg(not(feature = "tool"))]
        {
            let _ = n;
            false
        }
    }

    /// The stiffness per grabbed node, `k/n` (N/m).
    #[inline(always)]
    pub(crate) fn k(&self) -> f32 {
        #[cfg(feature = "tool")]
        return self.tool.k_node;
        #[cfg(not(feature = "tool"))]
        0.0
    }

    /// Where the spring of a node with grab offset `offset` pulls it to.
    #[cfg(feature = "tool")]
    #[inline(always)]
    pub(crate) fn anchor(&self, offset: Vec3) -> Vec3 {
        self.tool.anchor(offset)
    }

    /// The target (m): where the grabbed nodes' centroid is pulled to.
    #[cfg(all(feature = "tool", feature = "energy-guard"))]
    #[inline(always)]
    pub(crate) fn target(&self) -> Vec3 {
        self.tool.target
    }
}
