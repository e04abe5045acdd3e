//! `report.html` of `place`, `bake` and `render`: one self-contained page
//! with the run's figures, images and 3D view, checked in headless
//! Chromium (it loads with no error, the 3D canvas draws, hovering a probe
//! shows its figures and influence box, every table and image is there),
//! under 5 MB for Sponza, and the same bytes for the same run, timings
//! aside.

use crate::browser::{self, Loaded};
use crate::common::*;
use std::path::Path;

/// The page of `dir`, with a script that waits for the 3D view, then
/// moves the pointer over the canvas until a probe answers, and writes
/// what the info box said into `#hover-result` and the canvas's place
/// into its `data-rect`: a copy beside the page, since the run's
/// directory is shared.
fn probing_copy(dir: &Path, out: &Path) -> std::path::PathBuf {
    const PROBE: &str = "<script>(function poll(){var s=document.getElementById('v3-status');\
if(s.dataset.state!=='drawn'){setTimeout(poll,50);return;}\
var c=document.getElementById('v3-canvas'),r=c.getBoundingClientRect(),info=document.getElementById('v3-info');\
var found=function(){return info.textContent.indexOf('probe ')===0;};\
for(var y=0;y<90&&!found();y++){for(var x=0;x<160&&!found();x++){\
c.dispatchEvent(new PointerEvent('pointermove',{clientX:r.left+(x+0.5)*r.width/160,clientY:r.top+(y+0.5)*r.height/90,bubbles:true}));}}\
var o=document.createElement('pre');o.id='hover-result';\
o.dataset.rect=[r.left,r.top,r.width,r.height].map(Math.round).join(',');\
o.textContent=info.textContent;document.body.appendChild(o);})();</script>";
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let page = out.join("probing.html");
    std::fs::write(&page, html.replace("</body>", &format!("{PROBE}</body>"))).unwrap();
    page
}

/// The figures Sponza's page must hold: the run's tables.
const PLACE_TABLES: [&str; 5] = [
    "summary-table",
    "refine-table",
    "diffuse-table",
    "svo-table",
    "timings-table",
];

#[test]
fn sponza_place_page_draws_in_headless_chromium() {
    shared_scenes();
    let run = shared_job("place", "configs/sponza.ron", &[]);
    let page = run.dir.join("report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    let size = html.len();
    eprintln!("sponza place report.html: {size} bytes");
    assert!(size < 5 << 20, "report.html is {size} bytes, over 5 MB");
    browser::assert_self_contained(&html, "sponza report.html");
    let Some(chromium) = browser::chromium("sponza_place_page_draws_in_headless_chromium") else {
        return;
    };
    let work = tempfile::tempdir().unwrap();
    let probing = probing_copy(&run.dir, work.path());
    let loaded = browser::load(&chromium, &probing);
    loaded.assert_clean("sponza report.html");
    loaded.assert_view_drawn("sponza report.html");
    for id in PLACE_TABLES {
        assert!(loaded.dom.contains(&format!("id=\"{id}\"")), "no #{id}");
    }
    // Every image the run wrote is on the page, decoded.
    assert_eq!(loaded.decoded_images("sponza report.html"), 2);
    for name in ["placement.png", "atlas.png"] {
        assert!(loaded.dom.contains(&format!("alt=\"{name}\"")), "no {name}");
    }
    // The mesh is whole (Sponza is within the triangle budget) and the
    // probes are the run's.
    let r = &run.report;
    let status = loaded.text("v3-status");
    assert!(
        status.contains(&format!("{} triangles", r["scene"]["triangles"])),
        "{status}"
    );
    assert!(loaded
        .text("v3-note")
        .contains(&format!("all {} probes", r["probe_count"])));
    // Hovering a probe shows its figures and its influence box.
    let hover = loaded.text("hover-result");
    assert!(
        hover.starts_with("probe ")
            && hover.contains("clearance")
            && hover.contains("influence box"),
        "hover: {hover:?}"
    );
    // The canvas drew a picture: its region of a screenshot of the page
    // (laid out alike) is not one colour.
    let rect: Vec<u32> = loaded
        .attr("hover-result", "data-rect")
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let shot = browser::screenshot(&chromium, &page);
    assert_drawn(&shot, &rect);
}

/// The region `rect` (x, y, width, height) of `shot` is a picture: many
/// colours, and a good share of it unlike its most common colour (the
/// background).
fn assert_drawn(shot: &probeplace::raster::RgbImage, rect: &[u32]) {
    let (x0, y0) = (rect[0], rect[1]);
    let x1 = (x0 + rect[2]).min(shot.width());
    let y1 = (y0 + rect[3]).min(shot.height());
    assert!(
        x1 > x0 + 100 && y1 > y0 + 100,
        "canvas {rect:?} off the screenshot"
    );
    let mut counts = std::collections::HashMap::new();
    for y in y0..y1 {
        for x in x0..x1 {
            *counts.entry(shot.get_pixel(x, y)).or_insert(0u64) += 1;
        }
    }
    let total = ((x1 - x0) * (y1 - y0)) as u64;
    let most = counts.values().copied().max().unwrap_or(0);
    assert!(counts.len() > 50, "the canvas has {} colours", counts.len());
    assert!(
        most * 100 < 95 * total,
        "the canvas is {}% one colour",
        100 * most / total
    );
}

/// The images a page of `dir` must show: every PNG the run wrote.
fn pngs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    names.sort();
    names
}

/// The page of `dir` loads cleanly, draws its 3D view, holds `tables`,
/// and shows every PNG of the run with a caption naming it.
fn assert_run_page(chromium: &Path, dir: &Path, tables: &[&str], what: &str) -> Loaded {
    let loaded = browser::load(chromium, &dir.join("report.html"));
    loaded.assert_clean(what);
    loaded.assert_view_drawn(what);
    for id in tables {
        assert!(
            loaded.dom.contains(&format!("id=\"{id}\"")),
            "{what}: no #{id}"
        );
    }
    let images = pngs(dir);
    assert_eq!(
        loaded.decoded_images(what),
        images.len(),
        "{what}: {images:?}"
    );
    for name in &images {
        assert!(
            loaded.dom.contains(&format!("<figcaption><b>{name}</b>:")),
            "{what}: {name} has no caption"
        );
    }
    loaded
}

/// `place`, `bake --from` and `render --from --cpu` on our Cornell box at
/// test quality: each page shows every image of its run with its caption,
/// and the tables of what ran; and the same run twice gives the same page,
/// timings aside.
#[test]
fn bake_and_render_pages_show_every_image_and_repeat() {
    let config = test_quality("configs/cornell.ron", &[]);
    let d = tempfile::tempdir().unwrap();
    let (chain, again) = (d.path().join("chain"), d.path().join("again"));
    let run = |args: &[&str]| {
        let o = probeplace(args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let s = |p: &Path| p.to_str().unwrap().to_string();
    run(&["place", config.arg(), "--out", &s(&chain), "-q"]);
    run(&["place", config.arg(), "--out", &s(&again), "-q"]);
    let page = |dir: &Path| std::fs::read_to_string(dir.join("report.html")).unwrap();
    let first = page(&chain);
    assert!(
        browser::untimed(&first) == browser::untimed(&page(&again)),
        "report.html differs between two runs of the same config"
    );
    assert_ne!(browser::untimed(&first), first, "no #timings section");
    browser::assert_self_contained(&first, "cornell report.html");
    run(&["bake", "--from", &s(&chain), "-q"]);
    let Some(chromium) = browser::chromium("bake_and_render_pages_show_every_image_and_repeat")
    else {
        return;
    };
    let baked = assert_run_page(
        &chromium,
        &chain,
        &["summary-table", "svo-table", "bake-table"],
        "bake report.html",
    );
    assert!(!baked.dom.contains("id=\"render-table\""));
    // The reused placement's holes are drawn: report.json keeps them.
    let r = read_json(&chain.join("report.json"));
    let holes = r["coverage_detail"]["coverable_samples"].as_u64().unwrap()
        - r["coverage_detail"]["covered_samples"].as_u64().unwrap();
    assert!(
        baked
            .text("v3-note")
            .contains(&format!("{holes} coverage holes")),
        "{}",
        baked.text("v3-note")
    );
    run(&["render", "--from", &s(&chain), "--cpu", "-q"]);
    let rendered = assert_run_page(
        &chromium,
        &chain,
        &["summary-table", "bake-table", "render-table"],
        "render report.html",
    );
    for variant in ["hiz", "bilevel"] {
        assert!(rendered
            .dom
            .contains(&format!("alt=\"error_{variant}.png\"")));
    }
}

/// Every figure the render page shows is in the report under the name the
/// page reads it by (the page's typed reading of `report.json`, whose every
/// field is optional, shows an absent number as `–` and an absent text as
/// `?`): on the suite's shared CornellBox-Glossy render, no value cell of
/// the figure tables and no cell of the render table is either.
#[test]
fn the_render_page_finds_every_figure_it_shows() {
    shared_scenes();
    let run = shared_job("render", "configs/cornell-glossy.ron", &[]);
    let html = std::fs::read_to_string(run.dir.join("report.html")).unwrap();
    let text = |cell: &str| {
        let mut out = String::new();
        let mut tag = false;
        for c in cell.chars() {
            match c {
                '<' => tag = true,
                '>' => tag = false,
                c if !tag => out.push(c),
                _ => {}
            }
        }
        out.trim().to_string()
    };
    let mut checked = 0;
    for table in [
        "summary-table",
        "placement-table",
        "refine-table",
        "diffuse-table",
        "svo-table",
        "bake-table",
        "render-table",
    ] {
        let at = html
            .find(&format!("id=\"{table}\""))
            .unwrap_or_else(|| panic!("no {table}"));
        let body = &html[at..at + html[at..].find("</table>").unwrap()];
        for row in body.split("<tr").skip(1) {
            let cells: Vec<String> = row
                .split("<td")
                .skip(1)
                .map(|c| text(&format!("<td{c}")))
                .collect();
            // The figure tables' values are their second cell; the render
            // table's every cell but the variant's name is a figure.
            let values = if table == "render-table" {
                &cells[..]
            } else if cells.len() > 1 {
                &cells[1..2]
            } else {
                &cells[..0]
            };
            for v in values {
                assert!(
                    !v.split([' ', '(', ')', ',']).any(|w| w == "–" || w == "?"),
                    "{table}: a figure the report lacks: {row}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 40, "{checked} figures checked");
}
