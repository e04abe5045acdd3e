//! Progress bars for stages that take longer than about a second.
//!
//! Bars go to stderr and only when it is a terminal (indicatif's rule), so
//! logs and CI output stay clean; `--quiet` turns them off altogether.

use indicatif::{ProgressBar, ProgressStyle};

/// Hands out progress bars, or hidden ones when quiet.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    enabled: bool,
    lines: bool,
}

impl Default for Progress {
    /// No bars, no stage lines: library use.
    fn default() -> Self {
        Progress::hidden()
    }
}

impl Progress {
    /// `enabled = false` makes every bar hidden.
    pub fn new(enabled: bool) -> Progress {
        Progress {
            enabled,
            lines: false,
        }
    }

    /// No bars at all (library use, tests).
    pub fn hidden() -> Progress {
        Progress::new(false)
    }

    /// The same, printing one plain line per finished stage when `lines`
    /// (the command line's choice when stderr is not a terminal).
    pub fn with_lines(self, lines: bool) -> Progress {
        Progress { lines, ..self }
    }

    /// A stopwatch that prints stage lines as this progress says.
    pub fn stopwatch(&self) -> Stopwatch {
        Stopwatch::new(self.lines)
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

/// The wall times of a job's stages, by name, in the order they finished.
///
/// One type times every stage: a job wraps each stage call in
/// [`Stopwatch::time`] instead of threading a map of laps through the
/// stages' signatures. When `log` is on (stderr is not a terminal and the
/// run is not quiet), each finished stage also prints one plain line to
/// stderr, so logs show where a long run is.
#[derive(Debug, Clone)]
pub struct Stopwatch {
    laps: Vec<(String, f64)>,
    started: std::time::Instant,
    /// When the last lap ([`Stopwatch::lap`]) ended, or the start.
    last: std::time::Instant,
    log: bool,
}

impl Stopwatch {
    /// A stopwatch started now; `log` prints a line per finished stage.
    pub fn new(log: bool) -> Stopwatch {
        let now = std::time::Instant::now();
        Stopwatch {
            laps: Vec::new(),
            started: now,
            last: now,
            log,
        }
    }

    /// Records stage `name` as the time since the last lap ended (or the
    /// stopwatch started): the steps of one function, timed in turn.
    pub fn lap(&mut self, name: &str) {
        let now = std::time::Instant::now();
        self.record(name, (now - self.last).as_secs_f64() * 1e3);
        self.last = now;
    }

    /// Runs `f` as stage `name` and records its wall time.
    pub fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let t = std::time::Instant::now();
        let out = f();
        self.record(name, t.elapsed().as_secs_f64() * 1e3);
        out
    }

    /// Runs the fallible `f` as stage `name`; only a stage that succeeds
    /// prints its line (a failure's one line is the error).
    pub fn try_time<T, E>(&mut self, name: &str, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        let t = std::time::Instant::now();
        let out = f()?;
        self.record(name, t.elapsed().as_secs_f64() * 1e3);
        Ok(out)
    }

    /// Records `ms` milliseconds for stage `name` (a later record of the
    /// same name replaces the earlier one).
    pub fn record(&mut self, name: &str, ms: f64) {
        if self.log {
            eprintln!("probeplace: {name} done in {:.2} s", ms / 1e3);
        }
        match self.laps.iter_mut().find(|(n, _)| n == name) {
            Some(lap) => lap.1 = ms,
            None => self.laps.push((name.to_string(), ms)),
        }
    }

    /// Adds `other`'s laps (a product's steps) without printing them again.
    pub fn absorb(&mut self, other: &Stopwatch) {
        let log = std::mem::replace(&mut self.log, false);
        for (name, ms) in &other.laps {
            self.record(name, *ms);
        }
        self.log = log;
    }

    /// Milliseconds since the stopwatch started.
    pub fn elapsed_ms(&self) -> f64 {
        self.started.elapsed().as_secs_f64() * 1e3
    }

    /// The laps by name (ms), as reports write them.
    pub fn to_map(&self) -> std::collections::BTreeMap<String, f64> {
        self.laps.iter().cloned().collect()
    }

    /// The laps with `total` (the sum of the laps) added.
    pub fn to_map_with_total(&self) -> std::collections::BTreeMap<String, f64> {
        let mut map = self.to_map();
        map.insert("total".into(), self.laps.iter().map(|(_, ms)| ms).sum());
        map
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stopwatch_keeps_one_lap_per_name_and_sums_them() {
        let mut s = Stopwatch::new(false);
        assert_eq!(s.time("a", || 7), 7);
        s.record("b", 2.0);
        s.record("b", 3.0);
        let m = s.to_map_with_total();
        assert_eq!(m.len(), 3);
        assert_eq!(m["b"], 3.0);
        assert!((m["total"] - m["a"] - 3.0).abs() < 1e-9);
    }
}
