//! The result file (`corofem-result 1`, see docs/scene-format.md): its JSON
//! structures, a compact-but-readable layout, and an all-or-nothing write.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;

/// Value of the `format` key.
pub const FORMAT: &str = "corofem-result 1";

/// The whole result file.
#[derive(Debug, Clone, Serialize)]
pub struct RunResult {
    /// Always [`FORMAT`].
    pub format: &'static str,
    /// The scene file as given on the command line.
    pub scene: String,
    /// Node and element counts of the built scene.
    pub mesh: MeshCounts,
    /// Element method name.
    pub method: &'static str,
    /// Time steps run (for a static solve: Newton iterations run).
    pub steps: u64,
    /// Static solves only: how the Newton iterations ended.
    #[serde(rename = "static", skip_serializing_if = "Option::is_none")]
    pub static_solve: Option<StaticOutcome>,
    /// Wall-clock timing.
    pub timing: Timing,
    /// Final state.
    #[serde(rename = "final")]
    pub final_state: FinalState,
    /// Records every `output.every` steps, including step 0 and the last step
    /// (static: one per Newton iteration).
    pub history: Vec<HistoryEntry>,
    /// The `[visual]` surface, when the scene has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub visual: Option<VisualResult>,
}

/// `visual` key: the embedded surface.
#[derive(Debug, Clone, Serialize)]
pub struct VisualResult {
    /// Vertices of the surface file.
    pub vertices: usize,
    /// Triangles (polygons split into triangles).
    pub triangles: usize,
    /// Vertices inside a tetrahedron.
    pub inside: u32,
    /// Vertices outside the tetrahedra, extrapolated from the nearest one.
    pub outside: u32,
    /// Largest distance of a vertex from its tetrahedron at rest (m).
    pub max_distance: f32,
    /// How far outside a vertex was allowed (m).
    pub reach: f32,
    /// Vertex positions at the end (m), in the order of the file.
    pub final_positions: Vec<[f32; 3]>,
}

/// `mesh` key.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MeshCounts {
    /// Nodes.
    pub nodes: usize,
    /// Tetrahedra.
    pub tets: usize,
}

/// `static` key: outcome of a static solve, with each stopping rule's value
/// at the last Newton iteration.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StaticOutcome {
    /// The out-of-balance force of the final shape is small: `force ≤
    /// tolerance`.
    pub converged: bool,
    /// The rule that stopped the Newton iterations. `"force"`: `residual ≤
    /// tolerance`. `"update"`: `update ≤ update_tolerance` and `cg_residual
    /// ≤ cg_tolerance` (the body no longer moves; `force` says whether it
    /// is in equilibrium). `null`: neither, within `newton_iterations`.
    pub met: Option<&'static str>,
    /// Out-of-balance force over the load, before the last update.
    pub residual: f32,
    /// Out-of-balance force over the load of the final shape, after the
    /// last update: what `converged` is about.
    pub force: f32,
    /// What `residual` is held to (`[solver] newton_tolerance`).
    pub tolerance: f32,
    /// RMS of the last update over the RMS displacement (0 when no update
    /// was made).
    pub update: f32,
    /// What `update` is held to.
    pub update_tolerance: f32,
    /// Relative residual of the last CG solve (0 when none ran).
    pub cg_residual: f32,
    /// What `cg_residual` must reach for the update rule to count
    /// (`[solver] cg_tolerance`).
    pub cg_tolerance: f32,
}

/// `timing` key.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Timing {
    /// Median wall time of one step (ms): the `step` call alone.
    pub ms_per_step_median: f64,
    /// Fastest step (ms).
    pub ms_per_step_min: f64,
    /// Wall time of the whole stepping loop, with diagnostics and VTK output (s).
    pub total_s: f64,
}

impl Timing {
    /// Median and minimum of per-step times (ms), and the loop's total (s).
    pub fn from_samples(mut ms: Vec<f64>, total_s: f64) -> Timing {
        ms.sort_by(f64::total_cmp);
        let median = match ms.len() {
            0 => 0.0,
            n if n % 2 == 1 => ms[n / 2],
            n => 0.5 * (ms[n / 2 - 1] + ms[n / 2]),
        };
        Timing {
            ms_per_step_median: median,
            ms_per_step_min: ms.first().copied().unwrap_or(0.0),
            total_s,
        }
    }
}

/// `final` key.
#[derive(Debug, Clone, Serialize)]
pub struct FinalState {
    /// Node positions (m).
    pub positions: Vec<[f32; 3]>,
    /// Node velocities (m/s); zero after a static solve.
    pub velocities: Vec<[f32; 3]>,
    /// Elements with negative signed volume.
    pub inverted: u32,
}

/// One `history` record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HistoryEntry {
    /// Steps done (static: Newton iterations done).
    pub step: u64,
    /// Simulated time (s).
    pub t: f64,
    /// `½ Σ m |v|²` (J).
    pub kinetic_energy: f32,
    /// Elastic energy of the current shape (J).
    pub elastic_energy: f32,
    /// `Σ m v` (kg·m/s).
    pub momentum: [f32; 3],
    /// `Σ x × m v` about the origin (kg·m²/s).
    pub angular_momentum: [f32; 3],
    /// Elements with negative signed volume.
    pub inverted: u32,
    /// CG iterations of the last step (0 at step 0).
    pub cg_iterations: u32,
    /// Relative CG residual of the last step (0 at step 0).
    pub cg_residual: f32,
    /// Force the body exerts on the tool (N).
    pub tool_force: [f32; 3],
    /// Force the body exerts on each `[[probe]]`, in file order (N).
    pub probe_forces: Vec<[f32; 3]>,
    /// Nodes held by a probe or the ground during the last step.
    pub contacts: u32,
    /// Force the fixed nodes and the ground exert on the body over the last
    /// step (N).
    pub support_force: [f32; 3],
    /// Static only: out-of-balance force before this iteration, relative to the load.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub newton_residual: Option<f32>,
    /// Static only: RMS update of this iteration relative to the RMS displacement.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub newton_update: Option<f32>,
}

impl HistoryEntry {
    /// The name of the first non-finite quantity, if any.
    pub fn non_finite(&self) -> Option<&'static str> {
        let vec_ok = |v: [f32; 3]| v.iter().all(|x| x.is_finite());
        [
            ("kinetic energy", self.kinetic_energy.is_finite()),
            ("elastic energy", self.elastic_energy.is_finite()),
            ("momentum", vec_ok(self.momentum)),
            ("angular momentum", vec_ok(self.angular_momentum)),
            ("CG residual", self.cg_residual.is_finite()),
            ("tool force", vec_ok(self.tool_force)),
            ("probe force", self.probe_forces.iter().all(|f| vec_ok(*f))),
            ("support force", vec_ok(self.support_force)),
            (
                "Newton residual",
                self.newton_residual.is_none_or(f32::is_finite),
            ),
            (
                "Newton update",
                self.newton_update.is_none_or(f32::is_finite),
            ),
        ]
        .into_iter()
        .find_map(|(name, ok)| (!ok).then_some(name))
    }
}

/// The result as JSON text: containers near the top break lines, the rest
/// (vectors, history records) stay on one line each.
pub fn to_json(result: &RunResult) -> String {
    let mut out = Vec::new();
    let mut ser = serde_json::Serializer::with_formatter(&mut out, LayoutFormatter::default());
    // Serializing plain structs of numbers and strings into memory cannot fail.
    result
        .serialize(&mut ser)
        .expect("result serializes to JSON");
    out.push(b'\n');
    String::from_utf8(out).expect("serde_json writes UTF-8")
}

/// Line breaks for objects up to this nesting level (the top object is 1).
const BREAK_OBJECTS_TO: usize = 2;
/// Line breaks for arrays up to this nesting level.
const BREAK_ARRAYS_TO: usize = 3;

/// A JSON layout between compact and pretty: the top object and `final` break
/// lines, `positions` / `velocities` / `history` put one entry per line, and
/// every entry (a vector or a history record) stays on a single line.
#[derive(Debug, Default)]
struct LayoutFormatter {
    /// Per open container: whether it breaks lines.
    open: Vec<bool>,
    has_value: bool,
}

impl LayoutFormatter {
    fn breaks(&self) -> bool {
        self.open.last().copied().unwrap_or(false)
    }

    fn indent<W: ?Sized + Write>(&self, w: &mut W, level: usize) -> io::Result<()> {
        for _ in 0..level {
            w.write_all(b"  ")?;
        }
        Ok(())
    }

    fn item<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        if self.breaks() {
            w.write_all(if first { b"\n" } else { b",\n" })?;
            self.indent(w, self.open.len())
        } else if first {
            Ok(())
        } else {
            w.write_all(b", ")
        }
    }

    fn close<W: ?Sized + Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        let broke = self.open.pop().unwrap_or(false);
        if broke && self.has_value {
            w.write_all(b"\n")?;
            self.indent(w, self.open.len())?;
        }
        w.write_all(bracket)
    }
}

impl serde_json::ser::Formatter for LayoutFormatter {
    fn begin_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open.push(self.open.len() < BREAK_ARRAYS_TO);
        self.has_value = false;
        w.write_all(b"[")
    }

    fn end_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"]")
    }

    fn begin_array_value<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        self.item(w, first)
    }

    fn end_array_value<W: ?Sized + Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
    }

    fn begin_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open.push(self.open.len() < BREAK_OBJECTS_TO);
        self.has_value = false;
        w.write_all(b"{")
    }

    fn end_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"}")
    }

    fn begin_object_key<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        self.item(w, first)
    }

    fn begin_object_value<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(b": ")
    }

    fn end_object_value<W: ?Sized + Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
    }
}

/// Where the result goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Destination {
    /// A file, written to a temporary file in the same folder and renamed.
    File(PathBuf),
    /// Standard output (`--out -`).
    Stdout,
}

impl Destination {
    /// Fails early if the file's folder does not exist, so that a long run
    /// does not end with nowhere to write.
    pub fn check(&self) -> io::Result<()> {
        match self {
            Destination::Stdout => Ok(()),
            Destination::File(path) => {
                let dir = folder_of(path);
                if dir.is_dir() {
                    Ok(())
                } else {
                    Err(io::Error::new(
                        io::ErrorKind::NotFound,
                        format!(
                            "{}: the folder {} does not exist",
                            path.display(),
                            dir.display()
                        ),
                    ))
                }
            }
        }
    }

    /// Writes `text` all at once: a file appears complete or not at all.
    pub fn write(&self, text: &str) -> io::Result<()> {
        match self {
            Destination::Stdout => {
                let mut out = io::stdout().lock();
                out.write_all(text.as_bytes())?;
                out.flush()
            }
            Destination::File(path) => write_atomic(path, text.as_bytes()),
        }
    }
}

/// The folder of `path` (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to a temporary file next to `path`, syncs it and renames it
/// over `path`; on failure the temporary file is removed and `path` untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{}: not a file name", path.display()),
        )
    })?;
    let tmp = folder_of(path).join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let attempt = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if let Err(e) = attempt {
        let _ = fs::remove_file(&tmp);
        return Err(io::Error::new(
            e.kind(),
            format!("{}: cannot write: {e}", path.display()),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(step: u64) -> HistoryEntry {
        HistoryEntry {
            step,
            t: 0.1,
            kinetic_energy: 0.1,
            elastic_energy: 0.0,
            momentum: [0.0; 3],
            angular_momentum: [1.0, 2.0, 3.0],
            inverted: 0,
            cg_iterations: 5,
            cg_residual: 1e-3,
            tool_force: [0.0; 3],
            probe_forces: Vec::new(),
            contacts: 0,
            support_force: [0.0; 3],
            newton_residual: None,
            newton_update: None,
        }
    }

    fn sample() -> RunResult {
        RunResult {
            format: FORMAT,
            scene: "s.toml".into(),
            mesh: MeshCounts { nodes: 2, tets: 1 },
            method: "qr",
            steps: 1,
            static_solve: None,
            timing: Timing::from_samples(vec![3.0, 1.0, 2.0, 10.0], 0.5),
            final_state: FinalState {
                positions: vec![[0.1, 0.2, 0.3], [1.0, 0.0, 0.0]],
                velocities: vec![[0.0; 3], [0.0; 3]],
                inverted: 0,
            },
            history: vec![entry(0), entry(1)],
            visual: None,
        }
    }

    #[test]
    fn layout_is_valid_json_with_one_record_per_line() {
        let text = to_json(&sample());
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["format"], FORMAT);
        assert_eq!(v["timing"]["ms_per_step_median"], 2.5);
        assert_eq!(
            v["final"]["positions"][0][1].as_f64().unwrap() as f32,
            0.2f32
        );
        assert!(text.contains("\n      [0.1, 0.2, 0.3],\n"), "{text}");
        assert!(
            text.contains("\n    {\"step\": 0, \"t\": 0.1, \"kinetic_energy\": 0.1,"),
            "{text}"
        );
        assert!(!text.contains("newton"), "{text}");
    }

    #[test]
    fn atomic_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("corofem-cli-result-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("r.json");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "two");
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1);
        fs::remove_dir_all(&dir).unwrap();
    }
}
