//! The plain C structs and the method codes.

use corofem_core::{Method, Preconditioner};

use crate::ptr::Plain;
use crate::status::Status;

/// Element method codes for `corofem_set_method` and `corofem_settings.method`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodCode {
    /// The paper's QR method, `B` from the current shape (the default).
    Qr = 0,
    /// Polar decomposition (about 30% more work).
    Polar = 1,
    /// Small-displacement linear elasticity (no rotation).
    Linear = 2,
    /// QR with `B` frozen at rest, as SOFA's default (ghost torques).
    QrRestB = 3,
    /// QR, with inverted elements taking the closest proper rotation
    /// (feature `qr-invertible`).
    QrInvertible = 4,
}

/// The core method for a C code (the codes are the order of
/// `Method::VARIANTS`). A method that is not compiled in is the scene's to
/// refuse (`Status::Unsupported`).
pub fn method_from_code(code: u32) -> Result<Method, Status> {
    from_code(&Method::VARIANTS, code)
}

/// The C code of a core method.
#[must_use]
pub fn method_code(m: Method) -> u32 {
    code_of(&Method::VARIANTS, m)
}

/// The value of C code `code`: its place in `variants`.
fn from_code<T: Copy>(variants: &[T], code: u32) -> Result<T, Status> {
    let i = usize::try_from(code).map_err(|_| Status::InvalidArgument)?;
    variants.get(i).copied().ok_or(Status::InvalidArgument)
}

/// The C code of `value`: its place in `variants` (`u32::MAX` if absent).
fn code_of<T: PartialEq>(variants: &[T], value: T) -> u32 {
    variants
        .iter()
        .position(|v| *v == value)
        .map_or(u32::MAX, |i| i as u32)
}

/// Preconditioner codes for `corofem_settings.preconditioner`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PreconditionerCode {
    /// The lumped mass, the paper's CG (the default).
    Mass = 0,
    /// The 3×3 node blocks of the system matrix.
    BlockJacobi = 1,
    /// Node blocks plus rigid-body modes per aggregate of nodes.
    TwoLevel = 2,
}

/// The core preconditioner for a C code (the order of
/// `Preconditioner::VARIANTS`). One the library was built without is the
/// scene's to refuse (`Status::Unsupported`).
pub fn preconditioner_from_code(code: u32) -> Result<Preconditioner, Status> {
    from_code(&Preconditioner::VARIANTS, code)
}

/// The C code of a core preconditioner.
#[must_use]
pub fn preconditioner_code(p: Preconditioner) -> u32 {
    code_of(&Preconditioner::VARIANTS, p)
}

/// Build flag: swap two nodes of negatively oriented tetrahedra instead of
/// refusing them.
pub const COROFEM_BUILD_REORIENT: u32 = 1;

/// An isotropic material.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Young's modulus (Pa, ≥ 0).
    pub young: f32,
    /// Poisson ratio (0 ≤ ν < 0.5).
    pub poisson: f32,
    /// Density (kg/m³, > 0).
    pub density: f32,
}

/// How the scene is stepped (see `corofem_settings_default` for the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Element method code (`COROFEM_METHOD_*`). Default QR with inverted
    /// elements turned back (`COROFEM_METHOD_QR_INVERTIBLE`) where compiled
    /// in, else QR.
    pub method: u32,
    /// Time step (s, > 0). Default 0.001.
    pub dt: f32,
    /// CG iterations per step: the budget (≥ 1). Default 4 with the two-level
    /// preconditioner, 5 with mass. A step runs more,
    /// up to 2 cg_iterations + 16 and a Galerkin step, only where stopping
    /// there would add energy to the body.
    pub cg_iterations: u32,
    /// Relative residual at which CG may stop early (≥ 0; 0 = no early
    /// stop). Default 0.
    pub cg_tolerance: f32,
    /// Mass-proportional Rayleigh damping (1/s, ≥ 0). Default 0.
    pub rayleigh_mass: f32,
    /// Stiffness-proportional Rayleigh damping (s, ≥ 0). Default 0.
    pub rayleigh_stiffness: f32,
    /// Nonzero: start CG from the last step's velocity change. Default 1
    /// with the two-level preconditioner, 0 with mass.
    pub warm_start: u32,
    /// Gravity (m/s²). Default (0, 0, −9.81).
    pub gravity: [f32; 3],
    /// Preconditioner code (`COROFEM_PRECONDITIONER_*`). Default two-level
    /// where compiled in, else mass.
    /// `TWO_LEVEL` and `BLOCK_JACOBI` need a library built with the feature
    /// `two-level` (the host default); otherwise `corofem_set_settings`
    /// returns `COROFEM_UNSUPPORTED`.
    pub preconditioner: u32,
    /// Nonzero: the energy guard (a step takes out of the body's
    /// deformation the energy the previous step made while nothing did work
    /// on it and elements were inverted). Default 1 in a library built with the feature `energy-guard`
    /// (the host default), else 0; nonzero without it is refused
    /// (`COROFEM_INVALID_ARGUMENT`).
    pub energy_guard: u32,
    /// Nonzero: free rotation (a body that nothing holds and that moves as
    /// one over a step turns by a rigid rotation instead of moving along its
    /// tangents, which would stretch a spinning body). Default 1 in a
    /// library built with the feature `free-rotation` (the host default),
    /// else 0; nonzero without it is refused (`COROFEM_INVALID_ARGUMENT`).
    pub free_rotation: u32,
    /// Most rounds of the contact state in a step (with friction): after
    /// the solve a held node's friction is made Coulomb's for the impulse
    /// it computed, and while that changes a node the solve goes on (the
    /// step's CG budget per round). 0: one solve, the state decided after
    /// the last step. Default 4.
    pub contact_rounds: u32,
    /// The stiffness-proportional damping (s, ≥ 0) a body has while the
    /// ground has friction: the step damps with the larger of it and
    /// `rayleigh_stiffness`. An undamped elastic body under Coulomb
    /// friction flutters at large μ. 0: undamped. Default 0.003.
    pub friction_damping: f32,
}

impl Settings {
    /// From the core's settings.
    #[must_use]
    pub fn from_core(s: &corofem_core::Settings) -> Self {
        Self {
            method: method_code(s.method),
            dt: s.dt,
            cg_iterations: s.cg_iterations,
            cg_tolerance: s.cg_tolerance,
            rayleigh_mass: s.rayleigh_mass,
            rayleigh_stiffness: s.rayleigh_stiffness,
            warm_start: u32::from(s.warm_start),
            gravity: s.gravity,
            preconditioner: preconditioner_code(s.preconditioner),
            energy_guard: u32::from(s.energy_guard),
            free_rotation: u32::from(s.free_rotation),
            contact_rounds: s.contact_rounds,
            friction_damping: s.friction_damping,
        }
    }

    /// To the core's settings (validated by the core when set).
    pub fn to_core(&self) -> Result<corofem_core::Settings, Status> {
        Ok(corofem_core::Settings {
            method: method_from_code(self.method)?,
            dt: self.dt,
            cg_iterations: self.cg_iterations,
            cg_tolerance: self.cg_tolerance,
            rayleigh_mass: self.rayleigh_mass,
            rayleigh_stiffness: self.rayleigh_stiffness,
            warm_start: self.warm_start != 0,
            preconditioner: preconditioner_from_code(self.preconditioner)?,
            gravity: self.gravity,
            energy_guard: self.energy_guard != 0,
            free_rotation: self.free_rotation != 0,
            contact_rounds: self.contact_rounds,
            friction_damping: self.friction_damping,
        })
    }
}

/// What the last step did.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    /// Steps since the build.
    pub steps: u64,
    /// Simulated time since the build (s).
    pub time: f64,
    /// CG iterations run in the last step.
    pub cg_iterations: u32,
    /// Final relative CG residual of the last step.
    pub cg_residual: f32,
    /// Inverted elements at the start of the last step.
    pub inverted: u32,
    /// Nodes held by the ground or a probe during the last step; for a
    /// body whose ground contact is solved whole, the nodes that end it on
    /// the plane.
    pub contacts: u32,
    /// Force the body exerts on the tool (N): what a haptic device renders.
    pub tool_force: [f32; 3],
    /// Energy the guard took out before the last step (J): what the step
    /// before it made while nothing did work on the body.
    pub energy_removed: f32,
    /// Force the supports exerted on the body during the last step (N): the
    /// fixed nodes' and the ground's, friction included, as a force plate
    /// under the body reads it, with the sign of the force on the body (a
    /// body at rest: −(weight + loads + probe forces on it)). The probes'
    /// forces are not in it (`corofem_probe_force`).
    pub support_force: [f32; 3],
}

/// What `corofem_bind_surface` found.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BindStats {
    /// Vertices inside a tetrahedron (on its faces included).
    pub inside: u32,
    /// Vertices outside the mesh, within the reach: they follow the affine
    /// map of their nearest tetrahedron.
    pub outside: u32,
    /// The largest distance of a vertex from its tetrahedron (m); 0 when
    /// every vertex is inside.
    pub max_distance: f32,
    /// The vertex at that distance (0 when every vertex is inside).
    pub farthest_vertex: u32,
}

// SAFETY: `repr(C)` structs of integers and floats only: every bit pattern
// (padding aside, which is never read as a value) is valid.
unsafe impl Plain for Material {}
// SAFETY: as above.
unsafe impl Plain for Settings {}
// SAFETY: as above.
unsafe impl Plain for Stats {}
// SAFETY: as above.
unsafe impl Plain for BindStats {}
