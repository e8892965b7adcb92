//! Status codes: what every C function returns, and their messages.

use core::ffi::c_char;

use corofem_core::{Error, StepError};

/// What a call did: `COROFEM_STATUS_OK` (0) or a negative error code. After
/// any error the scene is unchanged. A 32-bit integer in C on every target
/// (`arm-none-eabi-gcc` would otherwise shrink a plain enum to one byte).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Success.
    Ok = 0,
    /// A pointer that must not be null was null.
    NullPointer = -1,
    /// The handle is not a live scene or surface: never initialised,
    /// de-initialised, misaligned, or its buffer was copied or moved after
    /// initialisation; or a surface bound to another mesh than the scene's;
    /// or a `corofem_coupling` that `corofem_coupling_init` never
    /// initialised.
    InvalidHandle = -2,
    /// A caller buffer is smaller than the call needs (scene or surface
    /// buffer, scratch or output array).
    BufferTooSmall = -3,
    /// An array pointer is not aligned for its element type (4 bytes for
    /// `float` and `uint32_t`).
    Misaligned = -4,
    /// An input or output array overlaps the scene's or the surface's own
    /// buffer, or another array of the call that is written.
    Overlap = -5,
    /// More nodes or tetrahedra than the scene was sized for, more than
    /// 65 536 nodes, more surface vertices than `uint32_t` indexes, or a
    /// size that does not fit in `size_t`.
    Capacity = -6,
    /// A node or element index does not exist in the built scene (or, in a
    /// tetrahedron, in the node array; in a surface triangle, in the vertex
    /// array).
    IndexOutOfRange = -7,
    /// A parameter is out of its documented range, not finite, or an unknown
    /// flag or method code.
    InvalidArgument = -8,
    /// The method or model was not compiled into this library.
    Unsupported = -9,
    /// The call needs a built scene (`corofem_build` first).
    NotBuilt = -10,
    /// The mesh has no tetrahedron.
    NoElements = -11,
    /// A node or surface vertex coordinate is NaN or infinite.
    NonFiniteCoordinate = -12,
    /// A tetrahedron lists the same node twice.
    RepeatedNode = -13,
    /// A tetrahedron has zero (or unrepresentably small) rest volume.
    DegenerateElement = -14,
    /// A tetrahedron is negatively oriented and `COROFEM_BUILD_REORIENT` was not given.
    InvertedElement = -15,
    /// A node belongs to no tetrahedron.
    UnusedNode = -16,
    /// The step produced NaN or infinite values and was not applied.
    Diverged = -17,
    /// A surface vertex lies farther than the reach from every tetrahedron.
    VertexTooFar = -18,
    /// A surface triangle repeats a vertex or has collinear corners.
    DegenerateTriangle = -19,
    /// A probe's first step (after it was added or placed) would start with
    /// a node of the body's surface inside it, or inside the body:
    /// `corofem_step_probes` names the probe and the node.
    ProbeInsideBody = -20,
    /// A step would start with a free node below the ground (checked by the
    /// first step after the ground is set or the body built, moved, reset
    /// or unfixed): move the body or the plane.
    BelowGround = -21,
}

impl Status {
    /// The message of a status code (never null, static, NUL-terminated).
    #[must_use]
    pub fn message(code: i32) -> &'static core::ffi::CStr {
        match code {
            0 => c"ok",
            -1 => c"null pointer",
            -2 => c"invalid scene handle",
            -3 => c"buffer too small",
            -4 => c"misaligned array pointer",
            -5 => c"array overlaps the scene buffer",
            -6 => c"capacity exceeded",
            -7 => c"index out of range",
            -8 => c"invalid argument",
            -9 => c"not compiled into this library",
            -10 => c"scene not built",
            -11 => c"the mesh has no tetrahedron",
            -12 => c"non-finite node coordinate",
            -13 => c"tetrahedron repeats a node",
            -14 => c"degenerate tetrahedron",
            -15 => c"negatively oriented tetrahedron",
            -16 => c"node belongs to no tetrahedron",
            -17 => c"step diverged",
            -18 => c"surface vertex too far outside the mesh",
            -19 => c"degenerate surface triangle",
            -20 => c"a probe starts inside the body",
            -21 => c"the body starts below the ground",
            _ => c"unknown status code",
        }
    }

    /// Pointer form of [`Status::message`] for C.
    #[must_use]
    pub fn message_ptr(code: i32) -> *const c_char {
        Self::message(code).as_ptr()
    }
}

/// A status code and, for mesh and index errors, the element or node it names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Failure {
    /// The code.
    pub status: Status,
    /// The offending element (element errors), node (node errors and a
    /// probe that starts inside the body), surface vertex (vertex errors) or
    /// surface triangle (triangle errors).
    pub at: Option<usize>,
}

impl From<Status> for Failure {
    fn from(status: Status) -> Self {
        Self { status, at: None }
    }
}

impl From<Error> for Failure {
    fn from(e: Error) -> Self {
        let (status, at) = match e {
            Error::TooManyNodes { .. }
            | Error::TooManyElements { .. }
            | Error::TooManyGrabbed { .. }
            | Error::TooManyLoads { .. } => (Status::Capacity, None),
            Error::NoElements => (Status::NoElements, None),
            Error::NonFiniteCoordinate { node } => (Status::NonFiniteCoordinate, index(node)),
            Error::NodeIndexOutOfRange { element, .. } => (Status::IndexOutOfRange, Some(element)),
            Error::RepeatedNode { element, .. } => (Status::RepeatedNode, Some(element)),
            Error::DegenerateElement { element } => (Status::DegenerateElement, Some(element)),
            Error::InvertedElement { element } => (Status::InvertedElement, Some(element)),
            Error::UnusedNode { node } => (Status::UnusedNode, index(node)),
            Error::NodeOutOfRange { node } => (Status::IndexOutOfRange, index(node)),
            Error::ElementOutOfRange { element } => (Status::IndexOutOfRange, Some(element)),
            Error::InvalidParameter { .. } => (Status::InvalidArgument, None),
            Error::MethodNotCompiled { .. } => (Status::Unsupported, None),
            Error::UnsupportedInstructionSet { .. } => (Status::Unsupported, None),
            Error::PreconditionerUnavailable { .. } => (Status::Unsupported, None),
            Error::NotBuilt => (Status::NotBuilt, None),
            // The static solve is not part of the C API.
            Error::Unconstrained => (Status::InvalidArgument, None),
            Error::StaticDiverged => (Status::Diverged, None),
            Error::TooManyVertices { .. } => (Status::Capacity, None),
            Error::NonFiniteVertex { vertex } => (Status::NonFiniteCoordinate, index(vertex)),
            Error::VertexTooFar { vertex } => (Status::VertexTooFar, index(vertex)),
            Error::TriangleIndexOutOfRange { triangle, .. } => {
                (Status::IndexOutOfRange, Some(triangle))
            }
            Error::DegenerateTriangle { triangle } => (Status::DegenerateTriangle, Some(triangle)),
        };
        Self { status, at }
    }
}

/// A node index as the C API reports it (`size_t`).
fn index(node: u32) -> Option<usize> {
    usize::try_from(node).ok()
}

impl From<StepError> for Failure {
    fn from(e: StepError) -> Self {
        match e {
            StepError::NonFiniteInput => Status::InvalidArgument.into(),
            StepError::Diverged => Status::Diverged.into(),
            StepError::TooManyProbes => Status::Capacity.into(),
            StepError::ProbeInsideBody { node, .. } => Self {
                status: Status::ProbeInsideBody,
                at: node.and_then(index),
            },
            StepError::BelowGround { node } => Self {
                status: Status::BelowGround,
                at: index(node),
            },
        }
    }
}
