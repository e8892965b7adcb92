//! `corofem`: runs corofem scenes from TOML files (results as JSON, optionally
//! a VTK time series) and describes mesh files.
//!
//! The scene and result formats are described in docs/scene-format.md and
//! listed key by key, with defaults, by `corofem run --help`.

mod info;
mod mesh_input;
mod plot;
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
    #[command(after_long_help = run_help())]
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
    /// Draw a result's history as an SVG: energies, forces (support, tool,
    /// probes), contacts and CG iterations over time.
    Plot {
        /// The result file (JSON) that `corofem run` wrote.
        result: PathBuf,
        /// The picture. Default: the result's path with the extension .svg.
        #[arg(long, value_name = "FILE.svg")]
        out: Option<PathBuf>,
    },
    /// Print counts, bounding box, volumes, quality and orientation of a mesh
    /// file (.tetmesh, Gmsh .msh, .vtk, .vtu), or counts, bounding box and
    /// closedness of a surface file (.obj, .stl).
    Info {
        /// The mesh or surface file.
        mesh: PathBuf,
    },
}

/// The text after `corofem run --help`'s options: every scene key with its
/// default (from the parser's own table), then the result and exit status.
fn run_help() -> String {
    format!(
        "Scene keys, with their defaults (docs/scene-format.md gives each in full, \
         docs/choosing-settings.md how to choose the solver's):\n\n{}\n{RUN_HELP_TAIL}",
        scene_file::keys_help()
    )
}

const RUN_HELP_TAIL: &str = "\
With \"mass\" (the paper's CG) cg_iterations defaults to 5 and warm_start to false; a
static solve runs 400 CG iterations to cg_tolerance 1e-4 per Newton iteration and ignores
dt, steps, [initial], the ground, [[material_change]] and [tool] release.

Result of a static solve: \"steps\" counts Newton iterations; \"static\" gives
\"converged\" (the out-of-balance force of the final shape, \"force\", is at most
newton_tolerance), the rule that stopped the iterations (\"met\": \"force\", \"update\" or
null) and each rule's value against its tolerance; each history record adds
\"newton_residual\" and \"newton_update\", its \"step\" is the iteration count, \"t\" is 0.
timing.total_s is the wall time of the stepping loop including diagnostics and VTK output.

The result file is written whole at the end (temporary file + rename): a failed run
leaves none. `corofem plot RESULT.json` draws its history. Exit status: 0 on success,
1 on any error, 2 on bad command-line usage.";

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
        Command::Plot { result, out } => plot::plot(&result, out.as_deref()).map(|path| {
            eprintln!("wrote {}", path.display());
        }),
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
