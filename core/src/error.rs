//! Errors: small `Copy` values that say which element, node or parameter is
//! wrong. Nodes are named by their `u32` index, as everywhere in the API
//! ([`Scene`](crate::Scene)); elements by their position in the mesh's
//! slice of tetrahedra (`usize`).

use core::fmt;

use crate::element::Method;

/// Why building or configuring a scene failed. The scene is unchanged after
/// every error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// More nodes than the storage holds.
    TooManyNodes {
        /// Nodes asked for.
        count: usize,
        /// Nodes the storage holds.
        capacity: usize,
    },
    /// More tetrahedra than the storage holds.
    TooManyElements {
        /// Elements asked for.
        count: usize,
        /// Elements the storage holds.
        capacity: usize,
    },
    /// The mesh has no tetrahedron.
    NoElements,
    /// More nodes to grab than the storage's grab slots
    /// ([`Slots::grabs`](crate::Slots::grabs)).
    TooManyGrabbed {
        /// Distinct nodes asked for.
        count: usize,
        /// Grab slots of the storage.
        capacity: usize,
    },
    /// A force on one more node than the storage's load slots
    /// ([`Slots::loads`](crate::Slots::loads)).
    TooManyLoads {
        /// Load slots of the storage, all in use.
        capacity: usize,
    },
    /// A node coordinate is NaN or infinite.
    NonFiniteCoordinate {
        /// The offending node.
        node: u32,
    },
    /// An element refers to a node that does not exist.
    NodeIndexOutOfRange {
        /// The offending element.
        element: usize,
        /// The index it holds.
        node: u32,
    },
    /// An element lists the same node twice.
    RepeatedNode {
        /// The offending element.
        element: usize,
        /// The repeated node.
        node: u32,
    },
    /// An element has zero rest volume (flat, or two nodes at the same place),
    /// or a shape f32 cannot represent: a volume, mass or stiffness
    /// coefficient that underflows or overflows, or edges longer than ~1e19.
    DegenerateElement {
        /// The offending element.
        element: usize,
    },
    /// An element is negatively oriented (`det[b−a, c−a, d−a] < 0`) and
    /// re-orientation was not asked for.
    InvertedElement {
        /// The offending element.
        element: usize,
    },
    /// A node belongs to no element, so it would have no mass.
    UnusedNode {
        /// The offending node.
        node: u32,
    },
    /// A node index given to a setter does not exist in the built scene.
    NodeOutOfRange {
        /// The index given.
        node: u32,
    },
    /// An element index given to a setter does not exist in the built scene.
    ElementOutOfRange {
        /// The index given.
        element: usize,
    },
    /// A parameter is outside its valid range, not finite, or of the wrong
    /// length.
    InvalidParameter {
        /// Which one.
        parameter: Parameter,
    },
    /// The element method is not compiled into this build: enable the
    /// `corofem` feature [`Method::feature`].
    MethodNotCompiled {
        /// The method asked for.
        method: Method,
    },
    /// The instruction set asked for is not supported by this CPU (or, in a
    /// build without the `std` feature, was not enabled at build time).
    UnsupportedInstructionSet {
        /// The instruction set asked for.
        instruction_set: crate::InstructionSet,
    },
    /// The preconditioner is not compiled into this build (feature
    /// `two-level`), or the storage has no room for its data: one
    /// [`NodeBlock`](crate::NodeBlock) per node for `BlockJacobi` and
    /// `TwoLevel`, and at least one aggregate for `TwoLevel`.
    PreconditionerUnavailable {
        /// The preconditioner asked for.
        preconditioner: crate::Preconditioner,
    },
    /// The operation needs a built scene.
    NotBuilt,
    /// A static solve needs something that holds the body: fixed nodes or the tool.
    Unconstrained,
    /// A static solve produced non-finite displacements; the last finite
    /// iterate was kept.
    StaticDiverged,
    /// More surface vertices than the bindings given (or than `u32` indexes).
    TooManyVertices {
        /// Vertices given.
        count: usize,
        /// Binding slots given.
        capacity: usize,
    },
    /// A surface vertex is NaN or infinite.
    NonFiniteVertex {
        /// The offending vertex.
        vertex: u32,
    },
    /// A surface vertex lies farther than `reach` from every tetrahedron.
    VertexTooFar {
        /// The first such vertex.
        vertex: u32,
    },
    /// A surface triangle refers to a vertex that does not exist.
    TriangleIndexOutOfRange {
        /// The offending triangle.
        triangle: usize,
        /// The index it holds.
        vertex: u32,
    },
    /// A surface triangle lists a vertex twice, or its corners are collinear
    /// to f32 precision (`|e₁ × e₂| ≤ 4 ε |e₁| |e₂|`): it has no normal.
    DegenerateTriangle {
        /// The offending triangle.
        triangle: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::TooManyNodes { count, capacity } => {
                write!(f, "{count} nodes exceed the capacity of {capacity}")
            }
            Error::TooManyElements { count, capacity } => {
                write!(f, "{count} tetrahedra exceed the capacity of {capacity}")
            }
            Error::NoElements => write!(f, "the mesh has no tetrahedron"),
            Error::TooManyGrabbed { count, capacity } => write!(
                f,
                "{count} nodes to grab exceed the storage's {capacity} grab slots"
            ),
            Error::TooManyLoads { capacity } => {
                write!(f, "all {capacity} load slots of the storage are in use")
            }
            Error::NonFiniteCoordinate { node } => {
                write!(f, "node {node} has a NaN or infinite coordinate")
            }
            Error::NodeIndexOutOfRange { element, node } => {
                write!(
                    f,
                    "tetrahedron {element} refers to node {node}, which does not exist"
                )
            }
            Error::RepeatedNode { element, node } => {
                write!(f, "tetrahedron {element} lists node {node} twice")
            }
            Error::DegenerateElement { element } => {
                write!(
                    f,
                    "tetrahedron {element} is degenerate: zero rest volume (flat, or two nodes \
                     at one place), or a volume, mass or stiffness beyond f32's range"
                )
            }
            Error::InvertedElement { element } => write!(
                f,
                "tetrahedron {element} is negatively oriented (enable re-orientation to fix it)"
            ),
            Error::UnusedNode { node } => write!(f, "node {node} belongs to no tetrahedron"),
            Error::NodeOutOfRange { node } => write!(f, "node {node} does not exist"),
            Error::ElementOutOfRange { element } => write!(f, "element {element} does not exist"),
            Error::InvalidParameter { parameter } => write!(f, "invalid {parameter}"),
            Error::MethodNotCompiled { method } => write!(
                f,
                "element method `{}` is not compiled into this build (corofem feature `{}`)",
                method.name(),
                method.feature()
            ),
            Error::UnsupportedInstructionSet { instruction_set } => write!(
                f,
                "instruction set `{}` is not supported here",
                instruction_set.name()
            ),
            Error::PreconditionerUnavailable { preconditioner } => write!(
                f,
                "preconditioner `{}` needs the corofem feature `two-level` and storage for it \
                 (node blocks for every node; aggregates for `two-level`)",
                preconditioner.name()
            ),
            Error::NotBuilt => write!(f, "the scene has not been built"),
            Error::Unconstrained => {
                write!(f, "a static solve needs fixed nodes or a grabbing tool")
            }
            Error::StaticDiverged => write!(f, "the static solve diverged"),
            Error::TooManyVertices { count, capacity } => write!(
                f,
                "{count} surface vertices exceed the {capacity} binding slots"
            ),
            Error::NonFiniteVertex { vertex } => {
                write!(f, "surface vertex {vertex} has a NaN or infinite coordinate")
            }
            Error::VertexTooFar { vertex } => write!(
                f,
                "surface vertex {vertex} lies farther than the reach from every tetrahedron \
                 (is the surface in the mesh's units and place?)"
            ),
            Error::TriangleIndexOutOfRange { triangle, vertex } => write!(
                f,
                "surface triangle {triangle} refers to vertex {vertex}, which does not exist"
            ),
            Error::DegenerateTriangle { triangle } => write!(
                f,
                "surface triangle {triangle} is degenerate (a repeated vertex, or collinear corners)"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// A parameter that [`Error::InvalidParameter`] refuses. Its `Display` says
/// what a valid value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Parameter {
    /// Young's modulus (`Material::young`, `Scene::set_young`, ...).
    Young,
    /// Poisson's ratio (`Material::poisson`, `Scene::set_poisson`, ...).
    Poisson,
    /// `Material::density`.
    Density,
    /// `Settings::dt`.
    Dt,
    /// `Settings::cg_iterations`.
    CgIterations,
    /// `Settings::cg_tolerance`.
    CgTolerance,
    /// `Settings::rayleigh_mass`.
    RayleighMass,
    /// `Settings::rayleigh_stiffness`.
    RayleighStiffness,
    /// `Settings::gravity`.
    Gravity,
    /// The force of `Scene::set_force`.
    Force,
    /// The positions of `Scene::set_positions`.
    Positions,
    /// The displacements of `Scene::set_displacements`.
    Displacements,
    /// The velocities of `Scene::set_velocities`.
    Velocities,
    /// The node list of `Scene::grab`.
    ToolNodes,
    /// The spring stiffness of `Scene::grab`.
    ToolStiffness,
    /// The target of `Scene::set_tool_target`.
    ToolTarget,
    /// The plane of `Scene::set_ground`.
    Ground,
    /// `StaticSettings::cg_iterations`.
    StaticCgIterations,
    /// `StaticSettings::cg_tolerance`.
    StaticCgTolerance,
    /// `StaticSettings::tolerance`.
    StaticTolerance,
    /// `StaticSettings::update_tolerance`.
    StaticUpdateTolerance,
    /// The output slice of `Scene::elastic_forces`.
    ForcesOut,
    /// The displacements `d` of `Scene::stiffness_product`.
    ProductInput,
    /// The output slice of `Scene::stiffness_product`.
    ProductOut,
    /// `BoxMesh::cells`.
    Cells,
    /// `BoxMesh::size`.
    Size,
    /// `BoxMesh::tets_per_cell`.
    TetsPerCell,
    /// `Settings::energy_guard`.
    EnergyGuard,
    /// The `reach` of `Scene::bind_surface`.
    SurfaceReach,
    /// The scratch of `Scene::bind_surface`.
    SurfaceScratch,
    /// The radius of a `Probe`.
    ProbeRadius,
    /// The half length of a capsule `Probe`.
    ProbeHalfLength,
    /// The position or axis of a `Probe`.
    ProbePose,
    /// A `Friction`'s coefficients.
    Friction,
    /// The stiffness, damping or proxy mass of a `Coupling`.
    Coupling,
    /// The device position or velocity given to `Coupling::drive`.
    DeviceState,
    /// The output slice of `Scene::update_surface` or `vertex_normals`.
    SurfaceOut,
    /// `Settings::free_rotation`.
    FreeRotation,
    /// `Settings::friction_damping`.
    FrictionDamping,
}

impl fmt::Display for Parameter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Parameter::Young => {
                "Young's modulus: it must be finite and ≥ 0 Pa, and small enough that \
                 every element's λ/(36 V₀) and μ/(36 V₀) fit in f32"
            }
            Parameter::Poisson => {
                "Poisson's ratio: it must be in [0, 0.5), and every element's \
                 λ/(36 V₀) must fit in f32"
            }
            Parameter::Density => "density: it must be finite and > 0 kg/m³",
            Parameter::Dt => "time step `dt`: it must be finite and > 0 s",
            Parameter::CgIterations => "`cg_iterations`: it must be ≥ 1",
            Parameter::CgTolerance => "`cg_tolerance`: it must be finite and ≥ 0",
            Parameter::RayleighMass => "`rayleigh_mass`: it must be finite and ≥ 0 1/s",
            Parameter::RayleighStiffness => "`rayleigh_stiffness`: it must be finite and ≥ 0 s",
            Parameter::FrictionDamping => "`friction_damping`: it must be finite and ≥ 0 s",
            Parameter::Gravity => "`gravity`: it must be finite (m/s²)",
            Parameter::Force => "force: it must be finite (N)",
            Parameter::Positions => {
                "positions: one per node, each finite (m) and with a finite displacement"
            }
            Parameter::Displacements => {
                "displacements: one per node, each finite (m) and with a finite position"
            }
            Parameter::Velocities => "velocities: one per node, each finite (m/s)",
            Parameter::ToolNodes => "nodes to grab: at least one",
            Parameter::ToolStiffness => "tool stiffness: it must be finite and ≥ 0 N/m",
            Parameter::ToolTarget => "tool target: it must be finite (m)",
            Parameter::Ground => "ground plane: it must be finite with a non-zero normal",
            Parameter::StaticCgIterations => "static `cg_iterations`: it must be ≥ 1",
            Parameter::StaticCgTolerance => "static `cg_tolerance`: it must be ≥ 0",
            Parameter::StaticTolerance => "static `tolerance`: it must be ≥ 0",
            Parameter::StaticUpdateTolerance => "static `update_tolerance`: it must be ≥ 0",
            Parameter::ForcesOut => "output of `elastic_forces`: it needs one entry per node",
            Parameter::ProductInput => "`d` of `stiffness_product`: one per node, each finite (m)",
            Parameter::ProductOut => "output of `stiffness_product`: it needs one entry per node",
            Parameter::Cells => "`cells`: each must be ≥ 1",
            Parameter::Size => "`size`: each edge must be finite and > 0 m",
            Parameter::TetsPerCell => "`tets_per_cell`: it must be 5 or 6",
            Parameter::SurfaceReach => "surface `reach`: it must be finite and ≥ 0 m",
            Parameter::SurfaceScratch => {
                "scratch of `bind_surface`: it needs `surface_scratch_len(vertices)` entries"
            }
            Parameter::SurfaceOut => "surface output: it needs one entry per vertex",
            Parameter::ProbeRadius => "probe radius: it must be finite and > 0 m",
            Parameter::ProbeHalfLength => {
                "capsule half length: it must be ≥ 0 m, finite with the radius added"
            }
            Parameter::Friction => {
                "friction: the coefficients must be finite, ≥ 0, and the static one at least the kinetic one"
            }
            Parameter::Coupling => {
                "coupling: the stiffness must be finite and > 0 N/m, the damping finite and \
                 ≥ 0 N·s/m, the proxy mass finite and > 0 kg"
            }
            Parameter::DeviceState => {
                "device state: the position and velocity must be finite, and the proxy they \
                 drive must stay finite"
            }
            Parameter::ProbePose => {
                "probe pose: the position must be finite and the axis finite and non-zero"
            }
            Parameter::EnergyGuard => {
                "`energy_guard`: this build has no energy guard (cargo feature `energy-guard`)"
            }
            Parameter::FreeRotation => {
                "`free_rotation`: this build has no free rotation (cargo feature `free-rotation`)"
            }
        })
    }
}

/// Why a step was refused. The state is unchanged after every step error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepError {
    /// An input of this step (tool target) is NaN or infinite.
    NonFiniteInput,
    /// The solve produced a NaN or infinite velocity, position or tool force
    /// (for instance a load or a tool spring beyond what f32 holds for this
    /// body); the step was not applied.
    Diverged,
    /// More probes than [`MAX_PROBES`](crate::MAX_PROBES) were given to
    /// `Scene::step_with_probes`.
    TooManyProbes,
    /// A probe's first step (after [`Probe::sphere`](crate::Probe::sphere),
    /// [`Probe::capsule`](crate::Probe::capsule) or
    /// [`Probe::place`](crate::Probe::place)) starts with a boundary node of
    /// the body inside it, or inside the body (its axis, or its centre for
    /// a sphere, in an element): move the probe out (for a device, start
    /// its proxy outside the body).
    ProbeInsideBody {
        /// The probe's index in the slice.
        probe: u32,
        /// A boundary node inside the probe, or `None` for a probe inside
        /// the body that holds no boundary node.
        node: Option<u32>,
    },
    /// The step would start with a free node below the ground: the first
    /// step after the ground is set, the body built, moved or reset, or its
    /// nodes freed, checks it. Move the body or the plane so that the body
    /// starts on or above it.
    BelowGround {
        /// The first node below the ground.
        node: u32,
    },
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::NonFiniteInput => write!(f, "a step input is NaN or infinite"),
            StepError::Diverged => {
                write!(f, "the step produced non-finite values and was not applied")
            }
            StepError::TooManyProbes => write!(f, "more probes than a step takes"),
            StepError::ProbeInsideBody {
                probe,
                node: Some(node),
            } => write!(
                f,
                "the probe at index {probe} of the slice starts inside the body \
                 (boundary node {node} is inside it)"
            ),
            StepError::ProbeInsideBody { probe, node: None } => write!(
                f,
                "the probe at index {probe} of the slice starts wholly inside the body"
            ),
            StepError::BelowGround { node } => {
                write!(
                    f,
                    "the body starts below the ground (node {node} is below it)"
                )
            }
        }
    }
}

impl core::error::Error for StepError {}
