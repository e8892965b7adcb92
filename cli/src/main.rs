//! `corofem`: runs corofem scenes from TOML files (results as JSON, optionally
//! a VTK time series) and describes mesh files.
//!
//! The scene and result formats are described in docs/scene-format.md and
//! summarised by `corofem run --help`.

mod info;
mod mesh_input;
mod progress;
mod result;
mod run;
mod select;
mod visual;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
// The scene file and the error type are the library part of this package
// (src/lib.rs), which the fuzz target uses too.
use corofem_cli::{error, scene_file};

use crate::result::Destination;

/// Co-rotational tetrahedral FEM scenes from the command line.
#[derive(Debug, Parser)]
#[command(name = "corofem", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene file and write the result as JSON.
    #[command(after_long_help = RUN_HELP)]
    Run {
        /// The scene (TOML). Relative paths inside it are relative to its folder.
        scene: PathBuf,
        /// Result file (JSON, "corofem-result 1"); `-` for standard output.
        /// Default: `<scene stem>.result.json` in the current directory.
        #[arg(long, value_name = "RESULT.json")]
        out: Option<PathBuf>,
        /// Also write a VTK time series into DIR: one .vtu frame per history
        /// record and series.pvd to open in ParaView (and, with a [visual]
        /// surface, its frames and surface.pvd beside them).
        #[arg(long, value_name = "DIR")]
        vtk: Option<PathBuf>,
        /// No progress bar, notes or summary on stderr (errors still appear).
        #[arg(long, short)]
        quiet: bool,
    },
    /// Print counts, bounding box, volumes, quality and orientation of a mesh
    /// file (.tetmesh, Gmsh .msh, .vtk, .vtu), or counts, bounding box and
    /// closedness of a surface file (.obj, .stl).
    Info {
        /// The mesh or surface file.
        mesh: PathBuf,
    },
}

const RUN_HELP: &str = "\
The scene file (TOML) and the result file (JSON) are described key by key in
docs/scene-format.md. Among the scene keys:
  [mesh]   reorient = true          swap nodes of negatively oriented tets instead of
                                    rejecting the mesh (default false)
  [solver] warm_start = false       start CG cold instead of from the previous step's
                                    solution (the guess costs nothing; steps with ground
                                    contacts, and steps after a solve that needed more than
                                    its budget, start cold; default on with \"two-level\" and
                                    \"block-jacobi\", off with \"mass\")
  [solver] energy_guard = false     turn off the energy guard (on by default): a step that
                                    finds the body with more energy than the last step left
                                    it, while no tool or ground held it and elements were
                                    inverted, first takes the excess out of its deformation
                                    velocity (momentum kept)
  [solver] preconditioner = \"mass\"  what preconditions CG: \"two-level\" (the default: node
                                    blocks plus rigid-body modes of node aggregates, turned
                                    with the body), \"block-jacobi\" (3x3 node blocks of the
                                    system matrix) or \"mass\" (the lumped mass, the paper's
                                    CG); it sets the defaults of cg_iterations and warm_start
  [solver] newton_iterations = 30   static solve: most Newton iterations
  [solver] newton_tolerance = 1e-5  static solve: out-of-balance force / load to stop at; it
                                    also stops when an update moves the body by at most 1e-4
                                    of its displacement and its CG solve reached cg_tolerance
  [visual] file = \"skin.obj\"       a detailed surface (.obj or .stl, in the mesh file's
                                    coordinates) carried by the tetrahedra; the result gets
                                    visual.final_positions, --vtk writes surface.pvd too
  [visual] reach = 0.002            how far outside the tetrahedra a vertex may lie (m;
                                    default half their mean edge length)
  [[probe]] radius = 0.01           a rigid sphere (or shape = \"capsule\" with half_length
            position = [x, y, z]    and axis) the body cannot enter, moving along path =
            path = [[t, dx, dy, dz]] [[t, dx, dy, dz], ...]; history gets probe_forces,
                                    contacts and support_force (fixed nodes and ground)
Defaults: [material] young 1e6, poisson 0.3, density 1000; [solver] method
\"qr-invertible\" (QR's bits wherever no element is inverted), dt 0.001,
preconditioner \"two-level\" with cg_iterations 4 and warm_start true (\"mass\": 5, false;
400 iterations for a static solve), cg_tolerance 0 (1e-4 static), no damping,
energy_guard true; [world] gravity [0, 0, -9.81]; [output] every 10;
[tool] path [[0, 0, 0, 0]].

Result of a static solve: \"steps\" counts Newton iterations, \"static\" gives
\"converged\", the rule met (\"met\": \"force\", \"update\" or null) and each rule's value
against its tolerance; each history record adds \"newton_residual\" and \"newton_update\",
its \"step\" is the iteration count, \"t\" is 0. timing.total_s is the wall time of the stepping loop
including diagnostics and VTK output.

The result file is written whole at the end (temporary file + rename): a failed run
leaves none. Exit status: 0 on success, 1 on any error, 2 on bad command-line usage.";

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Run {
            scene,
            out,
            vtk,
            quiet,
        } => {
            let out = match out {
                Some(p) if p.as_os_str() == "-" => Destination::Stdout,
                Some(p) => Destination::File(p),
                None => Destination::File(default_result_path(&scene)),
            };
            run::run(&run::RunOptions {
                scene,
                out,
                vtk,
                quiet,
            })
        }
        Command::Info { mesh } => info::info(&mesh),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `<scene stem>.result.json` in the current directory.
fn default_result_path(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    PathBuf::from(format!("{stem}.result.json"))
}
