//! Where a report's figures come from, and the report as a section of a
//! documentation page.
//!
//! A figure without its machine and command cannot be checked or compared,
//! so the report opens with both ([`provenance`]). With `--page FILE` the
//! report also replaces the generated section of `FILE` (docs/bench.md)
//! between [`BEGIN`] and [`END`], so that the page's figures are those of
//! one run and nothing else ([`splice`]).

use std::fmt::Write as _;
use std::path::Path;

/// First line of the generated section of a page (the rest of the line is free).
pub const BEGIN: &str = "<!-- BEGIN bench-report";
/// Last line of the generated section of a page.
pub const END: &str = "<!-- END bench-report -->";

/// The CPU model from `/proc/cpuinfo` (`model name`, or `Hardware` /
/// `Processor` on Arm), or `unknown`.
#[must_use]
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| cpu_model_from(&s))
        .unwrap_or_else(|| "unknown".into())
}

/// The CPU model named in the text of a `/proc/cpuinfo`.
#[must_use]
pub fn cpu_model_from(cpuinfo: &str) -> Option<String> {
    ["model name", "Hardware", "Processor"]
        .iter()
        .find_map(|key| {
            cpuinfo.lines().find_map(|l| {
                let (k, v) = l.split_once(':')?;
                (k.trim() == *key && !v.trim().is_empty()).then(|| v.trim().to_string())
            })
        })
}

/// The date `days` after 1970-01-01, as `YYYY-MM-DD` (proleptic Gregorian
/// calendar; Howard Hinnant's `civil_from_days`).
#[must_use]
pub fn date_from_days(days: i64) -> String {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097); // day of the 400-year era, [0, 146096]
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // [0, 399]
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of the year from March 1
    let mp = (5 * doy + 2) / 153; // month from March, [0, 11]
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Today's date (UTC), `YYYY-MM-DD`.
#[must_use]
pub fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    date_from_days(i64::try_from(secs / 86_400).unwrap_or(0))
}

/// `args` as one shell command line, each word quoted when it needs it.
#[must_use]
pub fn shell_words(args: &[String]) -> String {
    let quote = |w: &String| {
        if !w.is_empty()
            && w.chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c))
        {
            w.clone()
        } else {
            format!("'{}'", w.replace('\'', r"'\''"))
        }
    };
    args.iter().map(quote).collect::<Vec<_>>().join(" ")
}

/// The report's opening block: the command that produced it (`args`, the
/// program's arguments), the machine, the date and how loaded the machine
/// was when the run started.
#[must_use]
pub fn provenance(args: &[String]) -> String {
    let mut s = String::new();
    let cmd = if args.is_empty() {
        "cargo run --release -p corofem-bench".to_string()
    } else {
        format!(
            "cargo run --release -p corofem-bench -- {}",
            shell_words(args)
        )
    };
    let cores = std::thread::available_parallelism().map_or(0, std::num::NonZeroUsize::get);
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".into());
    let rustc = std::process::Command::new(std::env::var("RUSTC").unwrap_or("rustc".into()))
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map_or_else(|| "unknown".into(), |v| v.trim().to_string());
    let _ = writeln!(s, "| | |\n|---|---|");
    let _ = writeln!(s, "| command | `{cmd}` |");
    let _ = writeln!(s, "| machine | {} |", cpu_model());
    let _ = writeln!(
        s,
        "| cores, system | {cores} available to the process, {} {} |",
        std::env::consts::OS,
        std::env::consts::ARCH
    );
    let _ = writeln!(s, "| load average at the start | {load} |");
    let _ = writeln!(s, "| compiler | {rustc} |");
    let _ = writeln!(
        s,
        "| core features | `full`, `std` (every method and model, AVX2 detected at run time) |"
    );
    let _ = writeln!(s, "| date (UTC) | {} |", today());
    s
}

/// `report` (a markdown document) as a section of a page: headings one
/// level down, and the SVGs it shows, `](NAME.svg)`, looked up in `svg_dir`,
/// a folder relative to the page.
#[must_use]
pub fn as_section(report: &str, svg_dir: &str) -> String {
    let mut out = String::new();
    for line in report.lines() {
        let line = if line.starts_with('#') {
            format!("#{line}")
        } else {
            images(line).iter().fold(line.to_string(), |l, name| {
                l.replace(&format!("]({name})"), &format!("]({svg_dir}/{name})"))
            })
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// The SVG files a markdown report shows, `![..](NAME.svg)`, in order.
#[must_use]
pub fn images(report: &str) -> Vec<String> {
    let mut v = Vec::new();
    for part in report.split("](").skip(1) {
        if let Some((name, _)) = part.split_once(')') {
            if name.ends_with(".svg") && !name.contains('/') && !v.iter().any(|n| n == name) {
                v.push(name.to_string());
            }
        }
    }
    v
}

/// `page` with the lines strictly between its [`BEGIN`] and [`END`] lines
/// replaced by `section`; an error if either marker is missing or out of
/// order.
pub fn splice(page: &str, section: &str) -> Result<String, String> {
    let begin = page
        .lines()
        .position(|l| l.starts_with(BEGIN))
        .ok_or_else(|| format!("no line starting with `{BEGIN}`"))?;
    let end = page
        .lines()
        .position(|l| l.trim_end() == END)
        .filter(|&e| e > begin)
        .ok_or_else(|| format!("no line `{END}` after `{BEGIN}`"))?;
    let lines: Vec<&str> = page.lines().collect();
    let mut out = String::new();
    for l in &lines[..=begin] {
        out.push_str(l);
        out.push('\n');
    }
    out.push('\n');
    out.push_str(section.trim());
    out.push_str("\n\n");
    for l in &lines[end..] {
        out.push_str(l);
        out.push('\n');
    }
    Ok(out)
}

/// Writes `report` into the generated section of `page` and copies the
/// SVGs it shows from `out` into the folder named after the page (`docs/bench/`
/// for `docs/bench.md`).
pub fn write_page(page: &Path, report: &str, out: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(page).map_err(|e| format!("{}: {e}", page.display()))?;
    let stem = page
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| format!("{}: not a file name", page.display()))?;
    let svg_dir = page.with_file_name(stem);
    std::fs::create_dir_all(&svg_dir).map_err(|e| format!("{}: {e}", svg_dir.display()))?;
    for name in images(report) {
        std::fs::copy(out.join(&name), svg_dir.join(&name))
            .map_err(|e| format!("{name} into {}: {e}", svg_dir.display()))?;
    }
    let new =
        splice(&text, &as_section(report, stem)).map_err(|e| format!("{}: {e}", page.display()))?;
    std::fs::write(page, new).map_err(|e| format!("{}: {e}", page.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        assert_eq!(date_from_days(0), "1970-01-01");
        assert_eq!(date_from_days(59), "1970-03-01");
        assert_eq!(date_from_days(11_016), "2000-02-29");
        assert_eq!(date_from_days(19_782), "2024-02-29");
        assert_eq!(date_from_days(-1), "1969-12-31");
    }

    #[test]
    fn cpu_models() {
        let x86 = "processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 9R45\n";
        assert_eq!(cpu_model_from(x86).as_deref(), Some("AMD EPYC 9R45"));
        let arm = "processor\t: 0\nBogoMIPS\t: 50.00\n\nHardware\t: BCM2835\n";
        assert_eq!(cpu_model_from(arm).as_deref(), Some("BCM2835"));
        assert_eq!(cpu_model_from("processor : 0\n"), None);
    }

    #[test]
    fn quoting() {
        let w = |v: &[&str]| shell_words(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        assert_eq!(w(&["bench", "--out", "a/b"]), "bench --out a/b");
        assert_eq!(w(&["--out", "my dir", "it's"]), r"--out 'my dir' 'it'\''s'");
    }

    #[test]
    fn section_and_splice() {
        let report =
            "# Report\n\ntext\n\n## Figure\n\n![](fig.svg)\n![x](fig.svg) [l](https://a)\n";
        let s = as_section(report, "bench");
        assert!(s.starts_with("## Report\n"));
        assert!(s.contains("### Figure\n"));
        assert!(s.contains("![](bench/fig.svg)"));
        assert!(s.contains("[l](https://a)"));
        assert_eq!(images(report), ["fig.svg"]);

        let page = format!("# Page\n\nintro\n\n{BEGIN}: generated -->\nold\nold\n{END}\n\nafter\n");
        let new = splice(&page, &s).unwrap();
        assert!(new.starts_with("# Page\n\nintro\n\n<!-- BEGIN"));
        assert!(!new.contains("old"));
        assert!(new.contains("## Report"));
        assert!(new.ends_with(&format!("{END}\n\nafter\n")));
        // Splicing twice gives the same page.
        assert_eq!(splice(&new, &s).unwrap(), new);
        assert!(splice("no markers", &s).is_err());
        assert!(splice(&format!("{END}\n{BEGIN} -->\n"), &s).is_err());
    }
}
