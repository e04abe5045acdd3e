//! Progress bars for stages that take longer than about a second.
//!
//! Bars go to stderr and only when it is a terminal (indicatif's rule), so
//! logs and CI output stay clean; `--quiet` turns them off altogether.

use indicatif::{ProgressBar, ProgressStyle};

/// Hands out progress bars, or hidden ones when quiet.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    enabled: bool,
}

impl Progress {
    /// `enabled = false` makes every bar hidden.
    pub fn new(enabled: bool) -> Progress {
        Progress { enabled }
    }

    /// No bars at all (library use, tests).
    pub fn hidden() -> Progress {
        Progress { enabled: false }
    }

    /// A bar of `len` steps labelled `label`.
    pub fn bar(&self, label: &str, len: u64) -> ProgressBar {
        if !self.enabled {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(len);
        let style = ProgressStyle::with_template("{msg:>24} [{bar:30}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        bar.set_style(style);
        bar.set_message(label.to_string());
        bar
    }
}
