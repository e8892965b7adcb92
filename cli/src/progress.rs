//! A progress bar on stderr that appears only for runs expected to take more
//! than a second, and never with `--quiet` or when stderr is not a terminal.

use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How long the run goes before the bar may appear.
const PROBE: Duration = Duration::from_millis(200);
/// Runs expected to take longer than this get a bar.
const SHOW_ABOVE: Duration = Duration::from_secs(1);

/// Progress of `total` units of work (steps or Newton iterations).
#[derive(Debug)]
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    total: u64,
    /// The bar is still hidden but may be shown.
    may_show: bool,
}

impl Progress {
    /// A hidden bar over `total` units labelled `unit`; `quiet` keeps it hidden.
    pub fn new(total: u64, unit: &str, quiet: bool) -> Progress {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
        let template =
            format!("{{bar:40}} {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, eta {{eta}}");
        if let Ok(style) = ProgressStyle::with_template(&template) {
            bar.set_style(style.progress_chars("=> "));
        }
        Progress {
            bar,
            start: Instant::now(),
            total,
            may_show: !quiet,
        }
    }

    /// `done` units are finished.
    pub fn set(&mut self, done: u64) {
        // Re-estimated at every update: early steps can be much cheaper than
        // later ones (a body in free fall before it touches anything).
        if self.may_show && done > 0 {
            let elapsed = self.start.elapsed();
            let expected = elapsed.as_secs_f64() * self.total as f64 / done as f64;
            if elapsed >= PROBE && expected > SHOW_ABOVE.as_secs_f64() {
                self.may_show = false;
                self.bar.set_draw_target(ProgressDrawTarget::stderr());
            }
        }
        self.bar.set_position(done);
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
