//! The `split` job: cuts a world into tiles ([`crate::tiles`]) and writes
//! one tile job each, the scripts that run them as a Slurm array, and the
//! index `merge` checks them against.
//!
//! `DIR` gets:
//!
//! | file | what |
//! |---|---|
//! | `split.json` | the world config, seed, grid, margin, voxel size, and per tile its boxes, files and the provenance its run must carry |
//! | `tile-NNN/scene.obj` | the triangles that touch the tile's box, in world coordinates |
//! | `tile-NNN/config.ron` | the world config with the tile's scene, domain and output (`tile-NNN/out`) |
//! | `<library>.mtl` | the world's material libraries, which every tile names, with the textures they map beside them |
//! | `tile.sh` | runs tile `$1` (an array index) or the merge |
//! | `submit.sh` | `sbatch --array` over the tiles, then the merge `afterok` (docs/tiles.md) |

use super::outcome::Outcome;
use crate::config::{Config, Domain, VoxelSize};
use crate::error::{Error, Result};
use crate::provenance::{Overrides, Provenance};
use crate::tiles::{self, TileGrid, WorldBox};
use glam::UVec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What the command line gives `split`.
#[derive(Debug, Clone)]
pub struct SplitOptions {
    /// The world's config.
    pub config: PathBuf,
    /// Tiles along x, y, z.
    pub tiles: UVec3,
    /// The directory to write.
    pub out: PathBuf,
    /// The margin, world units (default: [`tiles::default_margin`]).
    pub margin: Option<f64>,
    /// CPUs each tile job asks the scheduler for.
    pub cpus: u32,
}

/// `split.json`, the index of a split (docs/formats.md).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SplitIndex {
    /// Always `probeplace.split`.
    pub format: String,
    /// Format version, 1.
    pub version: u32,
    /// The tool that split.
    pub tool: String,
    /// The world config, absolute.
    pub config: PathBuf,
    /// Its provenance (config and scene hashes, seed).
    pub world: Provenance,
    /// The seed every tile runs with.
    pub seed: u64,
    /// Tiles along x, y, z.
    pub tiles: [u32; 3],
    /// The world's domain.
    pub domain: WorldBox,
    /// How far a tile's box reaches beyond its core.
    pub margin: f64,
    /// The voxel size every tile uses.
    pub voxel_size: f64,
    /// The tiles, by array index.
    pub tile: Vec<TileEntry>,
}

/// One tile in `split.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TileEntry {
    /// `tile-NNN`.
    pub name: String,
    /// Array index.
    pub index: u32,
    /// Grid cell.
    pub cell: [u32; 3],
    /// The part of the world it owns.
    pub core: WorldBox,
    /// The box it places over.
    pub domain: WorldBox,
    /// Triangles in its OBJ.
    pub triangles: u64,
    /// Its config, relative to the split directory.
    pub config: PathBuf,
    /// Its output directory, relative to the split directory.
    pub output: PathBuf,
    /// The config hash its outputs must carry.
    pub config_hash: String,
    /// The scene hash its outputs must carry.
    pub scene_hash: String,
    /// Memory the scheduler is asked for, MiB.
    pub memory_mib: u64,
}

impl TileEntry {
    /// Whether no triangle touches the tile's box: nothing to place there
    /// (`tile.sh` succeeds at once, `merge` skips it; docs/tiles.md).
    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }
}

impl SplitIndex {
    /// The tile grid the index describes.
    pub fn grid(&self) -> TileGrid {
        TileGrid {
            world: self.domain,
            counts: UVec3::from_array(self.tiles),
            margin: self.margin,
        }
    }
}

/// Runs `probeplace split`.
///
/// Contract: on success `out` holds the files of the module docs, and
/// `split.json` is written last (a split cut short leaves none, so `merge`
/// refuses it); a config whose artist controls cannot be split
/// (`fixed_probes`, `max_probes`, `min_probes`: they hold for the whole
/// world) is a user error naming the field.
pub fn split(options: &SplitOptions) -> Result<Outcome> {
    let path = &options.config;
    let text = crate::input::read_text(path, "config", crate::config::MAX_CONFIG_BYTES)?;
    let config = Config::from_text(&text, path)?;
    // Before any work: a destination that cannot hold a split.
    check_outside_tiles(&options.out, None)?;
    check_dir(&options.out)?;
    let at = |field: &str, why: &str| Error::User(format!("{field}: {why}")).in_config(path, &text);
    if crate::scene::is_gltf(&config.scene) {
        return Err(at("scene", "split streams OBJ scenes into tiles; this one is glTF: place it whole, or export it as OBJ to split it"));
    }
    if !config.fixed_probes.is_empty() {
        return Err(at("fixed_probes", "split cannot share fixed probes among tiles yet; place the world on one machine, or remove them"));
    }
    if config.max_probes.is_some() || config.min_probes.is_some() {
        return Err(at(
            if config.max_probes.is_some() {
                "max_probes"
            } else {
                "min_probes"
            },
            "a count for the whole world cannot be split among tiles; remove it",
        ));
    }
    let world_provenance = Provenance::of(&config, path, &text, &Overrides::default())?;
    let world = match &config.domain {
        Domain::Box(b) => WorldBox {
            min: b.min,
            max: b.max,
        },
        Domain::Auto => tiles::stream_bounds(&config.scene, config.scale.0, config.up)?,
    };
    let voxel_size = match config.voxel_size {
        VoxelSize::Fixed(v) => v.0 as f64,
        VoxelSize::Auto => crate::resolution::auto_from_domain(&world) as f64,
    };
    let margin = match options.margin {
        Some(m) if !(m.is_finite() && m >= 0.0) => {
            return Err(Error::User(format!(
                "--margin: {m} is not a length of at least 0"
            )))
        }
        Some(m) => m,
        None => tiles::default_margin(&world, options.tiles, voxel_size),
    };
    let grid = TileGrid {
        world,
        counts: options.tiles,
        margin,
    };
    let dir = &options.out;
    let width = (grid.len() - 1).to_string().len().max(3);
    let names: Vec<String> = (0..grid.len())
        .map(|i| format!("tile-{i:0width$}"))
        .collect();
    // Every tile's config, written and parsed before the scene is split:
    // a config the tiles cannot take is refused before that work.
    let mut tile_texts = Vec::new();
    for (tile, name) in grid.tiles().into_iter().zip(&names) {
        let tile_text = set_fields(
            &text,
            &[
                ("scene", "\"scene.obj\"".to_string()),
                ("scale", "1.0".to_string()),
                ("up", "Y".to_string()),
                (
                    "domain",
                    format!(
                        "Box((min: {}, max: {}))",
                        point(tile.outer.min),
                        point(tile.outer.max)
                    ),
                ),
                ("voxel_size", format!("{voxel_size:?}")),
                // A tile's box cuts the world's free space into pieces that
                // its cameras do not reach: every tile keeps all its free
                // space (the reach of the world is not yet carried).
                ("reachable", "Everywhere".to_string()),
                ("output", "\"out\"".to_string()),
                ("seed", config.seed.to_string()),
                ("export", "[]".to_string()),
                ("probe_density", margin_density(&text, &tile, grid.counts)?),
            ],
        )
        .map_err(|m| Error::user_file(path, m))?;
        Config::parse(&tile_text, &dir.join(name).join("config.ron"))?;
        tile_texts.push(tile_text);
    }
    prepare_dir(dir)?;
    for name in &names {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
    }
    let objs: Vec<PathBuf> = names
        .iter()
        .map(|n| dir.join(n).join("scene.obj"))
        .collect();
    let (geometry, libraries) = tiles::split_obj(
        &config.scene,
        config.scale.0,
        config.up,
        &grid,
        &objs,
        "../",
    )?;
    let source_dir = config.scene.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut left_behind: Vec<String> = Vec::new();
    for lib in &libraries {
        let (from, to) = (source_dir.join(lib), dir.join(lib));
        if from.is_file() {
            copy_into(&from, &to)?;
            // The textures the library maps, beside the copy as beside the
            // original, so that the tiles' runs read them (and hash them).
            let (from_dir, to_dir) = (parent_of(&from), parent_of(&to));
            for texture in crate::provenance::inputs::texture_files(std::slice::from_ref(&from)) {
                use std::path::Component;
                let rel = texture.strip_prefix(&from_dir).unwrap_or(&texture);
                if rel.components().all(|c| matches!(c, Component::Normal(_))) {
                    copy_into(&texture, &to_dir.join(rel))?;
                } else if !rel.has_root() {
                    left_behind.push(texture.display().to_string());
                }
                // An absolute name is read from where it is.
            }
        }
    }
    let mut entries = Vec::new();
    for ((tile, tile_text), (name, g)) in grid
        .tiles()
        .into_iter()
        .zip(&tile_texts)
        .zip(names.iter().zip(&geometry))
    {
        let tile_config = dir.join(name).join("config.ron");
        std::fs::write(&tile_config, tile_text).map_err(|e| Error::io(&tile_config, e))?;
        let parsed = Config::from_text(tile_text, &tile_config)?;
        let p = Provenance::of(&parsed, &tile_config, tile_text, &Overrides::default())?;
        let size = tile.outer.size();
        let voxels = (size / voxel_size).ceil().max(glam::DVec3::ONE);
        let bytes = crate::scene::obj::BYTES_PER_TRIANGLE * g.triangles as f64
            + BYTES_PER_VOXEL * voxels.x * voxels.y * voxels.z
            + BASE_BYTES;
        entries.push(TileEntry {
            name: name.clone(),
            index: tile.index,
            cell: tile.cell.to_array(),
            core: tile.core,
            domain: tile.outer,
            triangles: g.triangles,
            config: PathBuf::from(name).join("config.ron"),
            output: PathBuf::from(name).join("out"),
            config_hash: p.config_hash,
            scene_hash: p.scene_hash,
            memory_mib: (bytes / (1u64 << 20) as f64).ceil() as u64,
        });
    }
    let index = SplitIndex {
        format: "probeplace.split".into(),
        version: 1,
        tool: crate::provenance::TOOL.into(),
        config: std::path::absolute(path).map_err(|e| Error::io(path, e))?,
        world: world_provenance,
        seed: config.seed,
        tiles: grid.counts.to_array(),
        domain: world,
        margin,
        voxel_size,
        tile: entries,
    };
    let exe = std::env::current_exe()
        .ok()
        .and_then(|p| p.canonicalize().ok())
        .unwrap_or_else(|| PathBuf::from("probeplace"));
    write_file(&dir.join("tile.sh"), &tile_script(&exe, &index.tile))?;
    write_file(&dir.join("submit.sh"), &submit_script(&index, options.cpus))?;
    for script in ["tile.sh", "submit.sh"] {
        set_executable(&dir.join(script))?;
    }
    let value = serde_json::to_value(&index)
        .map_err(|e| Error::Internal(format!("serializing split.json: {e}")))?;
    let json = serde_json::to_vec_pretty(&value)
        .map_err(|e| Error::Internal(format!("serializing split.json: {e}")))?;
    write_file(
        &dir.join("split.json"),
        std::str::from_utf8(&json).unwrap_or(""),
    )?;
    let triangles: u64 = index.tile.iter().map(|t| t.triangles).sum();
    let mut summary = Vec::new();
    if !left_behind.is_empty() {
        summary.push(format!(
            "warning: texture(s) outside their material library's folder not copied (the tiles' runs will not find them, and use the factors): {}",
            left_behind.join(", ")
        ));
    }
    Ok(Outcome {
        out_dir: dir.clone(),
        summary: [summary, vec![
            format!(
                "{} tiles ({}x{}x{}), margin {}, voxel {}: {triangles} triangles written over the tiles",
                grid.len(),
                grid.counts.x,
                grid.counts.y,
                grid.counts.z,
                crate::config::short(margin as f32),
                crate::config::short(voxel_size as f32)
            ),
            format!("run them: {}", dir.join("submit.sh").display()),
        ]]
        .concat(),
        report: value,
    })
}

/// Copies file `from` to `to`, creating `to`'s folder.
fn copy_into(from: &Path, to: &Path) -> Result<()> {
    if let Some(parent) = to.parent() {
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    std::fs::copy(from, to).map_err(|e| Error::io(to, e))?;
    Ok(())
}

/// The folder of file `path` (empty for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    path.parent().unwrap_or(Path::new("")).to_path_buf()
}

/// The tile's `probe_density`: the world's regions, then factor 0 over
/// every slab of space beyond a face of its core that a neighbour owns.
///
/// A tile places over its whole box, but demands views only of its core's
/// surfaces: refinement's filling and pruning then keep the fewest probes
/// that cover the core (standing in the margin where that sees it best),
/// as one machine's run would keep for that part of the world, and the
/// neighbour that owns the margin answers for it. Cores are half-open
/// (the world's upper faces closed, [`crate::tiles`]): a slab below a core
/// stops a hair short of it, so a surface on the face between two cores
/// is demanded by at least the one that owns it.
fn margin_density(text: &str, tile: &tiles::Tile, counts: UVec3) -> Result<String> {
    let fields = top_level_fields(text).map_err(Error::User)?;
    let existing = fields
        .fields
        .iter()
        .find(|f| f.0 == "probe_density")
        .map(|&(_, start, end)| text[start..end].trim())
        .unwrap_or("[]");
    let inner = existing
        .strip_prefix('[')
        .and_then(|t| t.strip_suffix(']'))
        .ok_or_else(|| Error::User("probe_density: is not a list `[...]`".into()))?
        .trim()
        .trim_end_matches(',');
    // The slabs reach far beyond the box: a triangle that touches the box
    // may reach out of it, and the samples on it there are no more this
    // tile's than those in the margin.
    let (core, outer) = (tile.core, tile.outer);
    let far = 1e6
        * (1.0
            + outer
                .min
                .iter()
                .chain(&outer.max)
                .fold(0.0f64, |m, v| m.max(v.abs())));
    let mut entries: Vec<String> = Vec::new();
    if !inner.is_empty() {
        entries.push(inner.to_string());
    }
    for k in 0..3 {
        let hair = 1e-9 * (outer.max[k] - outer.min[k]).abs().max(1.0);
        let (mut min, mut max) = ([-far; 3], [far; 3]);
        // Only where a neighbour owns what lies beyond: past the world's
        // own faces the cell at the edge owns it ([`TileGrid::owner`]).
        if tile.cell[k] > 0 {
            max[k] = core.min[k] - hair;
            entries.push(format!(
                "(Box((min: {}, max: {})), 0.0)",
                point(min),
                point(max)
            ));
        }
        (min, max) = ([-far; 3], [far; 3]);
        min[k] = core.max[k];
        if tile.cell[k] + 1 < counts[k] {
            entries.push(format!(
                "(Box((min: {}, max: {})), 0.0)",
                point(min),
                point(max)
            ));
        }
    }
    if entries.is_empty() {
        // One tile owns the whole world: nothing beyond it is anyone else's.
        return Ok("[]".into());
    }
    Ok(format!(
        "[\n        {},\n    ]",
        entries.join(",\n        ")
    ))
}

/// Bytes a tile's run takes per SDF voxel (distance, class, nearest point,
/// and the stages' per-voxel arrays), for the memory it asks for.
const BYTES_PER_VOXEL: f64 = 200.0;

/// Bytes a tile's run takes whatever its size.
const BASE_BYTES: f64 = 256.0 * 1024.0 * 1024.0;

/// Makes `dir` ready for a split: created when missing. An earlier
/// split there is replaced, not mixed with the new one: its index goes
/// first (so a split cut short cannot pass for a whole one), then its
/// tiles with their outputs, its merged world, its logs and scripts, so
/// no tile, placement or world of the old split is left to pass for the
/// new one's. A directory holding other things, or a path that is not a
/// directory, is refused.
fn prepare_dir(dir: &Path) -> Result<()> {
    check_dir(dir)?;
    if dir.is_dir() {
        let index = dir.join("split.json");
        if index.is_file() {
            let old = std::fs::read(&index).map_err(|e| Error::io(&index, e))?;
            std::fs::remove_file(&index).map_err(|e| Error::io(&index, e))?;
            for entry in earlier_split(&old) {
                let path = dir.join(&entry);
                let gone = if path.is_dir() {
                    std::fs::remove_dir_all(&path)
                } else {
                    std::fs::remove_file(&path)
                };
                match gone {
                    Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                        return Err(Error::io(&path, e))
                    }
                    _ => {}
                }
            }
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Refuses a split destination that is not a directory, or one that holds
/// files but no `split.json` (not an earlier split's, so not ours to
/// clear); [`prepare_dir`]'s checks, made before any work.
fn check_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::user_file(
            dir,
            "--out: is not a directory; give an empty or new directory",
        ));
    }
    if dir.exists() {
        let index = dir.join("split.json");
        let empty = std::fs::read_dir(dir)
            .map_err(|e| Error::io(dir, e))?
            .next()
            .is_none();
        if !index.is_file() && !empty {
            return Err(Error::user_file(
                dir,
                "--out: holds files but no split.json; give an empty or new directory",
            ));
        }
        if index.is_file() {
            let old = crate::input::read(&index, "split.json", 1 << 30)?;
            for entry in earlier_split(&old) {
                check_removable(&dir.join(&entry), &entry)?;
            }
        }
    }
    Ok(())
}

/// Refuses the entry `name` of an earlier split at `path` (which
/// [`prepare_dir`] removes) when it holds anything no split, tile run,
/// Slurm log or merge wrote: a file the user put there would go with it.
/// A tile holds its scene, config and output directory (checked as any
/// output directory: [`commit::check_destination`]); the logs, Slurm's
/// `probeplace-*.out`; `world`, the merge's output.
fn check_removable(path: &Path, name: &str) -> Result<()> {
    use crate::output::commit;
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return Ok(());
    };
    let refuse = |stray: &Path| {
        Err(Error::user_file(
            stray,
            "was not written by probeplace or its tile jobs, and the split replaces what the earlier split left here: move it out, or choose another --out",
        ))
    };
    if !meta.is_dir() {
        return if name.ends_with(".sh") {
            Ok(())
        } else {
            refuse(path)
        };
    }
    if name.ends_with(".sh") {
        return refuse(path);
    }
    if name == "world" {
        return commit::check_destination(path, &[]);
    }
    for (entry, is_dir) in commit::entries(path).map_err(|e| Error::io(path, e))? {
        let at = path.join(&entry);
        let ok = match name {
            "logs" => !is_dir && entry.starts_with("probeplace-") && entry.ends_with(".out"),
            _ if entry == "out" && is_dir => {
                commit::check_destination(&at, &[])?;
                true
            }
            // What a killed tile run's commit left beside its output.
            _ if entry.starts_with(".out.probeplace") => true,
            _ => !is_dir && (entry == "scene.obj" || entry == "config.ron"),
        };
        if !ok {
            return refuse(&at);
        }
    }
    Ok(())
}

/// Refuses an output directory `out` inside a tile of a split (a
/// directory above it holds `split.json`): a run there would replace a
/// tile's placement, or lie in what the next split sweeps, and `merge`
/// would read whatever it left. The one run allowed there is a tile's own:
/// `out` is that tile's `output` and `config` its config. Elsewhere in the
/// split directory (the merged `world`) is allowed. Symbolic links are
/// resolved before comparing.
pub(crate) fn check_outside_tiles(out: &Path, config: Option<&Path>) -> Result<()> {
    use crate::output::commit::absolute;
    let o = absolute(out);
    for root in o.ancestors().skip(1) {
        let index_path = root.join("split.json");
        let Ok(bytes) = crate::input::read(&index_path, "split.json", 1 << 30) else {
            continue;
        };
        let Ok(index) = serde_json::from_slice::<SplitIndex>(&bytes) else {
            continue;
        };
        let Some(first) = o
            .strip_prefix(root)
            .ok()
            .and_then(|r| r.components().next())
        else {
            continue;
        };
        let Some(tile) = index
            .tile
            .iter()
            .find(|t| first.as_os_str() == t.name.as_str())
        else {
            continue;
        };
        let own = o == absolute(&root.join(&tile.output))
            && config.is_some_and(|c| absolute(c) == absolute(&root.join(&tile.config)));
        if !own {
            return Err(Error::user_file(
                out,
                format!(
                    "lies inside {} of the split in {}, which only that tile's own run writes and `merge` reads; choose an --out outside the tiles",
                    tile.name,
                    root.display()
                ),
            ));
        }
    }
    Ok(())
}

/// What an earlier split wrote into its directory, from its `split.json`
/// (`index`): the scripts, the logs, the default merged world, and each
/// tile's directory. Only names a split writes are returned (a tile's
/// must read `tile-` and digits), so an index edited by hand cannot point
/// the removal elsewhere; an index without a readable tile list yields
/// the fixed names alone.
fn earlier_split(index: &[u8]) -> Vec<String> {
    #[derive(Deserialize)]
    struct Tiles {
        tile: Vec<Named>,
    }
    #[derive(Deserialize)]
    struct Named {
        name: String,
    }
    let mut names: Vec<String> = ["tile.sh", "submit.sh", "logs", "world"]
        .map(String::from)
        .to_vec();
    if let Ok(old) = serde_json::from_slice::<Tiles>(index) {
        names.extend(old.tile.into_iter().map(|t| t.name).filter(|n| {
            n.strip_prefix("tile-")
                .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
        }));
    }
    names
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| Error::io(path, e))
}

fn set_executable(path: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .map_err(|e| Error::io(path, e))
}

/// A point as RON: `(x, y, z)` with every digit f64 needs.
fn point(p: [f64; 3]) -> String {
    format!("({:?}, {:?}, {:?})", p[0], p[1], p[2])
}

/// `tile.sh INDEX` places tile INDEX; `tile.sh merge` merges. Slurm runs
/// it as `$SLURM_ARRAY_TASK_ID`, a Kubernetes Indexed Job as
/// `$JOB_COMPLETION_INDEX`. Without cgroups nothing holds a task to its
/// CPUs, so the task's rayon pool is sized to what it asked for. A tile
/// whose box no triangle touches succeeds at once: `place` would refuse
/// its empty scene, and a failed array task would cancel the merge.
fn tile_script(exe: &Path, tiles: &[TileEntry]) -> String {
    let cases: String = tiles
        .iter()
        .map(|t| {
            let (i, n) = (t.index, &t.name);
            if t.is_empty() {
                // Nothing to place; the array task succeeds, so the merge
                // (which skips the tile) still runs.
                format!(
                    "    {i}) echo \"tile.sh: {n} holds no triangles: nothing to place\" >&2; exit 0 ;;\n"
                )
            } else {
                format!("    {i}) tile={n} ;;\n")
            }
        })
        .collect();
    format!(
        r#"#!/bin/sh
# Written by probeplace split: places one tile (by array index) or merges.
set -eu
# Slurm runs a copy of this script from its spool: the split directory is
# where the job was submitted from (submit.sh submits from it).
cd "${{SLURM_SUBMIT_DIR:-$(dirname "$0")}}"
PROBEPLACE="${{PROBEPLACE:-{exe}}}"
if [ -n "${{SLURM_CPUS_PER_TASK:-}}" ]; then
    export RAYON_NUM_THREADS="$SLURM_CPUS_PER_TASK"
fi
index="${{1:-${{SLURM_ARRAY_TASK_ID:-${{JOB_COMPLETION_INDEX:-}}}}}}"
if [ "$index" = merge ]; then
    shift
    exec "$PROBEPLACE" merge . "$@"
fi
case "$index" in
{cases}    *) echo "tile.sh: no tile with index '$index'" >&2; exit 2 ;;
esac
exec "$PROBEPLACE" place "$tile/config.ron" --quiet
"#,
        exe = exe.display()
    )
}

/// `submit.sh`: the array of tile jobs, then the merge once every one of
/// them succeeded (`afterok`; with `kill_invalid_depend` or
/// `--kill-on-invalid-dep` a failed tile cancels the merge rather than
/// leaving it pending). `--wait` waits for the merge and exits with its
/// status, or 1 when it never ran.
fn submit_script(index: &SplitIndex, cpus: u32) -> String {
    let memory = index
        .tile
        .iter()
        .map(|t| t.memory_mib)
        .max()
        .unwrap_or(1024);
    let last = index.tile.len() - 1;
    format!(
        r#"#!/bin/bash
# Written by probeplace split: runs the {n} tiles as a Slurm array, then
# merges them. Extra arguments go to both sbatch calls (e.g. --partition).
# --wait (first argument) waits for the merge and returns its status.
set -euo pipefail
cd "$(dirname "$0")"
wait=""
if [ "${{1:-}}" = --wait ]; then wait=--wait; shift; fi
mkdir -p logs
rm -f logs/merge.status
array=$(sbatch --parsable --job-name=probeplace-tiles --array=0-{last} \
    --cpus-per-task={cpus} --mem={memory}M --output=logs/%x-%a.out "$@" tile.sh)
array="${{array%%;*}}"
echo "tiles: job $array"
merge=$(sbatch --parsable $wait --job-name=probeplace-merge \
    --dependency=afterok:"$array" --kill-on-invalid-dep=yes \
    --cpus-per-task={cpus} --mem={memory}M --output=logs/%x.out "$@" \
    --wrap 'sh tile.sh merge; echo $? > logs/merge.status')
echo "merge: job ${{merge%%;*}}"
if [ -n "$wait" ]; then
    if [ ! -f logs/merge.status ]; then
        echo "submit.sh: the merge never ran: a tile failed (logs/probeplace-tiles-*.out)" >&2
        exit 1
    fi
    exit "$(cat logs/merge.status)"
fi
"#,
        n = index.tile.len(),
    )
}

/// `text` (a RON config struct) with each top-level field of `fields` set
/// to its value: replaced where the text has it, added before the closing
/// parenthesis where not. Comments and every other field stay as written.
fn set_fields(text: &str, fields: &[(&str, String)]) -> std::result::Result<String, String> {
    let spans = top_level_fields(text)?;
    let mut out = text.to_string();
    let mut edits: Vec<(usize, usize, String)> = Vec::new();
    let mut missing = String::new();
    for (name, value) in fields {
        match spans.fields.iter().find(|f| f.0 == *name) {
            Some(&(_, start, end)) => edits.push((start, end, value.clone())),
            None if spans.fields.is_empty() => missing.push_str(&format!("\n    {name}: {value},")),
            None => missing.push_str(&format!(",\n    {name}: {value}")),
        }
    }
    if !missing.is_empty() {
        let at = spans
            .fields
            .iter()
            .map(|f| f.2)
            .max()
            .unwrap_or(spans.open + 1);
        edits.push((at, at, missing));
    }
    edits.sort_by_key(|e| std::cmp::Reverse(e.0));
    for (start, end, value) in edits {
        out.replace_range(start..end, &value);
    }
    Ok(out)
}

/// The top-level fields of a RON struct: `(name, value start, value end)`
/// byte offsets, and where its opening parenthesis is.
struct Fields<'a> {
    fields: Vec<(&'a str, usize, usize)>,
    open: usize,
}

fn top_level_fields(text: &str) -> std::result::Result<Fields<'_>, String> {
    let b = text.as_bytes();
    let mut i = 0;
    let mut depth = 0i32;
    let mut fields = Vec::new();
    let mut value_start: Option<(&str, usize)> = None;
    let mut open = 0;
    let mut name_start: Option<usize> = None;
    while i < b.len() {
        let c = b[i];
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
            continue;
        }
        if c == b'#' && depth == 0 {
            // `#![enable(...)]` extension attributes before the struct.
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            continue;
        }
        match c {
            b'[' | b'{' if depth == 0 => break,
            b'(' | b'[' | b'{' => {
                if depth == 0 {
                    open = i;
                }
                depth += 1
            }
            b')' | b']' | b'}' => {
                depth -= 1;
                if depth == 0 {
                    if let Some((name, start)) = value_start.take() {
                        fields.push((name, start, trim_end(text, start, i)));
                    }
                    return Ok(Fields { fields, open });
                }
            }
            _ => {}
        }
        if depth == 1 {
            if c == b',' {
                if let Some((name, start)) = value_start.take() {
                    fields.push((name, start, trim_end(text, start, i)));
                }
            } else if value_start.is_none() {
                if c.is_ascii_alphanumeric() || c == b'_' {
                    name_start.get_or_insert(i);
                } else if c == b':' {
                    if let Some(s) = name_start.take() {
                        let name = text[s..i].trim();
                        let mut v = i + 1;
                        while v < b.len() && (b[v] == b' ' || b[v] == b'\t') {
                            v += 1;
                        }
                        value_start = Some((name, v));
                    }
                } else if !c.is_ascii_whitespace() {
                    name_start = None;
                }
            }
        }
        i += 1;
    }
    Err("the config is not a RON struct `( ... )`".to_string())
}

/// `end`, moved back over whitespace to just after the value before it.
fn trim_end(text: &str, start: usize, end: usize) -> usize {
    start + text[start..end].trim_end().len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_earlier_split_names_only_what_a_split_writes() {
        let fixed = ["tile.sh", "submit.sh", "logs", "world"];
        assert_eq!(earlier_split(b"not json"), fixed);
        assert_eq!(earlier_split(br#"{"tile": 3}"#), fixed);
        let tiles: Vec<_> = [
            "tile-000",
            "tile-0013",
            "../elsewhere",
            "tile-",
            "tile-1/../..",
            "tiles",
        ]
        .iter()
        .map(|n| serde_json::json!({ "name": n, "index": 0 }))
        .collect();
        let index = serde_json::json!({ "format": "probeplace.split", "tile": tiles });
        let names = earlier_split(&serde_json::to_vec(&index).unwrap());
        assert_eq!(names[..4], fixed);
        assert_eq!(names[4..], ["tile-000", "tile-0013"]);
    }

    #[test]
    fn fields_are_replaced_in_place_and_added_when_missing() {
        let text = "// world\n(\n    scene: \"a.obj\", // the scene\n    domain: Box((min: (0, 0, 0), max: (1, 1, 1))),\n    lights: [Sky(radiance: (1, 1, 1))],\n    seed: 3\n)\n";
        let out = set_fields(
            text,
            &[
                ("scene", "\"scene.obj\"".into()),
                ("domain", "Auto".into()),
                ("output", "\"out\"".into()),
            ],
        )
        .unwrap();
        assert_eq!(
            out,
            "// world\n(\n    scene: \"scene.obj\", // the scene\n    domain: Auto,\n    lights: [Sky(radiance: (1, 1, 1))],\n    seed: 3,\n    output: \"out\"\n)\n"
        );
        assert!(set_fields("[1, 2]", &[]).is_err());
    }
}
