//! `ddgi.json`: a DDGI volume description (Majercik et al. 2019, "Dynamic
//! Diffuse Global Illumination with Ray-Traced Irradiance Fields"; the
//! RTXGI SDK's `DDGIVolumeDesc`) of a `grid:` or `relocated:` placement:
//! origin, spacing, counts, and per probe its relocation offset and its
//! classification state.
//!
//! **Grid.** The domain cut into N × M × K cells, a probe at each cell
//! centre ([`crate::placement::grid`]): probe (x, y, z) of the grid stands
//! at `origin + (x, y, z) · spacing`, `origin` the centre of the first
//! cell and `spacing` the cell size. RTXGI centres its volume instead:
//! its `origin` is our `center`, `origin + spacing · (counts − 1) / 2`.
//!
//! **Order.** Probes are listed in RTXGI's probe index order for a Y-up
//! frame (`DDGIGetProbeIndex` with `RTXGI_COORDINATE_SYSTEM_RIGHT`):
//! index = x + N·z + N·K·y, so x runs fastest, then z, then y (one
//! horizontal plane after another). `probes.json` lists grid probes x
//! fastest, then y, then z; each entry's `probe` gives its index there.
//!
//! **Offsets and states.** Relocation ([`crate::placement::relocate`])
//! moves a probe within 45% of its cell on each axis and switches off the
//! probes that stay inside geometry or see no surface within the cell
//! diagonal, which `probes.json` then leaves out. Those are RTXGI's
//! classification: a probe of `probes.json` is `active` with `offset` =
//! its position − its grid position (world units; RTXGI's probe-data
//! texture stores offset / spacing), a switched-off one `inactive` with a
//! zero offset. A plain grid is not classified: every probe is active,
//! offsets zero. Offsets below a millionth of the spacing, the f32
//! rounding of the grid's own positions, are written as 0.

use super::format::{Format, Planned};
use super::source::{Source, WorldBox};
use crate::config::params::GridParams;
use crate::placement::registry::Placement;
use serde_json::{json, Value};

/// Largest offset relocation gives, as a share of the cell, with room for
/// rounding.
const MAX_OFFSET: f64 = crate::placement::relocate::MAX_OFFSET_FRACTION as f64 + 1e-3;

/// Offsets smaller than this share of the spacing are rounding.
const ROUNDING: f64 = 1e-6;

/// `ddgi.json`.
pub struct Ddgi;

impl Format for Ddgi {
    const WORD: &'static str = "ddgi";
    const FILE: &'static str = "ddgi.json";
    const ABOUT: &'static str =
        "a DDGI volume (origin, spacing, counts, per-probe offsets and states) for `Grid` and `Relocated` placements";

    /// A volume needs a grid whose probes stay in their cells.
    fn refuses_plan(plan: &Planned) -> Option<String> {
        let grid = matches!(plan.placement, Placement::Grid(_) | Placement::Relocated(_));
        let plain = grid && !plan.refined && !plan.controlled && !plan.probes_file;
        let why = if plain {
            return None;
        } else if grid && plan.controlled {
            "fixed_probes, exclude and max_probes add probes to the grid or take cells from it"
        } else if grid {
            "refinement moves, adds and removes probes (set refine: (enabled: false), or --no-refine)"
        } else {
            "this run places by another method"
        };
        Some(format!(
            "needs a Grid or Relocated placement whose probes stay in their cells; {why}"
        ))
    }

    /// The cheap refusal, before the scene is read: a method that is no
    /// grid.
    fn refuses(source: &Source) -> Option<String> {
        match has_volume(&source.method) {
            true => None,
            false => Some(encode(source).err().unwrap_or_default()),
        }
    }

    fn encode(source: &Source, _: Option<&crate::scene::Scene>) -> Result<Vec<u8>, String> {
        encode(source)
    }
}

/// The grid of a method name, and whether it was relocated; `None` for any
/// other method (a refined grid's name ends in `+refine`).
fn grid_of(method: &str) -> Option<(GridParams, bool)> {
    let (dims, relocated) = match method.split_once(':')? {
        ("grid", d) => (d, false),
        ("relocated", d) => (d, true),
        _ => return None,
    };
    Some((GridParams::parse_dims(dims, "grid").ok()?, relocated))
}

/// Whether `method` (as `report.json` names it) has a DDGI volume.
pub fn has_volume(method: &str) -> bool {
    grid_of(method).is_some()
}

/// The DDGI volume's grid: origin (first cell centre), spacing, counts.
fn volume(domain: &WorldBox, g: &GridParams) -> ([f64; 3], [f64; 3], [u32; 3]) {
    let n = [g.cells.0 .0, g.cells.1 .0, g.cells.2 .0];
    let spacing: [f64; 3] =
        std::array::from_fn(|a| (domain.max[a] - domain.min[a]) / f64::from(n[a]));
    let origin = std::array::from_fn(|a| domain.min[a] + 0.5 * spacing[a]);
    (origin, spacing, n)
}

/// `ddgi.json` of `source`.
///
/// Contract: an error (the reason, led by the input file at fault when
/// one is) unless the
/// method is `grid:NxMxK` or `relocated:NxMxK` without refinement and each
/// probe lies within 45% of the cell of a grid position of its own;
/// otherwise one entry per grid cell in RTXGI's order, whose active
/// entries reproduce every probe's position as `origin + coords · spacing
/// + offset` (to a millionth of the spacing).
pub fn encode(source: &Source) -> Result<Vec<u8>, String> {
    let Some((grid, relocated)) = grid_of(&source.method) else {
        return Err(format!(
            "a DDGI volume needs a grid: or relocated: placement whose probes still stand in their cells; this run's is {} (place with --method relocated:NxMxK --no-refine)",
            source.method
        ));
    };
    let (origin, spacing, n) = volume(&source.domain, &grid);
    let cells = (n[0] * n[1] * n[2]) as usize;
    // RTXGI's index of grid coordinates (x, y, z), Y up.
    let rtxgi = |c: [u32; 3]| (c[0] + n[0] * c[2] + n[0] * n[2] * c[1]) as usize;
    let mut slots: Vec<Option<(usize, [f64; 3])>> = vec![None; cells];
    for (i, p) in source.probes.iter().enumerate() {
        let mut coords = [0u32; 3];
        let mut offset = [0.0f64; 3];
        for a in 0..3 {
            let t = (p.position[a] - origin[a]) / spacing[a];
            let c = t.round();
            if !(0.0..f64::from(n[a])).contains(&c) || (t - c).abs() > MAX_OFFSET {
                return Err(format!(
                    "probes.json: probe {i} lies outside every cell of the {} grid",
                    grid.dims_text()
                ));
            }
            coords[a] = c as u32;
            let o = p.position[a] - (origin[a] + c * spacing[a]);
            offset[a] = if o.abs() < ROUNDING * spacing[a] {
                0.0
            } else {
                o
            };
        }
        let slot = &mut slots[rtxgi(coords)];
        if slot.is_some() {
            return Err(format!(
                "probes.json: two probes stand in grid cell {coords:?}; they do not form the {} grid",
                grid.dims_text()
            ));
        }
        *slot = Some((i, offset));
    }
    if !relocated && source.probes.len() != cells {
        return Err(format!(
            "probes.json: has {} probes, the {} grid {cells}",
            source.probes.len(),
            grid.dims_text()
        ));
    }
    let off: u64 = ["switched_off_inside", "switched_off_no_surface"]
        .iter()
        .filter_map(|k| source.stats.get(*k).and_then(Value::as_u64))
        .sum();
    if relocated && off != (cells - source.probes.len()) as u64 {
        return Err(format!(
            "probes.json: lacks {} probes of the {} grid, but report.json counts {off} switched off",
            cells - source.probes.len(),
            grid.dims_text()
        ));
    }
    let mut entries = Vec::with_capacity(cells);
    for y in 0..n[1] {
        for z in 0..n[2] {
            for x in 0..n[0] {
                let coords = [x, y, z];
                entries.push(match slots[rtxgi(coords)] {
                    Some((i, offset)) => {
                        let mut e = json!({
                            "coords": coords, "state": "active", "offset": offset, "probe": i,
                        });
                        if let Some(light) = &source.light {
                            e["sh_l2"] = super::gltf::sh_rows(&light[i].sh.baked);
                        }
                        e
                    }
                    None => json!({
                        "coords": coords, "state": "inactive", "offset": [0.0, 0.0, 0.0], "probe": Value::Null,
                    }),
                });
            }
        }
    }
    let center: [f64; 3] =
        std::array::from_fn(|a| origin[a] + spacing[a] * f64::from(n[a] - 1) * 0.5);
    Ok(crate::encode::json::json_rows(
        &json!({
            "format": "probeplace.ddgi",
            "version": 1,
            "provenance": super::source::provenance_summary(&source.provenance),
            "method": source.method,
            "coordinate_system": "right-handed, +Y up (RTXGI_COORDINATE_SYSTEM_RIGHT)",
            "counts": n,
            "spacing": spacing,
            "origin": origin,
            "center": center,
            "index_order": "x + counts[0]*z + counts[0]*counts[2]*y",
            "active": source.probes.len(),
            "inactive": cells - source.probes.len(),
            "sh_holds": source.light.as_ref().map(|_| crate::report::sh::holds(source.direct_included)),
            "probes": entries,
        }),
        "probes",
        1,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_unrefined_grids_have_a_volume() {
        assert!(has_volume("grid:4x2x3"));
        assert!(has_volume("relocated:4x4x4"));
        assert!(!has_volume("relocated:4x4x4+refine"));
        assert!(!has_volume("sdf-skeleton+refine"));
        assert!(!has_volume("greedy:0.5"));
        assert!(!has_volume("grid:4x4"));
    }
}
