//! Headless Chromium for the tests of the HTML reports: finding it (or
//! skipping visibly, except under CI), loading a page offline and reading
//! the DOM it built, its console and its own error log, and screenshots.
//!
//! WebGL: headless Chromium without a GPU draws WebGL with SwiftShader;
//! recent versions want `--enable-unsafe-swiftshader` for it (older ones
//! ignore the flag), and `--disable-gpu` keeps every run on that path.

use std::path::{Path, PathBuf};

/// Chromium, or why there is none: skipping is visible, and fails under CI.
pub fn chromium(test: &str) -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        let found = std::process::Command::new("which")
            .arg(name)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
        if found.is_some() {
            return found;
        }
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: headless Chromium is required under CI (.ci/run installs it)"
    );
    eprintln!("SKIPPED {test}: no chromium on PATH");
    None
}

/// The window every page is laid out in, so that a screenshot and a DOM
/// dump of one page agree on where things are.
pub const WINDOW: (u32, u32) = (1280, 1600);

/// Runs Chromium headless on `page` (offline, a fresh profile) with `what`
/// (`--dump-dom` or `--screenshot=…`); returns stdout and stderr.
fn run(chromium: &Path, page: &Path, what: &str) -> (String, String) {
    let profile = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--enable-unsafe-swiftshader",
            "--no-first-run",
            "--disable-extensions",
            "--disable-dev-shm-usage",
            "--virtual-time-budget=20000",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--window-size={},{}", WINDOW.0, WINDOW.1))
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(what)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "chromium failed: {stderr}");
    (String::from_utf8_lossy(&o.stdout).into_owned(), stderr)
}

/// A page as Chromium built it after its load event and scripts.
pub struct Loaded {
    /// The DOM, serialized.
    pub dom: String,
    /// Chromium's log, console messages included.
    pub log: String,
}

impl Loaded {
    /// The value of `attr` on the element with `id`, if any.
    pub fn attr(&self, id: &str, attr: &str) -> Option<String> {
        let start = self.dom.find(&format!("id=\"{id}\""))?;
        let open = self.dom[..start].rfind('<')?;
        let tag = &self.dom[open..open + self.dom[open..].find('>')?];
        let key = format!("{attr}=\"");
        let at = tag.find(&key)? + key.len();
        Some(tag[at..at + tag[at..].find('"')?].to_string())
    }

    /// The text of the element with `id` up to its first child or end tag.
    pub fn text(&self, id: &str) -> String {
        self.dom
            .split(&format!("id=\"{id}\""))
            .nth(1)
            .and_then(|s| s.split('>').nth(1))
            .and_then(|s| s.split('<').next())
            .unwrap_or_default()
            .to_string()
    }

    /// The page loaded cleanly: no uncaught error in the console, and its
    /// own error log (`#page-errors`: script errors, failed or refused
    /// loads, `console.error`) empty.
    pub fn assert_clean(&self, page: &str) {
        let uncaught: Vec<&str> = self
            .log
            .lines()
            .filter(|l| l.contains("Uncaught"))
            .collect();
        assert!(uncaught.is_empty(), "{page}: {uncaught:?}");
        assert_eq!(
            self.attr("page-errors", "data-count").as_deref(),
            Some("0"),
            "{page}: the page logged errors: {}",
            self.text("page-errors")
        );
    }

    /// The 3D view drew its first frame.
    pub fn assert_view_drawn(&self, page: &str) {
        assert_eq!(
            self.attr("v3-status", "data-state").as_deref(),
            Some("drawn"),
            "{page}: {}",
            self.text("v3-status")
        );
    }

    /// Every image of the page decoded, by the page's own count; returns it.
    pub fn decoded_images(&self, page: &str) -> usize {
        let (decoded, total) = (
            self.attr("figures", "data-decoded"),
            self.attr("figures", "data-total"),
        );
        assert_eq!(decoded, total, "{page}: {}", self.text("figures"));
        decoded.and_then(|d| d.parse().ok()).unwrap_or(0)
    }
}

/// Loads `page` and returns its DOM and log.
pub fn load(chromium: &Path, page: &Path) -> Loaded {
    let (dom, log) = run(chromium, page, "--dump-dom");
    Loaded { dom, log }
}

/// A screenshot of `page` in [`WINDOW`].
pub fn screenshot(chromium: &Path, page: &Path) -> probeplace::raster::RgbImage {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("shot.png");
    run(chromium, page, &format!("--screenshot={}", png.display()));
    crate::common::read_png(&png)
}

/// `html` without its `#timings` section: what differs between two runs of
/// the same inputs (as `timings_ms` and `reused` in `report.json`).
pub fn untimed(html: &str) -> String {
    let Some(start) = html.find("<section id=\"timings\">") else {
        return html.to_string();
    };
    let end = html[start..]
        .find("</section>")
        .map_or(html.len(), |e| start + e + "</section>".len());
    format!("{}{}", &html[..start], &html[end..])
}

/// No part of `html` fetches anything: no remote sources, links, style
/// URLs or imports, and the page's content policy forbids every fetch.
pub fn assert_self_contained(html: &str, page: &str) {
    for remote in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(!html.contains(remote), "{page} refers to {remote}…");
    }
    assert!(
        html.contains("Content-Security-Policy\" content=\"default-src 'none';"),
        "{page} has no content policy"
    );
}
