//! What the command line prints while it works: the log sink (stderr, above the
//! progress line) and the progress line itself.

use super::*;

/// Log sink: prints to stderr unless quiet (above the progress line when there is one).
pub(super) struct Log {
    pub(super) quiet: bool,
    pub(super) bar: Option<indicatif::ProgressBar>,
}

impl Log {
    pub(super) fn say(&self, msg: impl AsRef<str>) {
        if self.quiet {
            return;
        }
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{}", msg.as_ref())),
            None => eprintln!("{}", msg.as_ref()),
        }
    }

    /// Prints every line, the progress line hidden once for all of them.
    pub(super) fn say_all(&self, lines: &[String]) {
        if self.quiet {
            return;
        }
        let print = || {
            for line in lines {
                eprintln!("{line}");
            }
        };
        match &self.bar {
            Some(b) => b.suspend(print),
            None => print(),
        }
    }
}

/// The progress line of the main job on stderr, rewritten in place (at most 20 times a
/// second): the stage, a bar and its percentage, the surfaces when the stage goes surface by
/// surface, and the time since the start, e.g.
/// `matching   [##############                ]  48%  surface 1/1  3s`. Only on a terminal
/// and without `--quiet` (`None` otherwise: nothing is drawn, no callback is installed).
pub(super) fn progress_bar(quiet: bool) -> Option<indicatif::ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(1);
    // one message holds the line but the clock, so a report is one redraw; the clock is
    // redrawn by the ticker when no report comes
    b.set_style(
        indicatif::ProgressStyle::with_template(PROGRESS_TEMPLATE)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    b.enable_steady_tick(std::time::Duration::from_millis(500));
    Some(b)
}

/// The progress line's template: [`progress_line`], then the elapsed time.
pub(super) const PROGRESS_TEMPLATE: &str = "{msg}  {elapsed}";

/// Shows `p` on the progress line. The reports that start or end a stage are drawn at
/// once, so every stage shows 0% and 100% (the others are drawn at most 20 times a second,
/// and one that comes too soon after the last drawn is left to the next).
pub(super) fn show_progress(b: &indicatif::ProgressBar, p: &crate::Progress) {
    b.set_message(progress_line(p));
    if p.done == 0 || p.done == p.total {
        b.force_draw();
    }
}

/// The progress line of `p` (see [`progress_bar`]).
pub(super) fn progress_line(p: &crate::Progress) -> String {
    const WIDTH: usize = 30;
    let label = match p.stage {
        crate::Stage::Read => "reading",
        crate::Stage::Topology => "topology",
        crate::Stage::Graph => "graph",
        crate::Stage::Matching => "matching",
        crate::Stage::Refine => "refining",
        crate::Stage::Optimize => "optimizing",
        crate::Stage::Check => "checking",
        crate::Stage::Write => "writing",
    };
    let f = p.fraction();
    let filled = ((f * WIDTH as f64) as usize).min(WIDTH);
    let surfaces = match p.surfaces {
        0 => String::new(),
        1 => "  surface 1/1".to_string(),
        n => format!("  {}/{n} surfaces done", p.surfaces_done),
    };
    format!(
        "{label:<10} [{}{}] {:>3}%{surfaces}",
        "#".repeat(filled),
        " ".repeat(WIDTH - filled),
        (f * 100.0) as u32
    )
}
