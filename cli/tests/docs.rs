//! The examples of the README and docs/scene-format.md run as they say:
//! the README's scene runs, and the scene-format page's example gives, line
//! for line, the result the page shows (all but the machine's times).

use std::fs;
use std::path::Path;

use crate::common::{corofem, TempDir};

/// The first fenced block of `lang` after the line `heading` in `doc`.
fn block(doc: &str, heading: &str, lang: &str) -> String {
    let text = fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(doc))
        .unwrap_or_else(|e| panic!("{doc}: {e}"));
    let after = &text[text
        .find(heading)
        .unwrap_or_else(|| panic!("{doc}: no {heading:?}"))..];
    let open = format!("```{lang}\n");
    let start = after
        .find(&open)
        .unwrap_or_else(|| panic!("{doc}: no {lang} block"))
        + open.len();
    let len = after[start..].find("```").unwrap();
    after[start..start + len].to_owned()
}

/// Runs the first toml block after `heading` in `doc` as `beam.toml` in
/// `dir`; returns the result file's text.
fn run_block(dir: &TempDir, doc: &str, heading: &str) -> String {
    dir.write("beam.toml", block(doc, heading, "toml"));
    let o = corofem(
        &["run", "beam.toml", "--out", "beam.json", "--quiet"],
        &dir.0,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fs::read_to_string(dir.path("beam.json")).unwrap()
}

#[test]
fn the_readme_scene_runs() {
    let dir = TempDir::new("readme-scene");
    let r = run_block(&dir, "README.md", "## The command-line program");
    let r: serde_json::Value = serde_json::from_str(&r).unwrap();
    assert_eq!(r["steps"], 500);
}

#[test]
fn the_scene_format_example_gives_the_result_shown() {
    let dir = TempDir::new("format-example");
    let got = run_block(&dir, "docs/scene-format.md", "## An example");
    let got: Vec<&str> = got.lines().map(str::trim).collect();
    let shown = block("docs/scene-format.md", "## The result file", "json");
    let mut checked = 0;
    for line in shown.lines().map(str::trim) {
        // `...` stands for lines left out; times are the machine's.
        if line.contains("...") || line.contains("ms_per_step") || line.contains("total_s") {
            continue;
        }
        assert!(
            got.contains(&line),
            "the page shows {line:?}, the run does not give it"
        );
        checked += 1;
    }
    assert!(checked > 20, "{checked} lines checked");
}
