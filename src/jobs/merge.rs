//! The `merge` job: joins the placed tiles of a split ([`super::split`])
//! into one world, without ever loading the whole world (except for
//! `--single`, which asks for it).
//!
//! 1. **Check.** Every tile must have finished, and its outputs must carry
//!    the provenance `split.json` recorded for it (config hash, scene hash,
//!    seed, tool): a missing, failed or foreign tile is refused with a line
//!    naming it, never merged into a partial world.
//! 2. **Offer.** Each tile placed probes over its box, core and margin,
//!    crediting them only with its core's surfaces, so near every cut two
//!    tiles kept probes where one would serve both, and the union holds no
//!    set as small as one machine's (on Dabrovic Sponza, an exact cover of
//!    the tiles' 93 probes needs 60 where one machine places 51). Tile by
//!    tile (one in memory at a time), the core therefore also offers the
//!    positions refinement fills from ([`Tile::offers`]).
//! 3. **Join.** Tile by tile again, the coverage measure of the tile's own
//!    run ([`crate::coverage`]: the same samples, the same `sees` rule)
//!    lists, for each coverable sample of its core, every probe and
//!    offered position inside the tile's box that sees it (those in
//!    overlaps of boxes are the report's `candidates`). [`crate::refine::cover::cover`] keeps
//!    the fewest that still reach the coverage target: the fill and
//!    redundancy pruning of refinement (Wang et al. 2019 §1, "fewest
//!    probes") over the whole world, then pairs swapped for one and a
//!    local search for a smaller cover.
//!    Coverage is what the kept probes see, summed over the cores.
//! 4. **Check.** The cover fitted the tiles' training samples; tile by
//!    tile again, a fresh stream's core samples the kept probes miss are
//!    listed with the positions that see them, and filled from
//!    ([`crate::refine::holdout::fill_round`]), for at most [`CHECK_ROUNDS`] rounds: one machine's
//!    [`crate::refine::holdout`] over the whole world.
//! 5. **Index.** Tile by tile again, the SVO of the tile's box is baked
//!    over the kept probes inside it and its leaves renumbered to the
//!    world's probe indices: `tile-NNN.svo.bin`, one per region, as
//!    engines stream probe volumes. `world.json` lists each tile's core
//!    box, box, probe index range (probes are numbered tile by tile, by the
//!    core that holds them) and file. `--single` also bakes one SVO over
//!    the whole domain (`svo.bin`), for a world that fits one machine.
//!    The same pass measures the report's `coverage` on each core's
//!    validation stream, which no step saw, and each probe by its own rays.

use super::outcome::Outcome;
use super::split::{SplitIndex, TileEntry};
use crate::config::Config;
use crate::coverage::{CoverageReference, Stream};
use crate::error::{Error, Result};
use crate::output::commit::{self, OutputSet};
use crate::placement::controls::Controls;
use crate::probes::{Probe, ProbeSet};
use crate::progress::Progress;
use crate::provenance::{Overrides, Provenance};
use crate::scene::raycast::Blocker;
use crate::sdf::VoxelClass;
use crate::stages::{self, Prepared};
use crate::tiles::TileGrid;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What the command line gives `merge`.
#[derive(Debug, Clone)]
pub struct MergeOptions {
    /// The split directory.
    pub dir: PathBuf,
    /// Output directory (default: `DIR/world`).
    pub out: Option<PathBuf>,
    /// Also bake one SVO over the whole world.
    pub single: bool,
    /// Progress and stage lines.
    pub progress: Progress,
}

/// A probe of some tile, in world coordinates.
#[derive(Debug, Clone, Copy)]
struct WorldProbe {
    position: DVec3,
    /// The tile whose run placed it.
    source: u32,
    /// The tile whose core holds it.
    owner: u32,
    /// Whether more than one tile's box holds it.
    candidate: bool,
    /// Whether the merge offered this position (a coverage reference point
    /// of its owner's core) rather than a tile placing a probe there.
    offered: bool,
    /// The fill tier of the position: the first of its tile's clearances
    /// it keeps ([`Tile::tier_of`] for a tile's own probe).
    tier: u8,
}

/// One probe in the merged `probes.json`.
#[derive(Debug, Serialize)]
struct MergedProbe {
    index: usize,
    position: [f64; 3],
    position_file: [f64; 3],
    clearance: f32,
    voxel_class: Option<VoxelClass>,
    tile: String,
    placed_by: String,
}

/// What the first pass learned of one tile's core.
#[derive(Debug, Default, Clone, Serialize)]
struct TileTally {
    name: String,
    probes_placed: usize,
    /// Positions its core offered ([`Tile::offers`]).
    positions_offered: usize,
    coverable_samples: usize,
    /// Coverable core samples some probe of the union sees.
    seen: usize,
    /// Core samples no probe of the union sees.
    unseen: usize,
    /// Coverable core samples of the validation stream.
    validation_samples: usize,
    /// Of them, those a kept probe sees.
    validation_covered: usize,
}

/// Runs `probeplace merge`.
///
/// Contract: on success the output directory holds exactly `world.json`,
/// `probes.json`, `report.json`, `<tile>.svo.bin` per tile (and
/// `svo.bin` with `single`), all of the world's provenance; on any error
/// it is as it was. A tile without a finished run, or whose run does not
/// carry the provenance `split.json` gives it, is a user error naming the
/// tile.
pub fn merge(options: &MergeOptions) -> Result<Outcome> {
    let watch_start = std::time::Instant::now();
    let dir = &options.dir;
    let index_path = dir.join("split.json");
    if !index_path.is_file() {
        return Err(Error::user_file(
            dir,
            "no split.json: not a split directory, or the split was cut short; run probeplace split",
        ));
    }
    let text = crate::input::read_text(&index_path, "split.json", 1 << 30)?;
    let index: SplitIndex =
        serde_json::from_str(&text).map_err(|e| Error::user_file(&index_path, e))?;
    if index.format != "probeplace.split" || index.tile.is_empty() {
        return Err(Error::user_file(
            &index_path,
            "is not a probeplace split index",
        ));
    }
    // Where the merged world goes, checked before any work: not the split
    // directory, nor above it, nor inside a tile.
    let out = options.out.clone().unwrap_or_else(|| dir.join("world"));
    let inputs = [index.config.clone(), index_path.clone()];
    super::split::check_outside_tiles(&out, None)?;
    let claim = commit::claim(&out, &inputs)?;
    let grid = index.grid();
    let mut probes: Vec<WorldProbe> = Vec::new();
    let mut placed = vec![0usize; index.tile.len()];
    let mut tiers_of = Vec::new();
    // A tile whose box no triangle touches has nothing to place, no
    // surface to demand views of and no SVO; `tile.sh` skips it.
    let empty = |t: u32| index.tile[t as usize].is_empty();
    for entry in &index.tile {
        let (positions, tiers) = if empty(entry.index) {
            (Vec::new(), None)
        } else {
            tile_probes(dir, &index, entry)?
        };
        tiers_of.push(tiers);
        for position in positions {
            placed[entry.index as usize] += 1;
            probes.push(WorldProbe {
                position,
                source: entry.index,
                owner: grid.owner(position),
                candidate: index
                    .tile
                    .iter()
                    .filter(|t| t.domain.contains(position))
                    .count()
                    > 1,
                offered: false,
                tier: 0,
            });
        }
    }
    let progress = &options.progress;

    // Each pass prepares its tiles one at a time; the last tile of a pass
    // is the first of the next (the join runs backwards), and is carried
    // over rather than prepared again: two preparations fewer, and never
    // more than one tile in memory.
    let mut carried: Option<(u32, Tile)> = None;

    // Pass 1 (offer): the positions each core offers besides the tiles' probes.
    let mut offered = vec![0usize; index.tile.len()];
    for (entry, tiers) in index.tile.iter().zip(&tiers_of) {
        let Some(tiers) = tiers else {
            continue;
        };
        let tile = Tile::take_or_prepare(&mut carried, dir, entry, progress)?;
        // The tile's own probes by the same measure: those its filling
        // added from a lower tier stand nearer a surface than the first.
        for p in probes
            .iter_mut()
            .filter(|p| p.source == entry.index && !p.offered)
        {
            p.tier = tile.tier_of(p.position, tiers);
        }
        for (position, tier) in tile.offers(&grid, entry.index, tiers) {
            offered[entry.index as usize] += 1;
            probes.push(WorldProbe {
                position,
                source: entry.index,
                owner: entry.index,
                candidate: false,
                offered: true,
                tier,
            });
        }
        carried = Some((entry.index, tile));
    }

    // Pass 2 (join): per core, the settled samples and the candidates that see
    // each unsettled one. Backwards, then put in tile order.
    let mut joined: Vec<Option<(TileTally, Vec<Vec<u32>>)>> =
        (0..index.tile.len()).map(|_| None).collect();
    for (slot, entry) in joined.iter_mut().zip(&index.tile).rev() {
        if empty(entry.index) {
            let tally = TileTally {
                name: entry.name.clone(),
                ..TileTally::default()
            };
            *slot = Some((tally, Vec::new()));
            continue;
        }
        let tile = Tile::take_or_prepare(&mut carried, dir, entry, progress)?;
        let relevant = tile.relevant(&probes, entry);
        let samples = tile.core_samples(&tile.reference, &grid, entry.index);
        let seen = tile.lists(&tile.reference, &samples, &relevant);
        let mut tally = TileTally {
            name: entry.name.clone(),
            probes_placed: placed[entry.index as usize],
            positions_offered: offered[entry.index as usize],
            coverable_samples: samples.len(),
            ..TileTally::default()
        };
        let mut kept_lists = Vec::new();
        for l in seen {
            if l.is_empty() {
                tally.unseen += 1;
            } else {
                tally.seen += 1;
                kept_lists.push(l);
            }
        }
        *slot = Some((tally, kept_lists));
        carried = Some((entry.index, tile));
    }
    let mut tallies = Vec::new();
    let mut lists: Vec<Vec<u32>> = Vec::new();
    for (tally, l) in joined.into_iter().flatten() {
        tallies.push(tally);
        lists.extend(l);
    }
    let coverable_all: usize = tallies.iter().map(|t| t.coverable_samples).sum();
    let world_config = Config::from_text(&index.world.config_text, &index.config)?;
    let target = world_config.refine.coverage_target.0 as f64;
    let need = ((target * coverable_all as f64).ceil() as usize).min(lists.len());
    // Refinement's tier rule: a position of a lower tier (nearer a
    // surface) serves only samples no position of a higher tier sees.
    let tier: Vec<u8> = probes.iter().map(|p| p.tier).collect();
    let mut kept = crate::refine::cover::cover(probes.len(), &lists, &tier, need);

    // Passes 3… (check rounds): per core, a fresh stream's samples the
    // kept probes miss, and the candidates that see each; filled from.
    let mut rounds = Vec::new();
    for round in 0..CHECK_ROUNDS {
        // From the tile carried over, so that it is not prepared again.
        let forward = carried.as_ref().is_none_or(|(i, _)| *i == 0);
        let order: Vec<&TileEntry> = if forward {
            index.tile.iter().collect()
        } else {
            index.tile.iter().rev().collect()
        };
        let (mut coverable, mut covered, mut holes) = (0, 0, Vec::new());
        for entry in order.into_iter().filter(|e| !empty(e.index)) {
            let tile = Tile::take_or_prepare(&mut carried, dir, entry, progress)?;
            let check = tile.resampled(Stream::Check(round), progress);
            let core = tile.core_samples(&check, &grid, entry.index);
            let relevant = tile.relevant(&probes, entry);
            let (missed, seen) = tile.missed(&check, &core, &relevant, &kept);
            coverable += core.len();
            covered += seen;
            holes.extend(tile.lists(&check, &missed, &relevant));
            carried = Some((entry.index, tile));
        }
        let record = crate::refine::holdout::fill_round(
            round,
            (coverable, covered, &holes),
            &mut kept,
            &tier,
            target,
        );
        rounds.push(record);
        if record.is_last(target) {
            break;
        }
    }

    // The world's probes, numbered tile by tile by the core that holds them.
    let mut order: Vec<usize> = (0..probes.len()).filter(|&k| kept[k]).collect();
    order.sort_by_key(|&k| (probes[k].owner, k));
    let final_probes: Vec<WorldProbe> = order.iter().map(|&k| probes[k]).collect();

    // The last pass (index): per tile, its SVO over the world's indices, the
    // validation figure of its core, and the rays' and the SDF's word on the
    // probes its core holds.
    let provenance = index.world.clone();
    let mut set = OutputSet::of(&provenance);
    let mut records: Vec<Option<MergedProbe>> = (0..final_probes.len()).map(|_| None).collect();
    let mut world_tiles = Vec::new();
    // Probes in solid by their own rays, outside the scene and in solid by
    // the tile's SDF.
    let mut health = (0usize, 0usize, 0usize);
    for entry in &index.tile {
        let owned: Vec<usize> = (0..final_probes.len())
            .filter(|&g| final_probes[g].owner == entry.index)
            .collect();
        let first = owned.first().copied().unwrap_or(
            final_probes
                .iter()
                .position(|p| p.owner > entry.index)
                .unwrap_or(final_probes.len()),
        );
        let mut world_tile = json!({
            "name": entry.name,
            "index": entry.index,
            "cell": entry.cell,
            "core": entry.core,
            "domain": entry.domain,
            "probes": { "first": first, "count": owned.len() },
            "svo": Value::Null,
        });
        if empty(entry.index) {
            world_tiles.push(world_tile);
            continue;
        }
        let tile = Tile::take_or_prepare(&mut carried, dir, entry, progress)?;
        let scene = &tile.prepared.scene;
        let inside: Vec<usize> = (0..final_probes.len())
            .filter(|&g| entry.domain.contains(final_probes[g].position))
            .collect();
        let set_here = probe_set(
            inside
                .iter()
                .map(|&g| scene.to_local(final_probes[g].position)),
        );
        let input = tile.prepared.placement_input(tile.config.seed, progress);
        let mut svo = crate::svo::bake(&tile.config.svo, &set_here, &input)
            .map_err(|e| tile_error(entry, e))?
            .svo;
        let global: Vec<u32> = inside.iter().map(|&g| g as u32).collect();
        svo.renumber(&global, final_probes.len() as u32);
        svo.provenance = provenance.to_bytes();
        let file = format!("{}.svo.bin", entry.name);
        set.add(file.clone(), svo.to_bytes());
        // The validation stream: the core's fresh samples, seen by a kept
        // probe in the tile's box.
        let validation = tile.resampled(Stream::Validation, progress);
        let core = tile.core_samples(&validation, &grid, entry.index);
        let viewers: Vec<(usize, glam::Vec3)> = inside
            .iter()
            .map(|&g| (g, scene.to_local(final_probes[g].position)))
            .collect();
        let all_kept = vec![true; final_probes.len()];
        let (_, seen) = tile.missed(&validation, &core, &viewers, &all_kept);
        if let Some(tally) = tallies.get_mut(entry.index as usize) {
            tally.validation_samples = core.len();
            tally.validation_covered = seen;
        }
        let sdf = &tile.prepared.sdf;
        // The probes its core holds, and those it placed in the core of a
        // tile without triangles, which has no SDF of its own to ask.
        let described = (0..final_probes.len()).filter(|&g| {
            let p = &final_probes[g];
            p.owner == entry.index || (empty(p.owner) && p.source == entry.index)
        });
        for g in described {
            let p = scene.to_local(final_probes[g].position);
            let voxel = sdf.voxel_at(p);
            let class = voxel.map(|v| sdf.class[v]);
            match class {
                Some(VoxelClass::Solid) => health.2 += 1,
                Some(VoxelClass::Outside) => health.1 += 1,
                _ => {}
            }
            if !crate::coverage::stands_free(&tile.prepared.bvh, sdf.voxel_size, p) {
                health.0 += 1;
            }
            let world = final_probes[g].position;
            let config = &tile.world_config;
            records[g] = Some(MergedProbe {
                index: g,
                position: world.to_array(),
                position_file: crate::scene::world_to_file(world, config.scale.0, config.up)
                    .to_array(),
                clearance: voxel.map_or(f32::NAN, |v| sdf.distance[v]),
                voxel_class: class,
                tile: index.tile[final_probes[g].owner as usize].name.clone(),
                placed_by: if final_probes[g].offered {
                    "merge".to_string()
                } else {
                    index.tile[final_probes[g].source as usize].name.clone()
                },
            });
        }
        world_tile["svo"] = json!(file);
        world_tiles.push(world_tile);
    }
    let records: Vec<MergedProbe> = records.into_iter().flatten().collect();
    if options.single {
        let world = single_world(&index, progress)?;
        let set_all = probe_set(
            final_probes
                .iter()
                .map(|p| world.scene.to_local(p.position)),
        );
        let input = world.placement_input(index.seed, progress);
        let mut svo = crate::svo::bake(&world_config.svo, &set_all, &input)?.svo;
        svo.provenance = provenance.to_bytes();
        set.add("svo.bin", svo.to_bytes());
    }

    // The training figure: the samples the cover fitted.
    let coverable: usize = tallies.iter().map(|t| t.coverable_samples).sum();
    let covered = lists
        .iter()
        .filter(|l| l.iter().any(|&k| kept[k as usize]))
        .count();
    // Nothing coverable in any core: nothing is missed.
    let ratio = |covered: usize, coverable: usize| match coverable {
        0 => (1.0, 0.0),
        n => crate::coverage::ratio_ci95(covered, n),
    };
    let (coverage_train, _) = ratio(covered, coverable);
    // What the report prints: the validation stream, never shown to the cover.
    let validation_coverable: usize = tallies.iter().map(|t| t.validation_samples).sum();
    let validation_covered: usize = tallies.iter().map(|t| t.validation_covered).sum();
    let (coverage, ci95) = ratio(validation_covered, validation_coverable);
    let candidates = probes.iter().filter(|p| p.candidate).count();
    let offered_all: usize = offered.iter().sum();
    let offered_kept = final_probes.iter().filter(|p| p.offered).count();
    let mut warnings = Vec::new();
    if coverage + ci95 < target {
        warnings.push(format!(
            "coverage {:.2}% ± {:.2}% on unseen samples is under refine.coverage_target {:.2}%: some core surfaces are seen by no tile's probe (a larger --margin sees more of them from both sides)",
            100.0 * coverage,
            100.0 * ci95,
            100.0 * target
        ));
    }
    let world_json = json!({
        "format": "probeplace.world",
        "version": 1,
        "provenance": provenance,
        "domain": index.domain,
        "tiles_grid": index.tiles,
        "margin": index.margin,
        "probe_count": final_probes.len(),
        "probes": "probes.json",
        "svo": options.single.then_some("svo.bin"),
        "tiles": world_tiles,
    });
    let report = json!({
        "format": "probeplace.report",
        "version": 1,
        "provenance": provenance,
        "method": "tiles",
        "seed": index.seed,
        "probe_count": final_probes.len(),
        "coverage": coverage,
        "coverage_ci95": ci95,
        "coverage_train": coverage_train,
        "probes_in_solid": health.0,
        "probes_in_solid_sdf": health.2,
        "probes_outside_scene": health.1,
        "merge": {
            "tiles": index.tile.len(),
            "probes_placed": probes.len() - offered_all,
            "offered": offered_all,
            "offered_kept": offered_kept,
            "candidates": candidates,
            "candidates_kept": order.iter().filter(|&&k| probes[k].candidate).count(),
            "coverable_samples": validation_coverable,
            "covered_samples": validation_covered,
            "coverable_samples_train": coverable,
            "covered_samples_train": covered,
            "check_rounds": rounds,
            "per_tile": tallies,
        },
        "timings_ms": { "total": watch_start.elapsed().as_secs_f64() * 1e3 },
        "warnings": warnings,
    });
    let probes_json = json!({
        "format": "probeplace.probes",
        "version": crate::report::FORMAT_VERSION,
        "provenance": provenance,
        "method": "tiles",
        "seed": index.seed,
        "scene": index.world.config_given.display().to_string(),
        "space": { "scale": world_config.scale.0, "up": world_config.up },
        "probes": records,
    });
    for (name, value) in [
        ("world.json", &world_json),
        ("report.json", &report),
        ("probes.json", &probes_json),
    ] {
        let bytes = serde_json::to_vec_pretty(value)
            .map_err(|e| Error::Internal(format!("serializing {name}: {e}")))?;
        set.add(name, bytes);
    }
    commit::commit(&claim, &set)?;
    let mut summary = vec![format!(
        "{} tiles: {} probes ({} placed, {} in overlaps, {} of them kept; {} of {} positions offered), coverage {:.2}% ± {:.2}% on unseen samples (training {:.2}%), {} in solid",
        index.tile.len(),
        final_probes.len(),
        probes.len() - offered_all,
        candidates,
        order.iter().filter(|&&k| probes[k].candidate).count(),
        offered_kept,
        offered_all,
        100.0 * coverage,
        100.0 * ci95,
        100.0 * coverage_train,
        health.0
    )];
    summary.extend(warnings.iter().map(|w| format!("warning: {w}")));
    Ok(Outcome {
        out_dir: out,
        report,
        summary,
    })
}

/// The probes of a tile's finished run, in world coordinates, after
/// checking its provenance against `split.json`, and the clearances of its
/// refinement's fill tiers (`None` when it did not refine).
fn tile_probes(
    dir: &Path,
    index: &SplitIndex,
    entry: &TileEntry,
) -> Result<(Vec<DVec3>, Option<Vec<f32>>)> {
    let out = dir.join(&entry.output);
    let rerun = format!(
        "rerun it (probeplace place {}) and merge again",
        dir.join(&entry.config).display()
    );
    let refuse = |why: String| Error::User(format!("{}: {why}; {rerun}", entry.name));
    let read = |name: &str| -> Result<Value> {
        let path = out.join(name);
        if !path.is_file() {
            return Err(refuse(format!(
                "no finished placement ({} is missing): the tile failed or never ran",
                path.display()
            )));
        }
        let text = crate::input::read_text(&path, name, 1 << 30)?;
        serde_json::from_str(&text).map_err(|e| refuse(format!("{}: {e}", path.display())))
    };
    let report = read("report.json")?;
    let probes = read("probes.json")?;
    crate::output::manifest::verify(&out, &format!("the tile's output is not whole; {rerun}"))
        .map_err(|e| Error::User(format!("{}: {e}", entry.name)))?;
    let p = &report["provenance"];
    let field = |v: &Value, k: &str| v[k].as_str().unwrap_or("").to_string();
    if field(p, "config_hash") != entry.config_hash {
        return Err(refuse(format!(
            "its run used another config (config hash {} where split.json has {})",
            field(p, "config_hash"),
            entry.config_hash
        )));
    }
    if field(p, "scene_hash") != entry.scene_hash {
        return Err(refuse(format!(
            "its run read another scene (scene hash {} where split.json has {})",
            field(p, "scene_hash"),
            entry.scene_hash
        )));
    }
    if p["seed"].as_u64() != Some(index.seed) {
        return Err(refuse(format!(
            "its run used seed {} where the split has {}",
            p["seed"], index.seed
        )));
    }
    if field(p, "tool") != index.tool {
        return Err(refuse(format!(
            "its run was made by {} and the split by {}",
            field(p, "tool"),
            index.tool
        )));
    }
    if probes["provenance"] != report["provenance"] {
        return Err(refuse(
            "its probes.json comes from another run than its report.json".into(),
        ));
    }
    let positions = probes["probes"]
        .as_array()
        .ok_or_else(|| refuse("its probes.json lists no probes".into()))?
        .iter()
        .map(|r| {
            let a = &r["position"];
            match (a[0].as_f64(), a[1].as_f64(), a[2].as_f64()) {
                (Some(x), Some(y), Some(z)) => Ok(DVec3::new(x, y, z)),
                _ => Err(refuse(
                    "its probes.json has a probe without a position".into(),
                )),
            }
        })
        .collect::<Result<Vec<DVec3>>>()?;
    let tiers = report["refine"]["clearance_tiers"]
        .as_array()
        .and_then(|a| {
            a.iter()
                .map(|c| {
                    c.as_f64()
                        .filter(|c| c.is_finite() && *c >= 0.0)
                        .map(|c| c as f32)
                })
                .collect::<Option<Vec<f32>>>()
                .filter(|t| !t.is_empty())
        });
    Ok((positions, tiers))
}

/// One tile, prepared again as its run prepared it: the same config, hence
/// the same scene, SDF and coverage samples.
struct Tile {
    config: Config,
    /// The world's config (for the file space of `probes.json`).
    world_config: Config,
    prepared: Prepared,
    reference: CoverageReference,
}

impl Tile {
    /// The tile `carried` holds when it is `entry`'s (taken out of it),
    /// or `entry` prepared; `carried` is emptied either way, so that the
    /// tile it held is dropped before another is prepared.
    fn take_or_prepare(
        carried: &mut Option<(u32, Tile)>,
        dir: &Path,
        entry: &TileEntry,
        progress: &Progress,
    ) -> Result<Tile> {
        if let Some((index, tile)) = carried.take() {
            if index == entry.index {
                return Ok(tile);
            }
        }
        Tile::prepare(dir, entry, progress)
    }

    fn prepare(dir: &Path, entry: &TileEntry, progress: &Progress) -> Result<Tile> {
        let path = dir.join(&entry.config);
        let text = crate::input::read_text(&path, "config", crate::config::MAX_CONFIG_BYTES)?;
        let config = Config::from_text(&text, &path)?;
        let p = Provenance::of(&config, &path, &text, &Overrides::default())?;
        if p.config_hash != entry.config_hash || p.scene_hash != entry.scene_hash {
            return Err(Error::User(format!(
                "{}: {} or its scene changed since the split; split again",
                entry.name,
                path.display()
            )));
        }
        let prepared =
            stages::prepare(&config, &path, &text, progress).map_err(|e| tile_error(entry, e))?;
        let reference =
            prepared.coverage_reference(&config.coverage, Stream::Train, config.seed, progress);
        let index_path = dir.join("split.json");
        let index: SplitIndex = serde_json::from_str(&crate::input::read_text(
            &index_path,
            "split.json",
            1 << 30,
        )?)
        .map_err(|e| Error::user_file(&index_path, e))?;
        let world_config = Config::from_text(&index.world.config_text, &index.config)?;
        Ok(Tile {
            config,
            world_config,
            prepared,
            reference,
        })
    }

    /// The positions the tile's core offers the merge, each with its fill
    /// tier: the reference points of its coverage measure (the viewers it
    /// found every coverable sample from, [`CoverageReference::references`])
    /// that its core owns, outside its `exclude` boxes, in the first of
    /// the clearance `tiers` of its run's refinement at which a probe may
    /// stand there ([`crate::refine::may_stand`]); in world coordinates, in
    /// the reference's order.
    ///
    /// These are refinement's fill candidates: a one-machine placement ends
    /// with mostly such positions (on Dabrovic Sponza 49 of its 51 probes
    /// were added by filling), while a tile's probes were chosen for its
    /// core alone.
    fn offers(&self, grid: &TileGrid, tile: u32, tiers: &[f32]) -> Vec<(DVec3, u8)> {
        let prepared = &self.prepared;
        let controls = Controls::new(&self.config, &prepared.scene);
        self.reference
            .references
            .iter()
            .filter(|&&p| !controls.excluded(p))
            .filter_map(|&p| {
                let tier = self.local_tier(p, tiers)?;
                let w = prepared.scene.to_world(p);
                (grid.owner(w) == tile).then_some((w, tier))
            })
            .collect()
    }

    /// The first of the clearance `tiers` at which a probe may stand at
    /// `p` (tile coordinates), if any.
    fn local_tier(&self, p: glam::Vec3, tiers: &[f32]) -> Option<u8> {
        let prepared = &self.prepared;
        tiers
            .iter()
            .position(|&c| crate::refine::may_stand(&prepared.sdf, &prepared.domain, c, p))
            .map(|t| t.min(u8::MAX as usize) as u8)
    }

    /// The tier of the tile's own probe at world position `w`: as for an
    /// offered position, or past the last tier where none holds (a
    /// position refinement did not choose, as the fixed probes).
    fn tier_of(&self, w: DVec3, tiers: &[f32]) -> u8 {
        let p = self.prepared.scene.to_local(w);
        self.local_tier(p, tiers)
            .unwrap_or(tiers.len().min(u8::MAX as usize) as u8)
    }

    /// The coverable samples of `reference` (one of the tile's) that its
    /// core owns.
    fn core_samples(
        &self,
        reference: &CoverageReference,
        grid: &TileGrid,
        tile: u32,
    ) -> Vec<usize> {
        let scene = &self.prepared.scene;
        (0..reference.samples.len())
            .filter(|&i| {
                reference.coverable[i]
                    && grid.owner(scene.to_world(reference.samples[i].position)) == tile
            })
            .collect()
    }

    /// The tile's measure on the samples of `stream` (of its run's seed).
    fn resampled(&self, stream: Stream, progress: &Progress) -> CoverageReference {
        let input = self.prepared.placement_input(self.config.seed, progress);
        self.reference
            .resampled(&input, &self.config.coverage, stream)
    }

    /// The positions of `probes` inside `entry`'s box (this tile's), with
    /// their index, in tile coordinates.
    fn relevant(&self, probes: &[WorldProbe], entry: &TileEntry) -> Vec<(usize, glam::Vec3)> {
        probes
            .iter()
            .enumerate()
            .filter(|(_, p)| entry.domain.contains(p.position))
            .map(|(k, p)| (k, self.prepared.scene.to_local(p.position)))
            .collect()
    }

    /// Of `reference`'s `samples`, those no kept position of `relevant`
    /// (index, tile coordinates) sees, and how many the kept ones see.
    fn missed(
        &self,
        reference: &CoverageReference,
        samples: &[usize],
        relevant: &[(usize, glam::Vec3)],
        kept: &[bool],
    ) -> (Vec<usize>, usize) {
        let viewers: Vec<glam::Vec3> = relevant
            .iter()
            .filter(|&&(k, _)| kept[k])
            .map(|&(_, p)| p)
            .collect();
        let chosen: Vec<crate::coverage::SurfaceSample> =
            samples.iter().map(|&i| reference.samples[i]).collect();
        let bar = indicatif::ProgressBar::hidden();
        let seen = reference.seen_by_all(&self.prepared.bvh, &chosen, &viewers, 1, &bar);
        let missed: Vec<usize> = samples
            .iter()
            .zip(&seen)
            .filter(|(_, &s)| !s)
            .map(|(&i, _)| i)
            .collect();
        let covered = samples.len() - missed.len();
        (missed, covered)
    }

    /// For each of `reference`'s `samples`, every one of the `relevant`
    /// positions (index, tile coordinates) that sees it, in index order.
    fn lists(
        &self,
        reference: &CoverageReference,
        samples: &[usize],
        relevant: &[(usize, glam::Vec3)],
    ) -> Vec<Vec<u32>> {
        let bvh = &self.prepared.bvh;
        samples
            .par_iter()
            .map_init(Blocker::default, |blocker, &i| {
                let s = &reference.samples[i];
                let mut list = relevant
                    .iter()
                    .filter(|&&(_, p)| reference.sees_from(bvh, p, s, blocker))
                    .map(|&(k, _)| k as u32)
                    .collect::<Vec<u32>>();
                // Grown by doubling: hand back the spare half, which over
                // millions of entries is most of the merge's memory.
                list.shrink_to_fit();
                list
            })
            .collect()
    }
}

/// The world prepared whole, for `--single`.
fn single_world(index: &SplitIndex, progress: &Progress) -> Result<Prepared> {
    let path = &index.config;
    let text = crate::input::read_text(path, "config", crate::config::MAX_CONFIG_BYTES)?;
    let config = Config::from_text(&text, path)?;
    let mut config = config;
    config.voxel_size =
        crate::config::VoxelSize::Fixed(crate::config::Positive(index.voxel_size as f32));
    config.domain = crate::config::Domain::Box(crate::config::BoxDomain {
        min: index.domain.min,
        max: index.domain.max,
    });
    stages::prepare(&config, path, &text, progress)
}

/// The merged probes at `positions` (in a scene's frame) as a probe set of
/// method `tiles`, for the SVO bake.
fn probe_set(positions: impl Iterator<Item = glam::Vec3>) -> ProbeSet {
    ProbeSet {
        method: "tiles".into(),
        probes: positions
            .map(|position| Probe {
                position,
                cluster_size: 0,
            })
            .collect(),
        stats: BTreeMap::new(),
        params: BTreeMap::new(),
        min_clearance: 0.0,
        fixed: 0,
    }
}

/// An error of a tile's stages, prefixed with the tile's name.
fn tile_error(entry: &TileEntry, e: Error) -> Error {
    match e {
        Error::User(m) => Error::User(format!("{}: {m}", entry.name)),
        e => e,
    }
}

/// Most fresh rounds of samples the merged cover is checked on and filled
/// from (as one machine's [`crate::refine::holdout`]), one pass over the
/// tiles each.
const CHECK_ROUNDS: u32 = 3;
