//! The scene file: strict TOML structures (unknown keys are errors) and their
//! validation into a [`SceneSpec`] whose values are all in range.
//!
//! Every error names the file, the key and what was expected, in the form
//! `liver_pull.toml: [material] poisson = 0.6: expected 0 <= poisson < 0.5`.
//! Syntax and type errors found by the TOML parser name the file, line and
//! column, the enclosing section, and show the offending line.

use std::fmt::{self, Display};
use std::path::{Path, PathBuf};

use corofem::{
    BoxMesh, Friction, Material, Method, Plane, Preconditioner, Settings, StaticSettings,
};
use serde::Deserialize;

use crate::error::{CliError, CliResult};
use crate::tool_path::ToolPath;

// ---------------------------------------------------------------------------
// Raw TOML structures: exactly the keys of docs/scene-format.md.
// ---------------------------------------------------------------------------

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    mesh: RawMesh,
    #[serde(default)]
    material: RawMaterial,
    #[serde(default)]
    solver: RawSolver,
    #[serde(default)]
    world: RawWorld,
    #[serde(default)]
    fixed: Vec<RawSelection>,
    #[serde(default)]
    force: Vec<RawForce>,
    initial: Option<RawInitial>,
    #[serde(default)]
    material_change: Vec<RawMaterialChange>,
    tool: Option<RawTool>,
    #[serde(default)]
    probe: Vec<RawProbe>,
    visual: Option<RawVisual>,
    #[serde(default)]
    output: RawOutput,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVisual {
    file: String,
    reach: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    file: Option<String>,
    generator: Option<String>,
    size: Option<[f64; 3]>,
    cells: Option<[i64; 3]>,
    tets_per_cell: Option<i64>,
    scale: Option<f64>,
    reorient: Option<bool>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    young: Option<f64>,
    poisson: Option<f64>,
    density: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSolver {
    method: Option<String>,
    dt: Option<f64>,
    steps: Option<i64>,
    cg_iterations: Option<i64>,
    cg_tolerance: Option<f64>,
    rayleigh_mass: Option<f64>,
    rayleigh_stiffness: Option<f64>,
    friction_damping: Option<f64>,
    #[serde(rename = "static")]
    static_solve: Option<bool>,
    warm_start: Option<bool>,
    energy_guard: Option<bool>,
    free_rotation: Option<bool>,
    contact_rounds: Option<i64>,
    preconditioner: Option<String>,
    newton_iterations: Option<i64>,
    newton_tolerance: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    gravity: Option<[f64; 3]>,
    ground: Option<RawPlane>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlane {
    normal: [f64; 3],
    #[serde(default)]
    offset: f64,
    friction: Option<f64>,
    static_friction: Option<f64>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBox {
    min: [f64; 3],
    max: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSelection {
    #[serde(rename = "box")]
    bbox: Option<RawBox>,
    nodes: Option<Vec<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawForce {
    #[serde(rename = "box")]
    bbox: Option<RawBox>,
    nodes: Option<Vec<i64>>,
    total: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInitial {
    velocity: Option<[f64; 3]>,
    angular_velocity: Option<[f64; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterialChange {
    step: i64,
    young: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTool {
    #[serde(rename = "box")]
    bbox: Option<RawBox>,
    nodes: Option<Vec<i64>>,
    stiffness: f64,
    path: Option<Vec<[f64; 4]>>,
    release: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProbe {
    shape: Option<String>,
    radius: f64,
    half_length: Option<f64>,
    axis: Option<[f64; 3]>,
    position: [f64; 3],
    path: Option<Vec<[f64; 4]>>,
    friction: Option<f64>,
    static_friction: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    every: Option<i64>,
}

// ---------------------------------------------------------------------------
// Validated scene.
// ---------------------------------------------------------------------------

/// Where the mesh comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshSource {
    /// A mesh file, resolved against the scene file's folder; `given` is the
    /// path as written in the scene.
    File {
        /// Resolved path.
        path: PathBuf,
        /// The `file` value as written.
        given: String,
    },
    /// A generated box.
    Box(BoxMesh),
}

/// The validated `[mesh]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSpec {
    /// File or generator.
    pub source: MeshSource,
    /// Coordinate factor (`> 0`).
    pub scale: f64,
    /// Re-orient negatively oriented tetrahedra instead of rejecting them.
    pub reorient: bool,
}

/// Nodes chosen by an axis-aligned box, an index list, or both (their union).
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Where the selection was written, e.g. `[[fixed]] #2` or `[tool]`.
    pub label: String,
    /// Box `(min, max)` in scaled mesh coordinates (m), inclusive.
    pub bbox: Option<([f32; 3], [f32; 3])>,
    /// Explicit node indices (each `>= 0`; checked against the mesh later).
    pub nodes: Vec<u64>,
}

/// A `[[force]]` entry.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceSpec {
    /// The nodes the force is spread over.
    pub selection: Selection,
    /// Total force (N).
    pub total: [f32; 3],
}

/// The `[initial]` table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialSpec {
    /// Translation velocity (m/s).
    pub velocity: [f64; 3],
    /// Angular velocity about the mass-weighted centroid (rad/s).
    pub angular_velocity: [f64; 3],
}

/// A `[[material_change]]` entry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialChange {
    /// Applied after this many steps, before the next one.
    pub step: u64,
    /// New Young's modulus of every element (Pa).
    pub young: f32,
}

/// The `[tool]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolSpec {
    /// The grabbed nodes.
    pub selection: Selection,
    /// Total spring stiffness (N/m).
    pub stiffness: f32,
    /// Target offset from the grabbed nodes' initial centroid over time.
    pub path: ToolPath,
    /// Time (s) from which the tool lets go.
    pub release: Option<f64>,
}

/// A `[[probe]]` entry: a rigid sphere or capsule the body cannot enter.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeSpec {
    /// Where it was written, e.g. `[[probe]] #1`.
    pub label: String,
    /// Radius (m).
    pub radius: f32,
    /// Half the capsule's segment length (m); 0 for a sphere.
    pub half_length: f32,
    /// The capsule's axis (unit; `[0, 0, 1]` for a sphere).
    pub axis: [f32; 3],
    /// The centre at t = 0 (m).
    pub position: [f64; 3],
    /// Offset of the centre from `position` over time.
    pub path: ToolPath,
    /// `friction` and `static_friction`.
    pub friction: Friction,
}

/// The `[visual]` table: a triangle surface carried by the tetrahedra.
#[derive(Debug, Clone, PartialEq)]
pub struct VisualSpec {
    /// The surface file, resolved against the scene file's folder.
    pub path: PathBuf,
    /// The `file` value as written.
    pub given: String,
    /// How far outside the tetrahedra a vertex may lie (m, after
    /// `[mesh] scale`); `None`: half the mean edge length.
    pub reach: Option<f32>,
}

/// A fully validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSpec {
    /// The scene file as given on the command line (used in messages).
    pub file: String,
    /// `[mesh]`.
    pub mesh: MeshSpec,
    /// `[material]`.
    pub material: Material,
    /// Step settings (`[solver]` and `[world] gravity`).
    pub settings: Settings,
    /// `[solver] dt` as written (s), for reported times.
    pub dt: f64,
    /// `[solver] steps` (0 for a static solve).
    pub steps: u64,
    /// `Some` for `[solver] static = true`.
    pub static_solve: Option<StaticSpec>,
    /// `[world] ground`.
    pub ground: Option<Plane>,
    /// `[world] ground`'s `friction` and `static_friction`.
    pub ground_friction: Friction,
    /// `[[fixed]]` entries.
    pub fixed: Vec<Selection>,
    /// `[[force]]` entries.
    pub forces: Vec<ForceSpec>,
    /// `[initial]`.
    pub initial: Option<InitialSpec>,
    /// `[[material_change]]` entries, sorted by step (stable).
    pub material_changes: Vec<MaterialChange>,
    /// `[tool]`.
    pub tool: Option<ToolSpec>,
    /// `[[probe]]` entries, in file order.
    pub probes: Vec<ProbeSpec>,
    /// `[visual]`.
    pub visual: Option<VisualSpec>,
    /// `[output] every`.
    pub every: u64,
}

/// Settings of a static solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticSpec {
    /// Newton iterations at most.
    pub max_iterations: u32,
    /// Per-solve settings (`max_iterations` is run one at a time by the CLI).
    pub settings: StaticSettings,
}

/// One key of the scene file, for `corofem run --help`: the table it is in,
/// its name, its default (from the constants the parser uses) and what it
/// sets. A test checks that the keys are exactly the parser's fields.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyDoc {
    /// `[mesh]`, `[[probe]]`, `[world] ground`, ...
    pub table: &'static str,
    /// The key.
    pub key: &'static str,
    /// The default as written in a scene file, or `required`, `none`.
    pub default: String,
    /// What it sets, with its unit.
    pub what: &'static str,
}

/// Default `[mesh] tets_per_cell`.
pub const DEFAULT_TETS_PER_CELL: i64 = 6;

/// Every key of the scene file with its default, in the parser's order.
pub fn keys() -> Vec<KeyDoc> {
    let m = Material::DEFAULT;
    let d = Settings::default();
    let mass = Settings::with_preconditioner(Preconditioner::Mass);
    let st = StaticSettings::default();
    // An f32 default as written in decimal (0.3, not 0.30000001192092896).
    let v = |x: f32| format!("{:?}", x.to_string().parse::<f64>().unwrap_or(0.0));
    let g = d.gravity;
    #[rustfmt::skip]
    let rows: [(&'static str, &'static str, String, &'static str); 59] = [
        ("[mesh]", "file", "required, or generator".into(), "mesh file: .tetmesh, Gmsh .msh (v2, v4), .vtk, .vtu"),
        ("[mesh]", "generator", "none".into(), "\"box\": a box split into tetrahedra, instead of file"),
        ("[mesh]", "size", "required with generator".into(), "[x, y, z]: the box's size (m)"),
        ("[mesh]", "cells", "required with generator".into(), "[nx, ny, nz]: cells along each axis"),
        ("[mesh]", "tets_per_cell", DEFAULT_TETS_PER_CELL.to_string(), "5 or 6 tetrahedra per cell"),
        ("[mesh]", "scale", "1.0".into(), "factor on the file's coordinates (0.01: cm to m)"),
        ("[mesh]", "reorient", "false".into(), "swap nodes of negatively oriented tets instead of refusing them"),
        ("[material]", "young", v(m.young), "Young's modulus (Pa); 0: no elastic force"),
        ("[material]", "poisson", v(m.poisson), "Poisson ratio, 0 <= nu < 0.5"),
        ("[material]", "density", v(m.density), "kg/m^3"),
        ("[solver]", "method", format!("{:?}", d.method.name()), "\"qr-invertible\", \"qr\", \"polar\", \"linear\", \"qr-rest-b\""),
        ("[solver]", "dt", v(d.dt), "time step (s)"),
        ("[solver]", "steps", "required, unless static".into(), "time steps to run (at most 1e9)"),
        ("[solver]", "cg_iterations", format!( "{} ({} with \"mass\", {} static)", d.cg_iterations, mass.cg_iterations, st.cg_iterations ), "CG iterations per step"),
        ("[solver]", "cg_tolerance", format!("{} ({} static)", v(d.cg_tolerance), v(st.cg_tolerance)), "relative residual at which CG stops early; 0: never"),
        ("[solver]", "rayleigh_mass", v(d.rayleigh_mass), "damping C = rayleigh_mass M + rayleigh_stiffness K (1/s)"),
        ("[solver]", "rayleigh_stiffness", v(d.rayleigh_stiffness), "stiffness damping (s)"),
        ("[solver]", "friction_damping", v(d.friction_damping), "stiffness damping at least, on a ground with friction (s)"),
        ("[solver]", "static", "false".into(), "true: solve for static equilibrium instead of stepping"),
        ("[solver]", "warm_start", format!("{} ({} with \"mass\")", d.warm_start, mass.warm_start), "start CG from the last step's solution"),
        ("[solver]", "energy_guard", d.energy_guard.to_string(), "take out energy that inverted elements made"),
        ("[solver]", "free_rotation", d.free_rotation.to_string(), "a free body that moves as one turns by a rigid rotation"),
        ("[solver]", "contact_rounds", d.contact_rounds.to_string(), "friction: most solves more per step that make it Coulomb's"),
        ("[solver]", "preconditioner", format!("{:?}", d.preconditioner.name()), "\"two-level\", \"block-jacobi\" or \"mass\" (the paper's CG)"),
        ("[solver]", "newton_iterations", st.max_iterations.to_string(), "static: most Newton iterations"),
        ("[solver]", "newton_tolerance", v(st.tolerance), "static: out-of-balance force / load that counts as converged"),
        ("[world]", "gravity", format!("[{}, {}, {}]", v(g[0]), v(g[1]), v(g[2])), "m/s^2"),
        ("[world]", "ground", "none".into(), "{ normal = [x, y, z], offset, friction, static_friction }: the plane n.x >= offset"),
        ("[world] ground", "normal", "required".into(), "the plane's normal (any length but 0)"),
        ("[world] ground", "offset", "0.0".into(), "n.x >= offset, with n normalised (m)"),
        ("[world] ground", "friction", "0.0".into(), "Coulomb coefficient (kinetic)"),
        ("[world] ground", "static_friction", "friction".into(), "static coefficient, at least friction"),
        ("[[fixed]]", "box", "none; box or nodes".into(), "{ min = [x, y, z], max = [x, y, z] }: nodes inside are held (m)"),
        ("[[fixed]]", "nodes", "none; box or nodes".into(), "[i, ...]: node indices (0-based) held"),
        ("[[fixed]] box", "min", "required".into(), "smallest corner (m)"),
        ("[[fixed]] box", "max", "required".into(), "largest corner (m)"),
        ("[[force]]", "box", "none; box or nodes".into(), "the nodes the force is spread over"),
        ("[[force]]", "nodes", "none; box or nodes".into(), "node indices (0-based)"),
        ("[[force]]", "total", "required".into(), "[fx, fy, fz]: the total force, spread evenly (N)"),
        ("[initial]", "velocity", "[0.0, 0.0, 0.0]".into(), "m/s"),
        ("[initial]", "angular_velocity", "[0.0, 0.0, 0.0]".into(), "rad/s, about the mass centroid"),
        ("[[material_change]]", "step", "required".into(), "after this many steps, before the next one"),
        ("[[material_change]]", "young", "required".into(), "the new Young's modulus (Pa)"),
        ("[tool]", "box", "none; box or nodes".into(), "the grabbed nodes"),
        ("[tool]", "nodes", "none; box or nodes".into(), "grabbed node indices (0-based)"),
        ("[tool]", "stiffness", "required".into(), "the spring's total stiffness (N/m)"),
        ("[tool]", "path", "[[0.0, 0.0, 0.0, 0.0]]".into(), "[[t, dx, dy, dz], ...]: target offset over time (s, m)"),
        ("[tool]", "release", "never".into(), "time at which the tool lets go (s)"),
        ("[[probe]]", "shape", "\"sphere\"".into(), "\"sphere\" or \"capsule\""),
        ("[[probe]]", "radius", "required".into(), "m"),
        ("[[probe]]", "half_length", "required for a capsule".into(), "half the capsule's axis segment (m)"),
        ("[[probe]]", "axis", "[0.0, 0.0, 1.0]".into(), "capsule only: the axis' direction"),
        ("[[probe]]", "position", "required".into(), "the centre at t = 0 (m)"),
        ("[[probe]]", "path", "[[0.0, 0.0, 0.0, 0.0]]".into(), "[[t, dx, dy, dz], ...]: offset from position over time"),
        ("[[probe]]", "friction", "0.0".into(), "Coulomb coefficient (kinetic)"),
        ("[[probe]]", "static_friction", "friction".into(), "static coefficient, at least friction"),
        ("[visual]", "file", "required".into(), "a triangle surface (.obj, .stl) carried by the tetrahedra"),
        ("[visual]", "reach", "half the mean edge".into(), "how far outside the tetrahedra a vertex may lie (m)"),
        ("[output]", "every", DEFAULT_EVERY.to_string(), "record the history every n steps"),
    ];
    rows.into_iter()
        .map(|(table, key, default, what)| KeyDoc {
            table,
            key,
            default,
            what,
        })
        .collect()
}

/// The key list of `corofem run --help`: one line per key, grouped by
/// table.
pub fn keys_help() -> String {
    let mut out = String::new();
    let mut table = "";
    for k in keys() {
        if k.table != table {
            table = k.table;
            out.push_str(&format!("{table}\n"));
        }
        let left = format!("  {} = {}", k.key, k.default);
        out.push_str(&format!("{left:<44} {}\n", k.what));
    }
    out
}

/// Default `[output] every`.
pub const DEFAULT_EVERY: u64 = 10;
/// Most time steps of one run (1e9: 14 hours at 50 µs a step; the run keeps
/// one timing sample per step).
pub const MAX_STEPS: u64 = 1_000_000_000;
/// Largest node count the core addresses (u16 indices).
pub const MAX_NODES: usize = 1 << 16;

/// Reads and validates a scene file. `file` is used in messages as given.
pub fn load(path: &Path) -> CliResult<SceneSpec> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError(format!("{file}: cannot read the scene file: {e}")))?;
    let base = path.parent().unwrap_or(Path::new(""));
    parse(&text, &file, base)
}

/// Parses and validates scene text. `file` names it in messages; relative
/// mesh paths are resolved against `base`.
pub fn parse(text: &str, file: &str, base: &Path) -> CliResult<SceneSpec> {
    let raw: RawScene = toml::from_str(text).map_err(|e| toml_error(file, text, &e))?;
    Ctx { file }.validate(raw, base)
}

/// Formats a TOML parse or type error: `file:line:col: [section] message`
/// followed by the offending line.
fn toml_error(file: &str, text: &str, e: &toml::de::Error) -> CliError {
    let message = e.message().trim_end();
    let Some(span) = e.span() else {
        return CliError(format!("{file}: {message}"));
    };
    if span.start == 0 && (span.end == 0 || span.end >= text.trim_end().len()) {
        // The whole document: a missing top-level table.
        return CliError(format!("{file}: {message} (a top-level table)"));
    }
    let start = span.start.min(text.len());
    let before = &text[..start];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = before[line_start..].chars().count() + 1;
    let line_text = text[line_start..].lines().next().unwrap_or("");
    // An error on a table header (an unknown table) is the top level's, not
    // the table's above it.
    let header = line_text.trim_start().starts_with('[');
    let section = if header {
        Some("(top level)".to_owned())
    } else {
        enclosing_section(&text[..line_start])
    };
    if let Some(field) = message.strip_prefix("missing field ") {
        // A required key left out: name the table it belongs to (the
        // parser reports it at the table's header, or at an inline
        // table's key), numbered as the other messages number entries.
        let head = line_text.split('#').next().unwrap_or("").trim();
        let table = if header {
            if head.starts_with("[[") {
                let n = text[..line_start]
                    .lines()
                    .filter(|l| l.split('#').next().unwrap_or("").trim() == head)
                    .count();
                format!("{head} #{}", n + 1)
            } else {
                head.to_owned()
            }
        } else {
            let key = head.split('=').next().unwrap_or("").trim();
            let outer = enclosing_section(&text[..line_start]).unwrap_or_default();
            format!("{outer} {key}").trim().to_owned()
        };
        return CliError(format!(
            "{file}:{line}:{col}: {table}: missing key {field}, which has no default \
             (corofem run --help lists every key)\n  {line} | {line_text}"
        ));
    }
    // serde calls a table a field; on a header line it is a table.
    let message = if header {
        message.replacen("unknown field", "unknown table", 1)
    } else {
        message.to_owned()
    };
    let section = section.map(|s| format!("{s} ")).unwrap_or_default();
    CliError(format!(
        "{file}:{line}:{col}: {section}{message}\n  {line} | {line_text}"
    ))
}

/// The last table header (`[x]` or `[[x]]`) in `text`, if any.
fn enclosing_section(text: &str) -> Option<String> {
    text.lines().rev().find_map(|l| {
        let l = l.split('#').next().unwrap_or("").trim();
        (l.starts_with('[') && l.ends_with(']')).then(|| l.to_owned())
    })
}

/// A number as it would be written in TOML (`0.6`, `1000.0`, `1e-7`).
pub struct Num(pub f64);

impl Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }
}

/// A list of numbers as written in TOML.
pub struct List<'a, T>(pub &'a [T]);

impl<T: fmt::Debug> Display for List<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[")?;
        for (i, x) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{x:?}")?;
        }
        f.write_str("]")
    }
}

/// A list of integers, shortened after 8 entries.
struct Ints<'a>(&'a [i64]);

impl Display for Ints<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[")?;
        for (i, x) in self.0.iter().take(8).enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{x}")?;
        }
        if self.0.len() > 8 {
            write!(f, ", ... ({} in all)", self.0.len())?;
        }
        f.write_str("]")
    }
}

/// The largest magnitude an f32 holds, as messages print it.
pub const F32_MAX_SHOWN: &str = "3.4e38";

/// `expected`, completed for a value too large for f32 (the solver's
/// number type): `young >= 0 (Pa) within f32's range (at most 3.4e38 in
/// magnitude)`.
fn beyond_f32(expected: &str) -> String {
    format!("{expected} within f32's range (at most {F32_MAX_SHOWN} in magnitude; the solver computes in f32)")
}

/// `expected`, completed for a value > 0 that f32 rounds to 0.
fn below_f32(expected: &str) -> String {
    format!(
        "{expected} that f32 does not round to 0 (at least 1.2e-38; the solver computes in f32)"
    )
}

/// Validation context: the file name for messages.
struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    /// `file: [section] key = value: expected ...`.
    fn bad(
        &self,
        section: &str,
        key: &str,
        value: impl Display,
        expected: impl Display,
    ) -> CliError {
        CliError(format!(
            "{}: {section} {key} = {value}: expected {expected}",
            self.file
        ))
    }

    /// The method called `name` in `[solver]`, if this build has it
    /// (`compiled`: `Method::COMPILED`, a parameter for the tests).
    fn method(&self, name: &str, compiled: &[Method]) -> CliResult<Method> {
        let quoted = |methods: &mut dyn Iterator<Item = Method>| {
            methods
                .map(|m| format!("{:?}", m.name()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let method = Method::from_name(name).ok_or_else(|| {
            self.bad(
                "[solver]",
                "method",
                format!("{name:?}"),
                format!("one of {}", quoted(&mut Method::VARIANTS.into_iter())),
            )
        })?;
        if !compiled.contains(&method) {
            return Err(self.bad(
                "[solver]",
                "method",
                format!("{name:?}"),
                format!(
                    "a method this build has ({}): {name:?} needs corofem's feature `{}`",
                    quoted(&mut compiled.iter().copied()),
                    method.feature()
                ),
            ));
        }
        Ok(method)
    }

    /// `file: [section]: message`.
    fn bad_table(&self, section: &str, message: impl Display) -> CliError {
        CliError(format!("{}: {section}: {message}", self.file))
    }

    /// A finite f64 that also fits f32, within `ok`. A value beyond f32's
    /// range (`young = 1e300`) is named as such, not as out of `ok`'s range.
    fn real(
        &self,
        section: &str,
        key: &str,
        value: f64,
        ok: impl Fn(f64) -> bool,
        expected: &str,
    ) -> CliResult<f32> {
        let narrow = value as f32;
        if value.is_finite() && !narrow.is_finite() {
            return Err(self.bad(section, key, Num(value), beyond_f32(expected)));
        }
        if value.is_finite() && ok(value) {
            Ok(narrow)
        } else {
            Err(self.bad(section, key, Num(value), expected))
        }
    }

    /// A vector of finite values that fit f32.
    fn vec3(&self, section: &str, key: &str, v: [f64; 3]) -> CliResult<[f32; 3]> {
        let out = v.map(|x| x as f32);
        if out.iter().all(|x| x.is_finite()) {
            Ok(out)
        } else if v.iter().all(|x| x.is_finite()) {
            Err(self.bad(section, key, List(&v), beyond_f32("three numbers")))
        } else {
            Err(self.bad(section, key, List(&v), "three finite numbers"))
        }
    }

    fn int(
        &self,
        section: &str,
        key: &str,
        value: i64,
        min: i64,
        max: i64,
        expected: &str,
    ) -> CliResult<u64> {
        if (min..=max).contains(&value) {
            Ok(value as u64)
        } else {
            Err(self.bad(section, key, value, expected))
        }
    }

    fn validate(&self, raw: RawScene, base: &Path) -> CliResult<SceneSpec> {
        let mesh = self.mesh(raw.mesh, base)?;
        let material = self.material(&raw.material)?;
        let static_requested = raw.solver.static_solve.unwrap_or(false);
        let (settings, dt, steps, static_solve) = self.solver(&raw.solver, &raw.world)?;
        let ground_friction = match &raw.world.ground {
            Some(p) => self.friction("[world] ground", p.friction, p.static_friction)?,
            None => Friction::NONE,
        };
        let ground = match raw.world.ground {
            None => None,
            Some(p) => {
                let value = format!(
                    "{{ normal = {}, offset = {} }}",
                    List(&p.normal),
                    Num(p.offset)
                );
                let plane = Plane {
                    normal: p.normal.map(|x| x as f32),
                    offset: p.offset as f32,
                };
                if plane.normalized().is_none() {
                    return Err(self.bad(
                        "[world]",
                        "ground",
                        value,
                        "a finite plane with a non-zero normal",
                    ));
                }
                Some(plane)
            }
        };
        let fixed = raw
            .fixed
            .into_iter()
            .enumerate()
            .map(|(i, s)| self.selection(&format!("[[fixed]] #{}", i + 1), s.bbox, s.nodes))
            .collect::<CliResult<Vec<_>>>()?;
        let mut forces = Vec::with_capacity(raw.force.len());
        for (i, f) in raw.force.into_iter().enumerate() {
            let label = format!("[[force]] #{}", i + 1);
            let total = self.vec3(&label, "total", f.total)?;
            forces.push(ForceSpec {
                selection: self.selection(&label, f.bbox, f.nodes)?,
                total,
            });
        }
        let initial = match raw.initial {
            None => None,
            Some(init) => {
                let velocity = init.velocity.unwrap_or([0.0; 3]);
                let angular_velocity = init.angular_velocity.unwrap_or([0.0; 3]);
                self.vec3("[initial]", "velocity", velocity)?;
                self.vec3("[initial]", "angular_velocity", angular_velocity)?;
                Some(InitialSpec {
                    velocity,
                    angular_velocity,
                })
            }
        };
        let mut material_changes = Vec::with_capacity(raw.material_change.len());
        for (i, c) in raw.material_change.iter().enumerate() {
            let label = format!("[[material_change]] #{}", i + 1);
            let max = if static_requested {
                i64::MAX
            } else {
                steps as i64 - 1
            };
            let expected = format!("a step number from 0 to {max} (steps = {steps})");
            let step = self.int(&label, "step", c.step, 0, max, &expected)?;
            let young = self.real(&label, "young", c.young, |y| y >= 0.0, "young >= 0 (Pa)")?;
            material_changes.push(MaterialChange { step, young });
        }
        material_changes.sort_by_key(|c| c.step);
        let tool = raw.tool.map(|t| self.tool(t)).transpose()?;
        let probes = (raw.probe.into_iter().enumerate())
            .map(|(i, p)| self.probe(&format!("[[probe]] #{}", i + 1), p))
            .collect::<CliResult<Vec<_>>>()?;
        if static_solve.is_some() && !probes.is_empty() {
            return Err(self.bad(
                "[solver]",
                "static",
                "true",
                "false with [[probe]] (probes move over time steps)",
            ));
        }
        let visual = raw.visual.map(|v| self.visual(v, base)).transpose()?;
        let every = match raw.output.every {
            None => DEFAULT_EVERY,
            Some(n) => self.int("[output]", "every", n, 1, i64::MAX, "a whole number >= 1")?,
        };
        Ok(SceneSpec {
            file: self.file.to_owned(),
            mesh,
            material,
            settings,
            dt,
            steps,
            static_solve,
            ground,
            ground_friction,
            fixed,
            forces,
            initial,
            material_changes,
            tool,
            probes,
            visual,
            every,
        })
    }

    fn visual(&self, v: RawVisual, base: &Path) -> CliResult<VisualSpec> {
        const S: &str = "[visual]";
        if v.file.is_empty() {
            return Err(self.bad(S, "file", "\"\"", "the path of an .obj or .stl file"));
        }
        let reach = match v.reach {
            None => None,
            Some(r) => Some(self.real(
                S,
                "reach",
                r,
                |r| r >= 0.0,
                "a distance >= 0 (m, after [mesh] scale)",
            )?),
        };
        Ok(VisualSpec {
            path: base.join(&v.file),
            given: v.file,
            reach,
        })
    }

    fn mesh(&self, m: RawMesh, base: &Path) -> CliResult<MeshSpec> {
        const S: &str = "[mesh]";
        let scale = match m.scale {
            None => 1.0,
            Some(s) => {
                let ok = s.is_finite() && s > 0.0;
                if !ok {
                    return Err(self.bad(S, "scale", Num(s), "a factor > 0"));
                }
                s
            }
        };
        let source = match (m.file, m.generator) {
            (Some(_), Some(g)) => {
                return Err(self.bad(
                    S,
                    "generator",
                    format!("{g:?}"),
                    "either `file` or `generator`, not both",
                ))
            }
            (None, None) => {
                return Err(self.bad_table(S, "expected `file = \"...\"` or `generator = \"box\"`"))
            }
            (Some(file), None) => {
                for (key, given) in [
                    ("size", m.size.is_some()),
                    ("cells", m.cells.is_some()),
                    ("tets_per_cell", m.tets_per_cell.is_some()),
                ] {
                    if given {
                        return Err(self.bad_table(
                            S,
                            format!("`{key}` is only for `generator = \"box\"`, not with `file`"),
                        ));
                    }
                }
                if file.is_empty() {
                    return Err(self.bad(S, "file", "\"\"", "the path of a mesh file"));
                }
                MeshSource::File {
                    path: base.join(&file),
                    given: file,
                }
            }
            (None, Some(g)) => {
                if g != "box" {
                    return Err(self.bad(S, "generator", format!("{g:?}"), "\"box\""));
                }
                let size = m.size.ok_or_else(|| {
                    self.bad_table(S, "`generator = \"box\"` needs `size = [x, y, z]` (m)")
                })?;
                let cells = m.cells.ok_or_else(|| {
                    self.bad_table(S, "`generator = \"box\"` needs `cells = [nx, ny, nz]`")
                })?;
                const SIZE: &str = "three lengths > 0 (m)";
                if !size.iter().all(|&s| s.is_finite() && s > 0.0) {
                    return Err(self.bad(S, "size", List(&size), SIZE));
                }
                if !size.iter().all(|&s| (s as f32).is_finite()) {
                    return Err(self.bad(S, "size", List(&size), beyond_f32(SIZE)));
                }
                if !size.iter().all(|&s| s as f32 > 0.0) {
                    return Err(self.bad(S, "size", List(&size), below_f32(SIZE)));
                }
                if !cells.iter().all(|&c| c >= 1) {
                    return Err(self.bad(S, "cells", Ints(&cells), "three whole numbers >= 1"));
                }
                // In u128: (2^63)^3 fits, so no count overflows here.
                let nodes: u128 = cells.iter().map(|&c| c as u128 + 1).product();
                if nodes > MAX_NODES as u128 {
                    return Err(self.bad(
                        S,
                        "cells",
                        Ints(&cells),
                        format!("at most {MAX_NODES} nodes in all ((nx+1)(ny+1)(nz+1) = {nodes})"),
                    ));
                }
                let tets_per_cell = m.tets_per_cell.unwrap_or(DEFAULT_TETS_PER_CELL);
                if tets_per_cell != 5 && tets_per_cell != 6 {
                    return Err(self.bad(S, "tets_per_cell", tets_per_cell, "5 or 6"));
                }
                let b = BoxMesh {
                    size: size.map(|s| s as f32),
                    cells: cells.map(|c| c as u32),
                    tets_per_cell: tets_per_cell as u8,
                };
                MeshSource::Box(b)
            }
        };
        Ok(MeshSpec {
            source,
            scale,
            reorient: m.reorient.unwrap_or(false),
        })
    }

    fn material(&self, m: &RawMaterial) -> CliResult<Material> {
        const S: &str = "[material]";
        let d = Material::DEFAULT;
        let young = match m.young {
            None => d.young,
            Some(y) => self.real(S, "young", y, |y| y >= 0.0, "young >= 0 (Pa)")?,
        };
        let poisson = match m.poisson {
            None => d.poisson,
            Some(p) => {
                let v = self.real(
                    S,
                    "poisson",
                    p,
                    |p| (0.0..0.5).contains(&p),
                    "0 <= poisson < 0.5",
                )?;
                // 0.4999999999 rounds to 0.5 in f32.
                if v >= 0.5 {
                    return Err(self.bad(S, "poisson", Num(p), "0 <= poisson < 0.5"));
                }
                v
            }
        };
        let density = match m.density {
            None => d.density,
            Some(r) => self.real(S, "density", r, |r| r > 0.0, "density > 0 (kg/m^3)")?,
        };
        Ok(Material {
            young,
            poisson,
            density,
        })
    }

    fn solver(
        &self,
        s: &RawSolver,
        w: &RawWorld,
    ) -> CliResult<(Settings, f64, u64, Option<StaticSpec>)> {
        const S: &str = "[solver]";
        let preconditioner = match &s.preconditioner {
            None => Preconditioner::DEFAULT,
            Some(name) => Preconditioner::from_name(name).ok_or_else(|| {
                self.bad(
                    "[solver]",
                    "preconditioner",
                    format!("{name:?}"),
                    format!(
                        "one of {}",
                        Preconditioner::VARIANTS
                            .map(|p| format!("{:?}", p.name()))
                            .join(", ")
                    ),
                )
            })?,
        };
        // The budget and the warm start default to the preconditioner's own.
        let d = Settings::with_preconditioner(preconditioner);
        let method = match &s.method {
            None => Method::DEFAULT,
            Some(name) => self.method(name, Method::COMPILED)?,
        };
        // The default as written in decimal (0.001), not its f32 value widened.
        let dt =
            s.dt.unwrap_or_else(|| d.dt.to_string().parse().unwrap_or(f64::from(d.dt)));
        let dt_f32 = self.real(S, "dt", dt, |x| x > 0.0, "a time step > 0 (s)")?;
        if dt_f32 <= 0.0 {
            return Err(self.bad(S, "dt", Num(dt), below_f32("a time step > 0 (s)")));
        }
        let is_static = s.static_solve.unwrap_or(false);
        let steps = match (s.steps, is_static) {
            (Some(n), _) => self.int(
                S,
                "steps",
                n,
                0,
                MAX_STEPS as i64,
                "a whole number of steps from 0 to 1e9",
            )?,
            (None, true) => 0,
            (None, false) => {
                return Err(self.bad_table(
                    S,
                    "missing `steps`: expected the number of time steps (or `static = true`)",
                ))
            }
        };
        let cg_iterations = match s.cg_iterations {
            None => None,
            Some(n) => Some(self.int(
                S,
                "cg_iterations",
                n,
                1,
                i64::from(u32::MAX),
                "a whole number >= 1",
            )? as u32),
        };
        let contact_rounds = match s.contact_rounds {
            None => d.contact_rounds,
            Some(n) => self.int(
                S,
                "contact_rounds",
                n,
                0,
                i64::from(u32::MAX),
                "a whole number >= 0",
            )? as u32,
        };
        let cg_tolerance = match s.cg_tolerance {
            None => None,
            Some(x) => Some(self.real(
                S,
                "cg_tolerance",
                x,
                |x| x >= 0.0,
                "a relative residual >= 0",
            )?),
        };
        let rayleigh_mass = match s.rayleigh_mass {
            None => d.rayleigh_mass,
            Some(x) => self.real(
                S,
                "rayleigh_mass",
                x,
                |x| x >= 0.0,
                "rayleigh_mass >= 0 (1/s)",
            )?,
        };
        let rayleigh_stiffness = match s.rayleigh_stiffness {
            None => d.rayleigh_stiffness,
            Some(x) => self.real(
                S,
                "rayleigh_stiffness",
                x,
                |x| x >= 0.0,
                "rayleigh_stiffness >= 0 (s)",
            )?,
        };
        let friction_damping = match s.friction_damping {
            None => d.friction_damping,
            Some(x) => self.real(
                S,
                "friction_damping",
                x,
                |x| x >= 0.0,
                "friction_damping >= 0 (s)",
            )?,
        };
        let gravity = match w.gravity {
            None => d.gravity,
            Some(g) => self.vec3("[world]", "gravity", g)?,
        };
        let settings = Settings {
            method,
            dt: dt_f32,
            cg_iterations: if is_static {
                d.cg_iterations
            } else {
                cg_iterations.unwrap_or(d.cg_iterations)
            },
            cg_tolerance: if is_static {
                d.cg_tolerance
            } else {
                cg_tolerance.unwrap_or(d.cg_tolerance)
            },
            rayleigh_mass,
            rayleigh_stiffness,
            friction_damping,
            warm_start: s.warm_start.unwrap_or(d.warm_start),
            energy_guard: s.energy_guard.unwrap_or(d.energy_guard),
            free_rotation: s.free_rotation.unwrap_or(d.free_rotation),
            contact_rounds,
            preconditioner,
            gravity,
        };
        let static_solve = if is_static {
            let mut st = StaticSettings::default();
            let max_iterations = match s.newton_iterations {
                None => st.max_iterations,
                Some(n) => self.int(
                    S,
                    "newton_iterations",
                    n,
                    1,
                    i64::from(u32::MAX),
                    "a whole number >= 1",
                )? as u32,
            };
            if let Some(n) = cg_iterations {
                st.cg_iterations = n;
            }
            if let Some(x) = cg_tolerance {
                st.cg_tolerance = x;
            }
            if let Some(x) = s.newton_tolerance {
                st.tolerance = self.real(
                    S,
                    "newton_tolerance",
                    x,
                    |x| x >= 0.0,
                    "a relative out-of-balance force >= 0",
                )?;
            }
            st.max_iterations = 1;
            Some(StaticSpec {
                max_iterations,
                settings: st,
            })
        } else {
            for (key, given) in [
                ("newton_iterations", s.newton_iterations.is_some()),
                ("newton_tolerance", s.newton_tolerance.is_some()),
            ] {
                if given {
                    return Err(self.bad_table(S, format!("`{key}` is only for `static = true`")));
                }
            }
            None
        };
        Ok((settings, dt, steps, static_solve))
    }

    fn selection(
        &self,
        label: &str,
        bbox: Option<RawBox>,
        nodes: Option<Vec<i64>>,
    ) -> CliResult<Selection> {
        if bbox.is_none() && nodes.is_none() {
            return Err(self.bad_table(
                label,
                "expected `box = { min = [x, y, z], max = [x, y, z] }` or `nodes = [i, ...]` (or both)",
            ));
        }
        let bbox = match bbox {
            None => None,
            Some(b) => {
                let min = b.min.map(|x| x as f32);
                let max = b.max.map(|x| x as f32);
                let finite = b.min.iter().chain(&b.max).all(|x| !x.is_nan());
                if !finite || (0..3).any(|k| b.min[k] > b.max[k]) {
                    return Err(self.bad(
                        label,
                        "box",
                        format!("{{ min = {}, max = {} }}", List(&b.min), List(&b.max)),
                        "min <= max in every coordinate (m)",
                    ));
                }
                Some((min, max))
            }
        };
        let nodes = match nodes {
            None => Vec::new(),
            Some(list) => {
                if list.is_empty() && bbox.is_none() {
                    return Err(self.bad(label, "nodes", "[]", "at least one node index"));
                }
                if list.iter().any(|&i| i < 0) {
                    return Err(self.bad(label, "nodes", Ints(&list), "node indices >= 0"));
                }
                list.into_iter().map(|i| i as u64).collect()
            }
        };
        Ok(Selection {
            label: label.to_owned(),
            bbox,
            nodes,
        })
    }

    fn tool(&self, t: RawTool) -> CliResult<ToolSpec> {
        const S: &str = "[tool]";
        let selection = self.selection(S, t.bbox, t.nodes)?;
        let stiffness = self.real(
            S,
            "stiffness",
            t.stiffness,
            |k| k > 0.0,
            "a stiffness > 0 (N/m)",
        )?;
        let path = self.path(S, t.path)?;
        let release = match t.release {
            None => None,
            Some(r) => {
                if !(r.is_finite() && r >= 0.0) {
                    return Err(self.bad(S, "release", Num(r), "a time >= 0 (s)"));
                }
                Some(r)
            }
        };
        Ok(ToolSpec {
            selection,
            stiffness,
            path,
            release,
        })
    }

    /// A `path` key: `[t, dx, dy, dz]` points, finite, with times from 0
    /// strictly increasing; absent, no motion.
    fn path(&self, section: &str, points: Option<Vec<[f64; 4]>>) -> CliResult<ToolPath> {
        let points = points.unwrap_or_else(|| vec![[0.0; 4]]);
        let shown = || {
            let rows: Vec<String> = points.iter().take(4).map(|p| List(p).to_string()).collect();
            let more = if points.len() > 4 { ", ..." } else { "" };
            format!("[{}{more}]", rows.join(", "))
        };
        let bad = |expected: &str| self.bad(section, "path", shown(), expected);
        if points.is_empty() {
            return Err(self.bad(section, "path", "[]", "at least one point [t, dx, dy, dz]"));
        }
        if points
            .iter()
            .flatten()
            .any(|x| !x.is_finite() || !(*x as f32).is_finite())
        {
            return Err(bad("finite points [t, dx, dy, dz]"));
        }
        if points[0][0] < 0.0 {
            return Err(bad("times t >= 0 (s)"));
        }
        if points.windows(2).any(|w| w[1][0] <= w[0][0]) {
            return Err(bad("strictly increasing times t"));
        }
        Ok(ToolPath::new(points))
    }

    fn probe(&self, s: &str, p: RawProbe) -> CliResult<ProbeSpec> {
        let capsule = match p.shape.as_deref() {
            None | Some("sphere") => false,
            Some("capsule") => true,
            Some(other) => {
                return Err(self.bad(
                    s,
                    "shape",
                    format!("\"{other}\""),
                    "\"sphere\" or \"capsule\"",
                ))
            }
        };
        let radius = self.real(s, "radius", p.radius, |r| r > 0.0, "a radius > 0 (m)")?;
        let half_length = match (capsule, p.half_length) {
            (true, Some(l)) => self.real(s, "half_length", l, |l| l >= 0.0, "a length >= 0 (m)")?,
            (true, None) => {
                return Err(self.bad(
                    s,
                    "half_length",
                    "(missing)",
                    "the capsule's half length (m)",
                ))
            }
            (false, Some(l)) => {
                return Err(self.bad(s, "half_length", Num(l), "no half_length for a sphere"))
            }
            (false, None) => 0.0,
        };
        let axis = match (capsule, p.axis) {
            (true, Some(a)) => {
                let ok = a.iter().all(|x| x.is_finite()) && a.iter().any(|x| *x != 0.0);
                if !ok {
                    return Err(self.bad(s, "axis", List(&a), "a finite, non-zero direction"));
                }
                let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                a.map(|x| (x / n) as f32)
            }
            (false, Some(a)) => {
                return Err(self.bad(s, "axis", List(&a), "no axis for a sphere"));
            }
            (_, None) => [0.0, 0.0, 1.0],
        };
        if !p
            .position
            .iter()
            .all(|x| x.is_finite() && (*x as f32).is_finite())
        {
            return Err(self.bad(s, "position", List(&p.position), "a finite point (m)"));
        }
        let friction = self.friction(s, p.friction, p.static_friction)?;
        let path = self.path(s, p.path)?;
        Ok(ProbeSpec {
            label: s.to_owned(),
            radius,
            half_length,
            axis,
            position: p.position,
            path,
            friction,
        })
    }

    /// Coulomb friction from `friction` (kinetic, default 0) and
    /// `static_friction` (default `friction`).
    fn friction(
        &self,
        section: &str,
        kinetic: Option<f64>,
        stick: Option<f64>,
    ) -> CliResult<Friction> {
        let kinetic = kinetic.unwrap_or(0.0);
        let stick = stick.unwrap_or(kinetic);
        if !(kinetic.is_finite() && kinetic >= 0.0) {
            return Err(self.bad(section, "friction", Num(kinetic), "a coefficient ≥ 0"));
        }
        Friction::new(stick as f32, kinetic as f32).map_err(|_| {
            self.bad(
                section,
                "static_friction",
                Num(stick),
                "a finite coefficient at least `friction`",
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX: &str = "[mesh]\ngenerator = \"box\"\nsize = [1.0, 0.2, 0.2]\ncells = [5, 1, 1]\n";

    fn parse_str(extra: &str) -> CliResult<SceneSpec> {
        parse(&format!("{BOX}{extra}"), "t.toml", Path::new("/scenes"))
    }

    /// The field names serde's derive gives `T` (renames applied): the
    /// keys the parser accepts. A deserializer that only records what
    /// `deserialize_struct` is asked for.
    fn fields<T: for<'de> Deserialize<'de>>() -> &'static [&'static str] {
        use serde::de::{self, Visitor};
        struct Capture<'a>(&'a mut &'static [&'static str]);
        impl<'de> de::Deserializer<'de> for Capture<'_> {
            type Error = de::value::Error;
            fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
                Err(de::Error::custom("not a struct"))
            }
            fn deserialize_struct<V: Visitor<'de>>(
                self,
                _: &'static str,
                fields: &'static [&'static str],
                _: V,
            ) -> Result<V::Value, Self::Error> {
                *self.0 = fields;
                Err(de::Error::custom("captured"))
            }
            serde::forward_to_deserialize_any! {
                bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
                bytes byte_buf option unit unit_struct newtype_struct seq tuple
                tuple_struct map enum identifier ignored_any
            }
        }
        let mut out: &'static [&'static str] = &[];
        let _ = T::deserialize(Capture(&mut out));
        out
    }

    #[test]
    fn the_help_lists_exactly_the_parsers_keys() {
        let tables: [(&str, &[&str]); 15] = [
            ("[mesh]", fields::<RawMesh>()),
            ("[material]", fields::<RawMaterial>()),
            ("[solver]", fields::<RawSolver>()),
            ("[world]", fields::<RawWorld>()),
            ("[world] ground", fields::<RawPlane>()),
            ("[[fixed]]", fields::<RawSelection>()),
            ("[[fixed]] box", fields::<RawBox>()),
            ("[[force]]", fields::<RawForce>()),
            ("[initial]", fields::<RawInitial>()),
            ("[[material_change]]", fields::<RawMaterialChange>()),
            ("[tool]", fields::<RawTool>()),
            ("[[probe]]", fields::<RawProbe>()),
            ("[visual]", fields::<RawVisual>()),
            ("[output]", fields::<RawOutput>()),
            ("(top level)", fields::<RawScene>()),
        ];
        let docs = keys();
        for (table, parsed) in tables {
            assert!(!parsed.is_empty(), "{table}: no fields captured");
            if table == "(top level)" {
                // Every top-level key is a table the help has a heading for.
                for f in parsed {
                    assert!(
                        docs.iter().any(|k| k.table.trim_matches(['[', ']']) == *f),
                        "table [{f}] has no keys in the help"
                    );
                }
                continue;
            }
            let listed: Vec<&str> = docs
                .iter()
                .filter(|k| k.table == table)
                .map(|k| k.key)
                .collect();
            assert_eq!(
                listed, parsed,
                "{table}: the help's keys against the parser's"
            );
        }
        // A key in a table the parser does not have would be listed too.
        let known: Vec<&str> = tables.iter().map(|t| t.0).collect();
        for k in &docs {
            assert!(
                known.contains(&k.table),
                "{}: not a table of the parser",
                k.table
            );
        }
        // The defaults are those the parser applies.
        let help = keys_help();
        let s = parse_str("[solver]\nsteps = 1\n").unwrap();
        for (key, value) in [
            ("young", format!("{:?}", f64::from(s.material.young))),
            ("dt", format!("{:?}", s.dt)),
            ("every", s.every.to_string()),
            ("poisson", "0.3".to_owned()),
            ("gravity", "[0.0, 0.0, -9.81]".to_owned()),
            ("newton_tolerance", "1e-5".to_owned()),
            ("cg_iterations", s.settings.cg_iterations.to_string()),
        ] {
            assert!(
                help.lines()
                    .any(|l| l.trim_start().starts_with(&format!("{key} = {value}"))),
                "{key} = {value} not in:\n{help}"
            );
        }
    }

    #[test]
    fn ground_friction_keys() {
        let plane = "[solver]\nsteps = 1\n[world]\nground = { normal = [0, 0, 1], offset = 0.0";
        let spec = parse_str(&format!(
            "{plane}, friction = 0.4, static_friction = 0.5 }}\n"
        ))
        .unwrap();
        assert_eq!(spec.ground_friction, Friction::new(0.5, 0.4).unwrap());
        // `static_friction` defaults to `friction`; no keys: frictionless.
        let spec = parse_str(&format!("{plane}, friction = 0.3 }}\n")).unwrap();
        assert_eq!(spec.ground_friction, Friction::coulomb(0.3).unwrap());
        let spec = parse_str(&format!("{plane} }}\n")).unwrap();
        assert_eq!(spec.ground_friction, Friction::NONE);
        for (keys, expected) in [
            (
                ", friction = -0.1",
                "[world] ground friction = -0.1: expected a coefficient ≥ 0",
            ),
            (
                ", friction = 0.5, static_friction = 0.4",
                "[world] ground static_friction = 0.4: expected a finite coefficient at least `friction`",
            ),
        ] {
            let err = parse_str(&format!("{plane}{keys} }}\n")).unwrap_err();
            assert!(err.to_string().contains(expected), "{err}");
        }
    }

    #[test]
    fn minimal_scene_gets_defaults() {
        let s = parse_str("[solver]\nsteps = 3\n").unwrap();
        assert_eq!(s.steps, 3);
        assert_eq!(s.every, DEFAULT_EVERY);
        assert_eq!(s.material, Material::DEFAULT);
        assert_eq!(s.settings, Settings::default());
        assert_eq!(s.settings.method, Method::QrInvertible);
        assert!(s.static_solve.is_none());
        // The paper's CG keeps its own budget: 5 cold iterations.
        let s = parse_str("[solver]\nsteps = 3\npreconditioner = \"mass\"\n").unwrap();
        assert_eq!(
            s.settings,
            Settings::with_preconditioner(Preconditioner::Mass)
        );
        assert_eq!(
            (s.settings.cg_iterations, s.settings.warm_start),
            (5, false)
        );
    }

    #[test]
    fn unknown_key_is_named() {
        let e = parse_str("[solver]\nsteps = 3\nstepz = 4\n").unwrap_err().0;
        assert!(e.contains("stepz"), "{e}");
        assert!(e.starts_with("t.toml:7:1: [solver]"), "{e}");
    }

    #[test]
    fn a_missing_key_is_named_with_its_table_not_the_one_above() {
        let e = parse_str("[solver]\nsteps = 3\n[[probe]]\nradius = 0.01\n")
            .unwrap_err()
            .0;
        assert!(
            e.starts_with("t.toml:7:1: [[probe]] #1: missing key `position`, which has no default"),
            "{e}"
        );
        assert!(!e.contains("(top level)"), "{e}");
        assert!(!e.contains("[solver]"), "{e}");
    }

    #[test]
    fn a_misspelt_table_is_an_unknown_table_at_the_top_level() {
        for (scene, table, not) in [
            (
                "[material]\nyoung = 1.0\n[solvr]\nsteps = 3\n",
                "solvr",
                "[material]",
            ),
            (
                "[solver]\nsteps = 3\n[outptu]\nevery = 1\n",
                "outptu",
                "[solver]",
            ),
        ] {
            let e = parse_str(scene).unwrap_err().0;
            assert!(
                e.contains(&format!(": (top level) unknown table `{table}`")),
                "{e}"
            );
            assert!(!e.contains(not), "{e}");
        }
    }

    #[test]
    fn too_many_cells_exceed_the_node_capacity() {
        for cells in [
            "[70000, 1, 1]",
            "[65535, 1, 1]",
            "[9223372036854775807, 2, 2]",
        ] {
            let scene = format!("{}[solver]\nsteps = 1\n", BOX.replace("[5, 1, 1]", cells));
            let e = parse(&scene, "t.toml", Path::new("")).unwrap_err().0;
            assert!(
                e.contains(&format!(
                    "[mesh] cells = {cells}: expected at most 65536 nodes in all"
                )),
                "{e}"
            );
        }
    }

    #[test]
    fn bad_poisson_names_file_key_and_range() {
        let e = parse_str("[material]\npoisson = 0.6\n[solver]\nsteps = 1\n")
            .unwrap_err()
            .0;
        assert_eq!(
            e,
            "t.toml: [material] poisson = 0.6: expected 0 <= poisson < 0.5"
        );
    }

    #[test]
    fn a_method_this_build_lacks_is_named_with_its_feature() {
        let p = Ctx { file: "t.toml" };
        assert_eq!(
            p.method("polar", Method::COMPILED).ok(),
            Some(Method::Polar)
        );
        let e = p
            .method("polar", &[Method::Qr, Method::Linear])
            .unwrap_err()
            .0;
        assert_eq!(
            e,
            "t.toml: [solver] method = \"polar\": expected a method this build has \
             (\"qr\", \"linear\"): \"polar\" needs corofem's feature `polar`"
        );
    }

    #[test]
    fn file_paths_are_relative_to_the_scene() {
        let s = parse(
            "[mesh]\nfile = \"m/liver.tetmesh\"\n[solver]\nsteps = 1\n",
            "x.toml",
            Path::new("/a/b"),
        )
        .unwrap();
        assert_eq!(
            s.mesh.source,
            MeshSource::File {
                path: PathBuf::from("/a/b/m/liver.tetmesh"),
                given: "m/liver.tetmesh".into()
            }
        );
    }

    #[test]
    fn material_change_step_must_be_within_the_run() {
        let e = parse_str("[solver]\nsteps = 10\n[[material_change]]\nstep = 10\nyoung = 1.0\n")
            .unwrap_err()
            .0;
        assert!(
            e.contains("[[material_change]] #1 step = 10: expected a step number from 0 to 9"),
            "{e}"
        );
    }

    #[test]
    fn probes_parse_and_bad_ones_are_named() {
        let ok = parse_str(
            "[solver]\nsteps = 1\n[[probe]]\nradius = 0.01\nposition = [0, 0, 1]\nfriction = 0.0\n\
             [[probe]]\nshape = \"capsule\"\nradius = 0.01\nhalf_length = 0.02\n\
             axis = [0, 2, 0]\nposition = [0, 0, 1]\npath = [[0, 0, 0, 0], [1, 0, 0, -1]]\n",
        )
        .unwrap();
        assert_eq!(ok.probes.len(), 2);
        assert_eq!(
            (ok.probes[0].half_length, ok.probes[0].axis),
            (0.0, [0.0, 0.0, 1.0])
        );
        assert_eq!(
            (ok.probes[1].half_length, ok.probes[1].axis),
            (0.02, [0.0, 1.0, 0.0])
        );
        assert_eq!(ok.probes[1].path.offset(0.5), [0.0, 0.0, -0.5]);
        for (text, expected) in [
            (
                "shape = \"cube\"\nradius = 1.0",
                "[[probe]] #1 shape = \"cube\": expected \"sphere\"",
            ),
            (
                "radius = 0.0",
                "[[probe]] #1 radius = 0.0: expected a radius > 0",
            ),
            (
                "radius = 1.0\nhalf_length = 1.0",
                "[[probe]] #1 half_length = 1.0: expected no",
            ),
            (
                "shape = \"capsule\"\nradius = 1.0",
                "[[probe]] #1 half_length = (missing)",
            ),
            (
                "shape = \"capsule\"\nradius = 1.0\nhalf_length = 1.0\naxis = [0, 0, 0]",
                "[[probe]] #1 axis = [0.0, 0.0, 0.0]: expected a finite, non-zero",
            ),
            (
                "radius = 1.0\nfriction = 0.3\nstatic_friction = 0.2",
                "[[probe]] #1 static_friction = 0.2: expected a finite coefficient at least `friction`",
            ),
            ("radius = 1.0\npath = []", "[[probe]] #1 path = []"),
        ] {
            let e = parse_str(&format!(
                "[solver]\nsteps = 1\n[[probe]]\nposition = [0, 0, 0]\n{text}\n"
            ))
            .unwrap_err()
            .0;
            assert!(e.contains(expected), "{e}");
        }
        let e =
            parse_str("[solver]\nstatic = true\n[[probe]]\nradius = 1.0\nposition = [0, 0, 0]\n")
                .unwrap_err()
                .0;
        assert!(e.contains("[solver] static = true"), "{e}");
    }

    #[test]
    fn tool_path_times_must_increase() {
        let e = parse_str(
            "[solver]\nsteps = 1\n[tool]\nnodes = [0]\nstiffness = 1.0\npath = [[0.0, 0, 0, 0], [0.0, 1, 0, 0]]\n",
        )
        .unwrap_err()
        .0;
        assert!(e.contains("[tool] path = "), "{e}");
        assert!(e.contains("strictly increasing"), "{e}");
    }

    #[test]
    fn selection_needs_box_or_nodes() {
        let e = parse_str("[solver]\nsteps = 1\n[[fixed]]\n").unwrap_err().0;
        assert!(e.starts_with("t.toml: [[fixed]] #1: expected `box"), "{e}");
    }

    #[test]
    fn static_without_steps_is_fine() {
        let s = parse_str("[solver]\nstatic = true\nnewton_iterations = 7\n").unwrap();
        let st = s.static_solve.unwrap();
        assert_eq!(st.max_iterations, 7);
        assert_eq!(
            st.settings.cg_iterations,
            StaticSettings::default().cg_iterations
        );
    }

    #[test]
    fn unknown_method_lists_the_names() {
        let e = parse_str("[solver]\nsteps = 1\nmethod = \"svd\"\n")
            .unwrap_err()
            .0;
        assert!(
            e.contains("[solver] method = \"svd\": expected one of \"qr\""),
            "{e}"
        );
    }
}
