//! A time series of VTK frames that ParaView opens as one animated data set.
//!
//! Layout of the output directory:
//!
//! ```text
//! DIR/frame_000000.vtu    one XML unstructured grid per frame (written with vtkio)
//! DIR/frame_000001.vtu
//! ...
//! DIR/series.pvd          ParaView collection: every frame with its time
//! DIR/surface_000000.vtu  an embedded surface's frames, if one is written
//! DIR/surface.pvd         (triangles with vertex normals), and their collection
//! ```
//!
//! Open `series.pvd` in ParaView. The `.pvd` is a few lines of XML written by hand;
//! it is rewritten in place after every frame, so it is valid (lists every frame
//! written so far) even if the program stops before [`VtkSeries::finish`].

use std::fs::{self, File};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use vtkio::model::{CellType, ElementType, IOBuffer, Version};

use crate::vtk::{cell_grid, point_attribute, write_vtu};

/// Name of the collection file inside the output directory.
pub const PVD_NAME: &str = "series.pvd";

/// Name of an embedded surface's collection file
/// ([`VtkSeries::create_surface`]).
pub const SURFACE_PVD_NAME: &str = "surface.pvd";

const PVD_HEADER: &str = "<?xml version=\"1.0\"?>\n\
<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
const PVD_FOOTER: &str = "  </Collection>\n</VTKFile>\n";

/// Writes a simulation as a series of `.vtu` frames plus a `series.pvd` index.
///
/// The mesh connectivity is fixed at [`create`](VtkSeries::create); each
/// [`write_frame`](VtkSeries::write_frame) writes the current node positions as the
/// grid's points and the node velocities as point data `"velocity"` (3 components).
/// A series made by [`create_surface`](VtkSeries::create_surface) holds
/// triangles instead, in `surface_*.vtu` frames listed in `surface.pvd`, and
/// its point data is the vertex normals, `"normal"`, that ParaView shades with.
///
/// ```no_run
/// # fn main() -> std::io::Result<()> {
/// use corofem_io::VtkSeries;
/// let tets = [[0, 1, 2, 3]];
/// let mut series = VtkSeries::create("out/run1".as_ref(), &tets)?;
/// let pos = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let vel = [[0.0f32; 3]; 4];
/// series.write_frame(0.0, &pos, &vel)?;
/// series.finish()?;
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct VtkSeries {
    dir: PathBuf,
    /// The cells' point indices, one cell after the other.
    cells: Vec<u64>,
    kind: Kind,
    /// Smallest node count the connectivity allows (largest index + 1).
    min_nodes: usize,
    /// Node count fixed by the first frame.
    n_nodes: Option<usize>,
    frames: usize,
    pvd: File,
    /// Byte offset of the footer in the `.pvd` file (where the next entry goes).
    pvd_end: u64,
}

impl VtkSeries {
    /// Creates `dir` (and its parents) if needed and starts an empty `series.pvd`.
    ///
    /// `tets` holds 0-based node indices; it is copied. Existing `frame_*.vtu`
    /// files in `dir` are overwritten as frames are written (stale frames beyond
    /// the new count stay on disk but are not listed in the `.pvd`).
    pub fn create(dir: &Path, tets: &[[usize; 4]]) -> io::Result<Self> {
        let cells = tets.iter().flatten().map(|&i| i as u64).collect();
        Self::start(dir, cells, Kind::Volume)
    }

    /// Creates `dir` if needed and starts an empty `surface.pvd`, for the
    /// frames of an embedded triangle surface (`surface_000000.vtu`, ...):
    /// beside a volume series in the same folder, it does not touch that
    /// one's files. `triangles` index the vertices; they are copied.
    pub fn create_surface(dir: &Path, triangles: &[[u32; 3]]) -> io::Result<Self> {
        let cells = triangles.iter().flatten().map(|&i| u64::from(i)).collect();
        Self::start(dir, cells, Kind::Surface)
    }

    fn start(dir: &Path, cells: Vec<u64>, kind: Kind) -> io::Result<Self> {
        fs::create_dir_all(dir).map_err(|e| with_path(dir, "cannot create directory", e))?;
        let pvd_path = dir.join(kind.pvd_name());
        let mut pvd =
            File::create(&pvd_path).map_err(|e| with_path(&pvd_path, "cannot create", e))?;
        pvd.write_all(PVD_HEADER.as_bytes())
            .and_then(|_| pvd.write_all(PVD_FOOTER.as_bytes()))
            .map_err(|e| with_path(&pvd_path, "cannot write", e))?;
        let min_nodes = cells.iter().max().map_or(0, |&m| m as usize + 1);
        Ok(VtkSeries {
            dir: dir.to_owned(),
            cells,
            kind,
            min_nodes,
            n_nodes: None,
            frames: 0,
            pvd,
            pvd_end: PVD_HEADER.len() as u64,
        })
    }

    /// The output directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Number of frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Path of frame number `index` (`DIR/frame_000042.vtu`, or
    /// `DIR/surface_000042.vtu` for a surface).
    pub fn frame_path(&self, index: usize) -> PathBuf {
        let prefix = match self.kind {
            Kind::Volume => "frame",
            Kind::Surface => "surface",
        };
        self.dir.join(format!("{prefix}_{index:06}.vtu"))
    }

    /// Writes the next frame and lists it in `series.pvd`.
    ///
    /// * `time` — simulation time of the frame (seconds; any finite value, normally
    ///   increasing).
    /// * `positions` — current node positions (length unit of the mesh), one per node.
    /// * `velocities` — node velocities (length unit per second), one per node and
    ///   written as point data `"velocity"`; pass an empty slice to omit the field.
    ///   For a surface series: the vertex normals, written as `"normal"`.
    ///
    /// Every frame must have the same node count, at least the largest node index of
    /// the connectivity plus one; otherwise an `InvalidInput` error is returned and
    /// nothing is written.
    pub fn write_frame(
        &mut self,
        time: f64,
        positions: &[[f32; 3]],
        velocities: &[[f32; 3]],
    ) -> io::Result<()> {
        let invalid = |msg: String| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("{}: frame {}: {msg}", self.dir.display(), self.frames),
            )
        };
        if !time.is_finite() {
            return Err(invalid(format!("time must be finite, got {time}")));
        }
        let n = positions.len();
        if let Some(expected) = self.n_nodes {
            if n != expected {
                return Err(invalid(format!(
                    "expected {expected} positions (as in frame 0), got {n}"
                )));
            }
        } else if n < self.min_nodes {
            return Err(invalid(format!(
                "the connectivity uses {} nodes but only {n} positions were given",
                self.min_nodes
            )));
        }
        if !velocities.is_empty() && velocities.len() != n {
            return Err(invalid(format!(
                "expected {n} velocities (one per position) or none, got {}",
                velocities.len()
            )));
        }

        let points = IOBuffer::F32(positions.iter().flatten().copied().collect());
        let point_data = if velocities.is_empty() {
            Vec::new()
        } else {
            let (name, elem) = match self.kind {
                Kind::Volume => ("velocity", ElementType::Vectors),
                Kind::Surface => ("normal", ElementType::Normals),
            };
            vec![point_attribute(
                name,
                elem,
                IOBuffer::F32(velocities.iter().flatten().copied().collect()),
            )]
        };
        let (per_cell, cell_type) = match self.kind {
            Kind::Volume => (4, CellType::Tetra),
            Kind::Surface => (3, CellType::Triangle),
        };
        let path = self.frame_path(self.frames);
        let grid = cell_grid(
            Version::new_xml(1, 0),
            points,
            self.cells.clone(),
            per_cell,
            cell_type,
            point_data,
        );
        write_vtu(&path, grid)?;

        // Overwrite the footer with the new entry followed by the footer.
        let file_name = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let entry = format!(
            "    <DataSet timestep=\"{time:?}\" group=\"\" part=\"0\" file=\"{file_name}\"/>\n"
        );
        let pvd_path = self.pvd_path();
        self.pvd
            .seek(SeekFrom::Start(self.pvd_end))
            .and_then(|_| self.pvd.write_all(entry.as_bytes()))
            .and_then(|_| self.pvd.write_all(PVD_FOOTER.as_bytes()))
            .and_then(|_| self.pvd.flush())
            .map_err(|e| with_path(&pvd_path, "cannot write", e))?;
        self.pvd_end += entry.len() as u64;
        self.n_nodes = Some(n);
        self.frames += 1;
        Ok(())
    }

    /// Path of the collection file (`DIR/series.pvd`, or `DIR/surface.pvd`),
    /// the file to open in ParaView.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(self.kind.pvd_name())
    }

    /// Finishes the series: flushes `series.pvd` to disk.
    ///
    /// Dropping a `VtkSeries` without calling this leaves a valid `.pvd` too; `finish`
    /// only adds the `fsync` and reports its errors.
    pub fn finish(self) -> io::Result<()> {
        self.pvd
            .sync_all()
            .map_err(|e| with_path(&self.pvd_path(), "cannot write", e))
    }
}

/// What a series holds.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Tetrahedra, with node velocities.
    Volume,
    /// Triangles, with vertex normals.
    Surface,
}

impl Kind {
    fn pvd_name(self) -> &'static str {
        match self {
            Kind::Volume => PVD_NAME,
            Kind::Surface => SURFACE_PVD_NAME,
        }
    }
}

/// An I/O error whose message names the path.
fn with_path(path: &Path, what: &str, e: io::Error) -> io::Error {
    io::Error::new(e.kind(), format!("{}: {what}: {e}", path.display()))
}
