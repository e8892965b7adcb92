//! VTK unstructured grids, legacy `.vtk` and XML `.vtu`, read and written with the
//! `vtkio` crate.
//!
//! Reading keeps the cells of type `VTK_TETRA` (10) and skips all others; legacy
//! files may be ASCII or binary, in the classic `CELLS` layout or the 5.x
//! `OFFSETS`/`CONNECTIVITY` one. vtkio's legacy parser reports no position, so
//! legacy parse errors carry no line number (count checks done here do). Writing
//! produces one unstructured grid of `VTK_TETRA` cells.

use std::io::BufReader;
use std::path::Path;

use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataArray, DataSet, ElementType, IOBuffer,
    Piece, UnstructuredGridPiece, Version, VertexNumbers, Vtk,
};

use crate::error::{check_count, MeshError};
use crate::guard::catch_quietly;
use crate::mesh::Mesh;
use crate::text::shorten;

/// Which VTK file flavour to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flavour {
    /// Legacy `.vtk` (ASCII or big-endian binary).
    Legacy,
    /// XML `.vtu`.
    Xml,
}

/// Parses the bytes of a legacy VTK file (`.vtk`, ASCII or binary) holding an
/// unstructured grid, keeping its `VTK_TETRA` cells.
///
/// `name` is only used in error messages. The `POINTS` and `CELLS` counts are
/// checked against [`MAX_COUNT`](crate::MAX_COUNT) before parsing.
pub fn parse_vtk_legacy(bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    parse(bytes, name, Flavour::Legacy)
}

/// Parses the bytes of an XML VTK unstructured-grid file (`.vtu`), keeping its
/// `VTK_TETRA` cells. Data may be ASCII, inline base64 or raw appended, and
/// uncompressed or zlib- or LZ4-compressed (VTK's and ParaView's usual output;
/// LZMA is not supported). Several pieces are concatenated.
///
/// `name` is only used in error messages. The `NumberOfPoints` and `NumberOfCells`
/// attributes are checked against [`MAX_COUNT`](crate::MAX_COUNT) before parsing.
pub fn parse_vtu(bytes: &[u8], name: &str) -> Result<Mesh, MeshError> {
    parse(bytes, name, Flavour::Xml)
}

fn parse(bytes: &[u8], name: &str, flavour: Flavour) -> Result<Mesh, MeshError> {
    match flavour {
        Flavour::Legacy => precheck_legacy(bytes, name)?,
        Flavour::Xml => precheck_xml(bytes, name)?,
    }
    let parse_error = |message: String| MeshError::Parse {
        file: name.to_owned(),
        line: None,
        message,
    };
    // vtkio has a few `unwrap`s and unchecked slices that malformed input reaches.
    let vtk = catch_quietly(|| match flavour {
        Flavour::Legacy => Vtk::parse_legacy_be(bytes),
        Flavour::Xml => Vtk::parse_xml(BufReader::new(bytes)),
    })
    .ok_or_else(|| parse_error("the vtkio parser failed (panicked) on this file".to_owned()))?
    .map_err(|e| {
        let e = e.to_string();
        // nom's `Complete`: the parser needed more input than the file has.
        if e.contains("Complete") || e.contains("Incomplete") {
            parse_error(
                "the file ends early: it stops before the points, cells or cell types its \
                 header lines announce (a truncated or partly written file?)"
                    .to_owned(),
            )
        } else {
            parse_error(format!("vtkio could not parse the file: {e}"))
        }
    })?;

    let pieces = match vtk.data {
        DataSet::UnstructuredGrid { pieces, .. } => pieces,
        other => {
            let kind = match other {
                DataSet::ImageData { .. } => "image data (structured points)",
                DataSet::StructuredGrid { .. } => "a structured grid",
                DataSet::RectilinearGrid { .. } => "a rectilinear grid",
                DataSet::PolyData { .. } => "poly data (a surface)",
                DataSet::Field { .. } => "a field",
                DataSet::UnstructuredGrid { .. } => unreachable!(),
            };
            return Err(MeshError::Malformed {
                file: name.to_owned(),
                line: None,
                expected: "an unstructured grid".to_owned(),
                found: kind.to_owned(),
            });
        }
    };

    let mut mesh = Mesh::default();
    let (mut skipped, mut higher_order) = (0, 0);
    for (k, piece) in pieces.into_iter().enumerate() {
        let piece = match piece {
            Piece::Inline(p) => *p,
            Piece::Source(..) | Piece::Loaded(..) => {
                return Err(MeshError::Unsupported {
                    file: name.to_owned(),
                    line: None,
                    what: "pieces stored in other files (parallel .pvtu); read the piece files"
                        .to_owned(),
                })
            }
        };
        let (s, h) = append_piece(&mut mesh, piece, name, k)?;
        skipped += s;
        higher_order += h;
    }
    if mesh.tets.is_empty() {
        return Err(MeshError::NoTetrahedra {
            file: name.to_owned(),
            skipped,
            higher_order,
        });
    }
    Ok(mesh)
}

/// Appends the points and tetrahedra of one piece; returns the number of non-tet
/// cells skipped and how many of them are higher-order tetrahedra.
fn append_piece(
    mesh: &mut Mesh,
    piece: UnstructuredGridPiece,
    name: &str,
    k: usize,
) -> Result<(usize, usize), MeshError> {
    let malformed = |expected: &str, found: String| MeshError::Malformed {
        file: name.to_owned(),
        line: None,
        expected: format!("{expected} (piece {k})"),
        found,
    };
    let coords: Vec<f64> = piece
        .points
        .cast_into::<f64>()
        .ok_or_else(|| malformed("numeric point coordinates", "bit data".to_owned()))?;
    if coords.len() % 3 != 0 {
        return Err(malformed(
            "3 coordinates per point",
            format!("{} values", coords.len()),
        ));
    }
    if let Some(bad) = coords.iter().position(|c| !c.is_finite()) {
        return Err(malformed(
            "finite point coordinates",
            format!("{} for point {}", coords[bad], bad / 3),
        ));
    }
    let base = mesh.nodes.len();
    let n_points = coords.len() / 3;
    mesh.nodes
        .extend(coords.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));

    // Normalise both topology layouts to (offsets, connectivity) with a leading 0.
    let types = piece.cells.types;
    let (starts, connectivity): (Vec<usize>, Vec<u64>) = match piece.cells.cell_verts {
        VertexNumbers::Legacy {
            num_cells,
            vertices,
        } => {
            // Each cell is `n i_1 ... i_n`.
            let mut starts = vec![0];
            let mut conn = Vec::with_capacity(vertices.len());
            let mut i = 0;
            while i < vertices.len() {
                let n = vertices[i] as usize;
                let cell = vertices.get(i + 1..i + 1 + n).ok_or_else(|| {
                    malformed("complete cell lists", "a truncated cell".to_owned())
                })?;
                conn.extend(cell.iter().map(|&v| u64::from(v)));
                starts.push(conn.len());
                i += 1 + n;
            }
            if starts.len() - 1 != num_cells as usize {
                return Err(MeshError::CountMismatch {
                    file: name.to_owned(),
                    line: None,
                    what: "cells".to_owned(),
                    declared: num_cells as usize,
                    found: starts.len() - 1,
                });
            }
            (starts, conn)
        }
        VertexNumbers::XML {
            offsets,
            connectivity,
        } => {
            let mut starts = Vec::with_capacity(offsets.len() + 1);
            // XML offsets are the ends of the cells; legacy 5.x OFFSETS start with 0.
            if offsets.first() != Some(&0) {
                starts.push(0);
            }
            for &o in &offsets {
                let o = usize::try_from(o).unwrap_or(usize::MAX);
                if o > connectivity.len() || starts.last().is_some_and(|&p| o < p) {
                    return Err(malformed(
                        "increasing cell offsets within the connectivity",
                        format!("offset {o}"),
                    ));
                }
                starts.push(o);
            }
            (starts, connectivity)
        }
    };
    if types.len() != starts.len() - 1 {
        return Err(MeshError::CountMismatch {
            file: name.to_owned(),
            line: None,
            what: "cell types".to_owned(),
            declared: starts.len() - 1,
            found: types.len(),
        });
    }

    let (mut skipped, mut higher_order) = (0, 0);
    for (c, ty) in types.iter().enumerate() {
        let cell = &connectivity[starts[c]..starts[c + 1]];
        if *ty != CellType::Tetra {
            skipped += 1;
            if matches!(
                ty,
                CellType::QuadraticTetra
                    | CellType::HigherOrderTetrahedron
                    | CellType::LagrangeTetrahedron
                    | CellType::BezierTetrahedron
            ) {
                higher_order += 1;
            }
            continue;
        }
        if cell.len() != 4 {
            return Err(malformed(
                "4 points per VTK_TETRA cell",
                format!("{} points in cell {c}", cell.len()),
            ));
        }
        let mut tet = [0usize; 4];
        for (v, &i) in tet.iter_mut().zip(cell) {
            if i >= n_points as u64 {
                return Err(MeshError::IndexOutOfRange {
                    file: name.to_owned(),
                    line: None,
                    index: i,
                    nodes: n_points,
                });
            }
            *v = base + i as usize;
        }
        mesh.tets.push(tet);
    }
    Ok((skipped, higher_order))
}

/// Checks the `POINTS n` and `CELLS n size` lines of a legacy file against the
/// count limit (the keyword lines are text even in binary files).
fn precheck_legacy(bytes: &[u8], name: &str) -> Result<(), MeshError> {
    let mut seen_points = false;
    let mut seen_cells = false;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let upper = |kw: &[u8]| {
            line.len() > kw.len()
                && line[..kw.len()].eq_ignore_ascii_case(kw)
                && line[kw.len()].is_ascii_whitespace()
        };
        let (what, field) = if !seen_points && upper(b"POINTS") {
            seen_points = true;
            ("point", 1)
        } else if !seen_cells && upper(b"CELLS") {
            seen_cells = true;
            ("cell", 1)
        } else {
            continue;
        };
        let text = String::from_utf8_lossy(line);
        let Some(token) = text.split_ascii_whitespace().nth(field) else {
            continue;
        };
        match token.parse::<u64>() {
            Ok(n) => {
                check_count(name, Some(i + 1), what, n)?;
            }
            Err(_) => {
                return Err(MeshError::BadNumber {
                    file: name.to_owned(),
                    line: i + 1,
                    expected: format!("the number of {what}s (a non-negative integer)"),
                    token: shorten(token),
                })
            }
        }
        if seen_points && seen_cells {
            break;
        }
    }
    Ok(())
}

/// Checks every `NumberOfPoints` / `NumberOfCells` attribute of an XML file
/// against the count limit.
fn precheck_xml(bytes: &[u8], name: &str) -> Result<(), MeshError> {
    for (attr, what) in [
        (&b"NumberOfPoints=\""[..], "point"),
        (&b"NumberOfCells=\""[..], "cell"),
    ] {
        let mut from = 0;
        while let Some(p) = bytes[from..].windows(attr.len()).position(|w| w == attr) {
            let start = from + p + attr.len();
            let len = bytes[start..]
                .iter()
                .position(|&b| b == b'"')
                .unwrap_or(0)
                .min(40);
            let token = String::from_utf8_lossy(&bytes[start..start + len]);
            let line = 1 + bytes[..start].iter().filter(|&&b| b == b'\n').count();
            let n = token
                .trim()
                .parse::<u64>()
                .map_err(|_| MeshError::BadNumber {
                    file: name.to_owned(),
                    line,
                    expected: format!("the number of {what}s (a non-negative integer)"),
                    token: token.to_string(),
                })?;
            check_count(name, Some(line), what, n)?;
            from = start;
        }
    }
    Ok(())
}

/// Builds the vtkio model of an unstructured grid of tetrahedra.
pub(crate) fn tet_grid(
    version: Version,
    points: IOBuffer,
    tets: &[[usize; 4]],
    point_data: Vec<Attribute>,
) -> Vtk {
    let flat: Vec<u64> = tets.iter().flatten().map(|&i| i as u64).collect();
    cell_grid(version, points, flat, 4, CellType::Tetra, point_data)
}

/// Builds the vtkio model of an unstructured grid of cells of one type,
/// `per_cell` points each, listed one after the other in `connectivity`.
pub(crate) fn cell_grid(
    version: Version,
    points: IOBuffer,
    connectivity: Vec<u64>,
    per_cell: usize,
    cell_type: CellType,
    point_data: Vec<Attribute>,
) -> Vtk {
    let count = connectivity.len() / per_cell.max(1);
    let offsets: Vec<u64> = (1..=count as u64).map(|c| per_cell as u64 * c).collect();
    Vtk {
        version,
        title: "corofem".to_owned(),
        byte_order: ByteOrder::LittleEndian,
        file_path: None,
        data: DataSet::inline(UnstructuredGridPiece {
            points,
            cells: Cells {
                cell_verts: VertexNumbers::XML {
                    offsets,
                    connectivity,
                },
                types: vec![cell_type; count],
            },
            data: Attributes {
                point: point_data,
                cell: Vec::new(),
            },
        }),
    }
}

/// A point-data array named `name` of kind `elem`.
pub(crate) fn point_attribute(name: &str, elem: ElementType, data: IOBuffer) -> Attribute {
    Attribute::DataArray(DataArray {
        name: name.to_owned(),
        elem,
        data,
    })
}

/// Writes a mesh as a VTK unstructured grid of `VTK_TETRA` cells (no point data),
/// e.g. to look at it in ParaView or to convert it.
///
/// The extension of `path` picks the flavour: `.vtk` writes legacy ASCII
/// (version 4.2, coordinates as `double`, exact), `.vtu` writes XML with inline
/// base64 binary data (little-endian, `Float64` coordinates). Errors name the path.
pub fn write_vtk_mesh(path: &Path, mesh: &Mesh) -> std::io::Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let points = IOBuffer::F64(mesh.nodes.iter().flatten().copied().collect());
    let result = match ext.to_ascii_lowercase().as_str() {
        "vtk" => {
            tet_grid(Version::new_legacy(4, 2), points, &mesh.tets, Vec::new()).export_ascii(path)
        }
        "vtu" => {
            return write_vtu(
                path,
                tet_grid(Version::new_xml(1, 0), points, &mesh.tets, Vec::new()),
            )
        }
        _ => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{}: cannot write VTK: extension must be .vtk or .vtu",
                    path.display()
                ),
            ))
        }
    };
    result.map_err(|e| vtk_io_error(path, e))
}

/// Writes `vtk` as an XML file to `path`, whatever its extension.
pub(crate) fn write_vtu(path: &Path, vtk: Vtk) -> std::io::Result<()> {
    let file = std::fs::File::create(path).map_err(|e| {
        std::io::Error::new(e.kind(), format!("{}: cannot create: {e}", path.display()))
    })?;
    let mut out = std::io::BufWriter::new(file);
    vtk.write_xml(&mut out).map_err(|e| vtk_io_error(path, e))?;
    std::io::Write::flush(&mut out).map_err(|e| vtk_io_error(path, vtkio::Error::IO(e)))
}

/// Converts a vtkio error into an I/O error that names the file.
pub(crate) fn vtk_io_error(path: &Path, e: vtkio::Error) -> std::io::Error {
    match e {
        vtkio::Error::IO(io) => {
            std::io::Error::new(io.kind(), format!("{}: cannot write: {io}", path.display()))
        }
        other => std::io::Error::other(format!("{}: cannot write VTK: {other}", path.display())),
    }
}
