//! A mesh file's format told by its content, for bytes that come without a
//! trustworthy file name (a file dropped on a web page, say).

use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::text::shorten;
use crate::MeshFormat;

impl MeshFormat {
    /// The format a file's content announces on its first non-blank line:
    /// `tetmesh 1`, Gmsh's `$MeshFormat` (or `$NOD` for MSH 1.0), legacy VTK's
    /// `# vtk DataFile Version`, or XML (`<?xml` or `<VTKFile`: VTU).
    pub fn detect(bytes: &[u8]) -> Option<MeshFormat> {
        let (_, first) = first_line(bytes)?;
        if first.starts_with("tetmesh") {
            Some(MeshFormat::Tetmesh)
        } else if first == "$MeshFormat" || first == "$NOD" {
            Some(MeshFormat::Gmsh)
        } else if first.to_ascii_lowercase().starts_with("# vtk datafile") {
            Some(MeshFormat::VtkLegacy)
        } else if first.starts_with("<?xml") || first.starts_with("<VTKFile") {
            Some(MeshFormat::Vtu)
        } else {
            None
        }
    }
}

/// The first non-blank line among the first 256 bytes, trimmed, with its 1-based
/// number.
fn first_line(bytes: &[u8]) -> Option<(usize, String)> {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(256)]);
    head.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .find(|(_, l)| !l.is_empty())
        .map(|(i, l)| (i, l.to_owned()))
}

/// Reads a tetrahedral mesh from the bytes of a file, choosing the reader by the
/// content ([`MeshFormat::detect`]) rather than by a file name.
///
/// Otherwise as [`read_mesh`](crate::read_mesh); `name` is only used in error
/// messages.
pub fn parse_mesh(bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    match MeshFormat::detect(bytes) {
        Some(format) => crate::parse_as(format, bytes, name),
        None => Err(match first_line(bytes) {
            Some((line, first)) => MeshError::Malformed {
                file: name.to_owned(),
                line: Some(line),
                expected: "a mesh file: \"tetmesh 1\", Gmsh's \"$MeshFormat\" or \"$NOD\", \
                           \"# vtk DataFile Version\" or VTU's XML"
                    .to_owned(),
                found: format!("\"{}\"", shorten(&first)),
            },
            None => MeshError::Truncated {
                file: name.to_owned(),
                line: 1,
                expected: "a mesh file".to_owned(),
            },
        }),
    }
}
