//! Errors: small `Copy` values that say which element, node or parameter is wrong.

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
    /// More nodes to grab than the storage's grab slots (`G` of
    /// `ArrayStorage`).
    TooManyGrabbed {
        /// Distinct nodes asked for.
        count: usize,
        /// Grab slots of the storage.
        capacity: usize,
    },
    /// A force on one more node than the storage's load slots (`L` of
    /// `ArrayStorage`).
    TooManyLoads {
        /// Load slots of the storage, all in use.
        capacity: usize,
    },
    /// A node coordinate is NaN or infinite.
    NonFiniteCoordinate {
        /// The offending node.
        node: usize,
    },
    /// An element refers to a node that does not exist.
    NodeIndexOutOfRange {
        /// The offending element.
        element: usize,
        /// The index it holds.
        node: usize,
    },
    /// An element lists the same node twice.
    RepeatedNode {
        /// The offending element.
        element: usize,
        /// The repeated node.
        node: usize,
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
        node: usize,
    },
    /// A node index given to a setter does not exist in the built scene.
    NodeOutOfRange {
        /// The index given.
        node: usize,
    },
    /// An element index given to a setter does not exist in the built scene.
    ElementOutOfRange {
        /// The index given.
        element: usize,
    },
    /// A parameter is outside its valid range or not finite.
    InvalidParameter {
        /// The parameter's name, as in the settings struct.
        name: &'static str,
    },
    /// The element method is not compiled into this build: enable the
    /// `corofem` feature [`Method::feature`].
    MethodNotCompiled {
        /// The method asked for.
        method: Method,
    },
    /// The operation needs a built scene.
    NotBuilt,
    /// A static solve needs something that holds the body: fixed nodes or the tool.
    Unconstrained,
    /// A static solve produced non-finite displacements; the last finite
    /// iterate was kept.
    StaticDiverged,
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
                write!(f, "tetrahedron {element} has zero rest volume")
            }
            Error::InvertedElement { element } => write!(
                f,
                "tetrahedron {element} is negatively oriented (enable re-orientation to fix it)"
            ),
            Error::UnusedNode { node } => write!(f, "node {node} belongs to no tetrahedron"),
            Error::NodeOutOfRange { node } => write!(f, "node {node} does not exist"),
            Error::ElementOutOfRange { element } => write!(f, "element {element} does not exist"),
            Error::InvalidParameter { name } => write!(f, "parameter `{name}` is out of range"),
            Error::MethodNotCompiled { method } => write!(
                f,
                "element method `{}` is not compiled into this build (corofem feature `{}`)",
                method.name(),
                method.feature()
            ),
            Error::NotBuilt => write!(f, "the scene has not been built"),
            Error::Unconstrained => {
                write!(f, "a static solve needs fixed nodes or a grabbing tool")
            }
            Error::StaticDiverged => write!(f, "the static solve diverged"),
        }
    }
}

impl core::error::Error for Error {}

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
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::NonFiniteInput => write!(f, "a step input is NaN or infinite"),
            StepError::Diverged => {
                write!(f, "the step produced non-finite values and was not applied")
            }
        }
    }
}

impl core::error::Error for StepError {}
