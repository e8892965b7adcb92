//! The error type of every mesh reader in this crate.

use std::fmt;
use std::io;

use crate::text::plural;

/// Largest node, element or cell count any reader accepts (10 million).
///
/// Counts declared in a file are checked against this limit *before* anything is
/// allocated for them, so a corrupt or hostile header such as `tetmesh 1` /
/// `99999999999 1` fails fast with [`MeshError::TooLarge`] instead of exhausting
/// memory.
pub const MAX_COUNT: usize = 10_000_000;

/// What to do about second- or higher-order tetrahedra (10-node and more),
/// which the readers skip: the one wording of this advice, for every reader
/// and every program that shows [`MeshError`] messages (the web demo too).
const FIRST_ORDER_HINT: &str =
    "corofem uses 4-node tetrahedra; mesh with first-order elements (Gmsh: `-order 1` or `Mesh.ElementOrder = 1`)";

/// Why a mesh file could not be read.
///
/// Every message names the file; where it applies it also names the 1-based line
/// number and says what was expected, in the usual `file:line: message` form, e.g.
/// `liver.tetmesh:5: expected 3 coordinates, found 2`.
///
/// `file` is the path as given to [`read_mesh`](crate::read_mesh) (or the `name`
/// given to a `parse_*` function).
#[derive(Debug)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be opened or read (missing file, permissions, ...).
    Io {
        /// The file.
        file: String,
        /// The underlying operating-system error.
        source: io::Error,
    },
    /// The file name has no extension this crate reads.
    UnknownExtension {
        /// The file.
        file: String,
        /// The extension found, without the dot (`None` if there is none).
        extension: Option<String>,
    },
    /// The surface file name has no extension this crate reads (`.obj`,
    /// `.stl`).
    UnknownSurfaceExtension {
        /// The file.
        file: String,
        /// The extension found, without the dot (`None` if there is none).
        extension: Option<String>,
    },
    /// The file does not have the structure its format requires (a missing or wrong
    /// header or section marker, the wrong number of values on a line, ...).
    Malformed {
        /// The file.
        file: String,
        /// 1-based line number, if known.
        line: Option<usize>,
        /// What the format requires here.
        expected: String,
        /// What the file contains instead.
        found: String,
    },
    /// The file ends before all the data its header announced.
    Truncated {
        /// The file.
        file: String,
        /// 1-based number of the line where more data was expected.
        line: usize,
        /// What was still expected.
        expected: String,
    },
    /// A count declared in the file disagrees with the data that follows it.
    CountMismatch {
        /// The file.
        file: String,
        /// 1-based line number where the disagreement shows, if known.
        line: Option<usize>,
        /// What is being counted (e.g. `"tetrahedra"`).
        what: String,
        /// The count the file declares.
        declared: usize,
        /// The count actually found (or a lower bound of it).
        found: usize,
    },
    /// A token that should be a number is not a valid one of the required kind
    /// (also: a non-finite coordinate such as `nan` or `inf`).
    BadNumber {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What the token should have been (e.g. `"y coordinate of node 3"`).
        expected: String,
        /// The offending token.
        token: String,
    },
    /// A tetrahedron refers to a node index that does not exist.
    IndexOutOfRange {
        /// The file.
        file: String,
        /// 1-based line number, if known.
        line: Option<usize>,
        /// The offending 0-based node index.
        index: u64,
        /// Number of nodes in the mesh (valid indices are `0..nodes`).
        nodes: usize,
    },
    /// A Gmsh element refers to a node tag that no `$Nodes` entry defines.
    UnknownNodeTag {
        /// The file.
        file: String,
        /// 1-based line number, if known.
        line: Option<usize>,
        /// The undefined node tag.
        tag: u64,
    },
    /// The file holds no tetrahedra (other element or cell types are skipped).
    NoTetrahedra {
        /// The file.
        file: String,
        /// How many elements or cells of other types were skipped.
        skipped: usize,
        /// How many of the skipped are second- or higher-order tetrahedra
        /// (Gmsh's 10-node type 11 and the like): the message then says to
        /// mesh with first-order elements.
        higher_order: usize,
    },
    /// A declared count exceeds [`MAX_COUNT`]; nothing was allocated for it.
    TooLarge {
        /// The file.
        file: String,
        /// 1-based line number of the count, if known.
        line: Option<usize>,
        /// What is being counted (e.g. `"node"`).
        what: String,
        /// The declared count.
        count: u64,
    },
    /// A valid file in a variant of its format this crate does not read
    /// (e.g. binary Gmsh MSH 2, MSH 4.0), or a format whose cargo feature is
    /// off in this build (VTK without `vtk`, binary MSH 4.1 without
    /// `gmsh-binary`).
    Unsupported {
        /// The file.
        file: String,
        /// 1-based line number, if known.
        line: Option<usize>,
        /// What is not supported, and what is.
        what: String,
    },
    /// A third-party parser (mshio for binary Gmsh MSH 4.1, vtkio for VTK) rejected
    /// the file; `message` is its explanation.
    Parse {
        /// The file.
        file: String,
        /// 1-based line number, if the parser reported a position.
        line: Option<usize>,
        /// The parser's explanation.
        message: String,
    },
}

impl MeshError {
    /// The file the error is about (as given to the reader).
    pub fn file(&self) -> &str {
        match self {
            MeshError::Io { file, .. }
            | MeshError::UnknownExtension { file, .. }
            | MeshError::UnknownSurfaceExtension { file, .. }
            | MeshError::Malformed { file, .. }
            | MeshError::Truncated { file, .. }
            | MeshError::CountMismatch { file, .. }
            | MeshError::BadNumber { file, .. }
            | MeshError::IndexOutOfRange { file, .. }
            | MeshError::UnknownNodeTag { file, .. }
            | MeshError::NoTetrahedra { file, .. }
            | MeshError::TooLarge { file, .. }
            | MeshError::Unsupported { file, .. }
            | MeshError::Parse { file, .. } => file,
        }
    }

    /// The 1-based line number the error is about, if it has one.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshError::Truncated { line, .. } | MeshError::BadNumber { line, .. } => Some(*line),
            MeshError::Malformed { line, .. }
            | MeshError::CountMismatch { line, .. }
            | MeshError::IndexOutOfRange { line, .. }
            | MeshError::UnknownNodeTag { line, .. }
            | MeshError::TooLarge { line, .. }
            | MeshError::Unsupported { line, .. }
            | MeshError::Parse { line, .. } => *line,
            MeshError::Io { .. }
            | MeshError::UnknownExtension { .. }
            | MeshError::UnknownSurfaceExtension { .. }
            | MeshError::NoTetrahedra { .. } => None,
        }
    }
}

/// Writes `file:line: ` or `file: `.
fn location(f: &mut fmt::Formatter<'_>, file: &str, line: Option<usize>) -> fmt::Result {
    match line {
        Some(line) => write!(f, "{file}:{line}: "),
        None => write!(f, "{file}: "),
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        location(f, self.file(), self.line())?;
        self.write_detail(f)
    }
}

/// [`MeshError::detail`]: the message without its location.
struct Detail<'a>(&'a MeshError);

impl fmt::Display for Detail<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.write_detail(f)
    }
}

impl MeshError {
    /// The message without the `file:line: ` prefix that `Display` writes,
    /// for a program that shows the file and the line ([`line`](Self::line))
    /// its own way.
    pub fn detail(&self) -> impl fmt::Display + '_ {
        Detail(self)
    }

    fn write_detail(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Io { source, .. } => write!(f, "cannot read file: {source}"),
            MeshError::UnknownExtension { extension, .. } => {
                match extension {
                    Some(ext) => write!(f, "unknown mesh file extension \".{ext}\"")?,
                    None => write!(f, "mesh file name has no extension")?,
                }
                write!(f, " (expected .tetmesh, .msh, .vtk or .vtu)")
            }
            MeshError::UnknownSurfaceExtension { extension, .. } => {
                match extension {
                    Some(ext) => write!(f, "unknown surface file extension \".{ext}\"")?,
                    None => write!(f, "surface file name has no extension")?,
                }
                write!(f, " (expected .obj or .stl)")
            }
            MeshError::Malformed {
                expected, found, ..
            } => write!(f, "expected {expected}, found {found}"),
            MeshError::Truncated { expected, .. } => {
                write!(f, "unexpected end of file, expected {expected}")
            }
            MeshError::CountMismatch {
                what,
                declared,
                found,
                ..
            } => write!(
                f,
                "file declares {declared} {what} but contains {found}"
            ),
            MeshError::BadNumber {
                expected, token, ..
            } => write!(f, "expected {expected}, found \"{token}\""),
            MeshError::IndexOutOfRange { index, nodes, .. } => write!(
                f,
                "node index {index} out of range (the mesh has {nodes} nodes, valid indices are 0..{nodes})"
            ),
            MeshError::UnknownNodeTag { tag, .. } => {
                write!(f, "element refers to node tag {tag}, which no $Nodes entry defines")
            }
            MeshError::NoTetrahedra {
                skipped,
                higher_order,
                ..
            } => {
                write!(
                    f,
                    "expected at least one 4-node tetrahedron, found none ({} of other types skipped)",
                    plural(*skipped, "element")
                )?;
                if *higher_order > 0 {
                    let (them, are) = match (*higher_order, *skipped) {
                        (1, 1) => ("It".to_owned(), "is a second- or higher-order tetrahedron"),
                        (1, _) => ("1 of them".to_owned(), "is a second- or higher-order tetrahedron"),
                        (h, _) => (format!("{h} of them"), "are second- or higher-order tetrahedra"),
                    };
                    write!(f, ". {them} {are}: {FIRST_ORDER_HINT}")?;
                }
                Ok(())
            }
            MeshError::TooLarge { what, count, .. } => write!(
                f,
                "{what} count {count} exceeds the limit of {MAX_COUNT}; refusing to allocate"
            ),
            MeshError::Unsupported { what, .. } => write!(f, "unsupported: {what}"),
            MeshError::Parse { message, .. } => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for MeshError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            MeshError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Returns [`MeshError::TooLarge`] if `count` exceeds [`MAX_COUNT`].
pub(crate) fn check_count(
    file: &str,
    line: Option<usize>,
    what: &str,
    count: u64,
) -> Result<usize, MeshError> {
    if count > MAX_COUNT as u64 {
        return Err(MeshError::TooLarge {
            file: file.to_owned(),
            line,
            what: what.to_owned(),
            count,
        });
    }
    Ok(count as usize)
}
