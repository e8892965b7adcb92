//! The command line shared by the report (`corofem-bench [bench]`) and the
//! peers example: `[--quick] [--out DIR]`, and the report's `[--page FILE]`.

use std::path::{Path, PathBuf};

/// Parsed options.
#[derive(Clone, Debug)]
pub struct ReportArgs {
    /// Shorter runs (CI).
    pub quick: bool,
    /// Output folder (created), `target/bench-report/` by default.
    pub out: PathBuf,
    /// A page whose generated section the report replaces (`--page FILE`,
    /// the report only: see `page::write_page`).
    pub page: Option<PathBuf>,
    /// The arguments as given, for the report's record of its command.
    pub words: Vec<String>,
}

/// Parses `std::env::args()`; words in `ignored` are accepted and skipped,
/// and `--page FILE` only if `page` is true. Prints `usage` and returns
/// `None` for `-h` or `--help`.
pub fn report_args(
    usage: &str,
    ignored: &[&str],
    page: bool,
) -> Result<Option<ReportArgs>, String> {
    let mut quick = false;
    let mut out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/bench-report");
    let mut page_file = None;
    let words: Vec<String> = std::env::args().skip(1).collect();
    let mut args = words.iter().cloned();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => quick = true,
            "--out" => out = args.next().ok_or("--out needs a directory")?.into(),
            "--page" if page => {
                page_file = Some(args.next().ok_or("--page needs a file")?.into());
            }
            "-h" | "--help" => {
                println!("{usage}  (default DIR target/bench-report)");
                return Ok(None);
            }
            w if ignored.contains(&w) => {}
            other => return Err(format!("unknown argument {other}")),
        }
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(Some(ReportArgs {
        quick,
        out,
        page: page_file,
        words,
    }))
}
