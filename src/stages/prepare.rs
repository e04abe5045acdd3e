//! The first stage: the scene loaded and scaled, its BVH, the voxel size
//! and the SDF (Wang et al. 2019 §3.1), what every placement method reads.

use crate::config::{short_all, Config, Domain, VoxelSize};
use crate::error::{Error, Result};
use crate::limits;
use crate::placement::PlacementInput;
use crate::progress::{Progress, Stopwatch};
use crate::resolution::{self, Resolution};
use crate::scene::raycast::SceneBvh;
use crate::scene::{self, Bounds, Scene};
use crate::sdf::{self, Sdf};
use glam::DVec3;
use std::path::Path;

/// The scene and what every placement method reads, built by [`prepare`].
pub struct Prepared {
    /// The loaded scene.
    pub scene: Scene,
    /// Where probes may go.
    pub domain: Bounds,
    /// The scene's BVH.
    pub bvh: SceneBvh,
    /// The SDF of the domain.
    pub sdf: Sdf,
    /// How its voxel size was chosen.
    pub resolution: Resolution,
    /// `load`, `bvh`, `resolution`, `sdf`.
    pub timings: Stopwatch,
    /// The free space a viewer reaches (`config.reachable`); `None` for
    /// `Everywhere`. The SDF already marks the rest `Outside`.
    pub reachable: Option<crate::reachable::Reachable>,
    /// The coverage measure's reference points
    /// ([`crate::coverage::free_points`]) and the count asked for: the
    /// same for every stream and seed, found once.
    free_points: std::sync::OnceLock<(u32, Vec<glam::Vec3>)>,
}

impl Prepared {
    /// The coverage measure over this scene ([`CoverageReference::by_rays`])
    /// for the samples of `stream` of a run seeded `seed`.
    pub fn coverage_reference(
        &self,
        params: &crate::config::CoverageParams,
        stream: crate::coverage::Stream,
        seed: u64,
        progress: &Progress,
    ) -> crate::coverage::CoverageReference {
        let count = params.reference_points.0;
        // Reference points only where a viewer reaches: a surface seen
        // only from a sealed void is no surface to cover.
        let find = || {
            let mut points =
                crate::coverage::free_points(&self.bvh, &self.sdf, &self.domain, count as usize);
            if let Some(reach) = &self.reachable {
                points.retain(|&p| !reach.excludes(&self.sdf, p));
            }
            points
        };
        let (cached, points) = self.free_points.get_or_init(|| (count, find()));
        let refs = if *cached == count {
            points.clone()
        } else {
            find()
        };
        crate::coverage::CoverageReference::on_free_points(
            &self.scene,
            &self.bvh,
            &self.sdf,
            params,
            stream.seed(seed),
            refs,
            self.reachable
                .as_ref()
                .map(|r| std::sync::Arc::new(r.mask.clone())),
            progress,
        )
    }

    /// The light transport of the bake for `config` (its lights and
    /// bounces): what probes record, and what the diffuse references and
    /// the diffuse step follow.
    pub fn renderer<'a>(&'a self, config: &crate::config::Config) -> crate::render::Renderer<'a> {
        crate::render::Renderer::new(
            &self.scene,
            &self.bvh,
            &config.lights,
            config.bake.bounces.0,
        )
    }

    /// The input of a placement method over this scene.
    pub fn placement_input<'a>(&'a self, seed: u64, progress: &'a Progress) -> PlacementInput<'a> {
        PlacementInput {
            scene: &self.scene,
            bvh: &self.bvh,
            sdf: &self.sdf,
            domain: &self.domain,
            seed,
            progress,
        }
    }
}

/// The stages before placement (load, domain, BVH, SDF) for `config`, read
/// from `config_path`, whose contents are `config_text`.
///
/// Contract: errors of the stages that read config fields (domain, SDF) are
/// prefixed with `config_path` and the line and column of the field in
/// `config_text` ([`Error::in_config`]); scene errors name the scene file
/// themselves.
pub fn prepare(
    config: &Config,
    config_path: &Path,
    config_text: &str,
    progress: &Progress,
) -> Result<Prepared> {
    let mut timings = progress.stopwatch();
    let mut scene = timings.try_time("load", || {
        scene::load(&config.scene, config.scale.0, config.up)
    })?;
    if config.scene_lights == crate::config::SceneLights::Ignore {
        scene.lights.clear();
    }
    let in_config = |e: Error| e.in_config(config_path, config_text);
    let domain = resolve_domain(&config.domain, &scene).map_err(in_config)?;
    let bvh = timings.time("bvh", || SceneBvh::new(&scene));
    crate::limits::set_ray_tests(bvh.expected_tests());
    let resolution = timings.time("resolution", || {
        resolve_voxel_size(config, &scene, &bvh, &domain)
    });
    check_work(config, &domain, resolution.voxel_size).map_err(in_config)?;
    let sdf = timings
        .try_time("sdf", || {
            sdf::build(
                &scene,
                &bvh,
                &domain,
                resolution.voxel_size,
                &config.sdf,
                config.seed,
                progress,
            )
        })
        .map_err(in_config)?;
    let mut sdf = sdf;
    check_reach_points(config, &scene, &sdf).map_err(in_config)?;
    let reachable = timings.time("reachable", || {
        restrict_to_reach(config, &scene, &bvh, &mut sdf)
    });
    Ok(Prepared {
        scene,
        domain,
        bvh,
        sdf,
        resolution,
        timings,
        reachable,
        free_points: std::sync::OnceLock::new(),
    })
}

/// The seeds of `config.reachable` in `scene`'s local coordinates: the
/// config's cameras (and the given points); `None` for `Everywhere`.
/// Empty when the config has neither: all free space then counts
/// ([`crate::reachable`] says why not a guess).
pub fn reach_seeds(config: &Config, scene: &Scene) -> Option<Vec<glam::Vec3>> {
    let cameras = config
        .reference
        .camera
        .iter()
        .chain(&config.compare.cameras)
        .map(|c| c.position.0);
    let points: Vec<[f64; 3]> = match &config.reachable {
        crate::config::Reach::Everywhere => return None,
        crate::config::Reach::Cameras => cameras.collect(),
        crate::config::Reach::From(given) => cameras.chain(given.iter().map(|p| p.0)).collect(),
    };
    Some(
        points
            .into_iter()
            .map(|p| scene.to_local(DVec3::from(p)))
            .collect(),
    )
}

/// Refuses a point of `reachable: From([...])` that starts nothing: one
/// beyond the SDF's grid (outside the domain), or in solid with no open
/// voxel near it ([`crate::reachable::starts_from`]). The flood would skip
/// it silently and, with no other seed, count all free space, a sealed
/// void included: the opposite of what the user asked. The error names
/// the field, the point's index in the list and why.
fn check_reach_points(config: &Config, scene: &Scene, sdf: &Sdf) -> Result<()> {
    let crate::config::Reach::From(given) = &config.reachable else {
        return Ok(());
    };
    for (i, p) in given.iter().enumerate() {
        let local = scene.to_local(DVec3::from(p.0));
        let [x, y, z] = p.0;
        let point = format!("point {i} ({x}, {y}, {z})");
        if sdf.voxel_at(local).is_none() {
            let (lo, hi) = (sdf.origin, sdf.origin + sdf.dims.as_vec3() * sdf.voxel_size);
            return Err(Error::User(format!(
                "reachable: {point} is outside the domain (the SDF's grid spans {:?} to {:?} in the scene's frame): it reaches nothing; move it into the free space a viewer stands in",
                lo.to_array(),
                hi.to_array()
            )));
        }
        if !crate::reachable::starts_from(sdf, local) {
            return Err(Error::User(format!(
                "reachable: {point} is inside solid geometry, with no free voxel within two voxels of it: it reaches nothing; move it into the free space a viewer stands in"
            )));
        }
    }
    Ok(())
}

/// The space `config.reachable` names ([`crate::reachable`]); every open
/// voxel outside it becomes [`sdf::VoxelClass::Outside`], so that no
/// placement puts a probe there and no coverage reference point stands
/// there. `None` for `Everywhere`, or without any seed, which change
/// nothing.
fn restrict_to_reach(
    config: &Config,
    scene: &Scene,
    bvh: &SceneBvh,
    sdf: &mut Sdf,
) -> Option<crate::reachable::Reachable> {
    let seeds = reach_seeds(config, scene).filter(|s| !s.is_empty())?;
    let reach = crate::reachable::reachable(sdf, bvh, &seeds, config.viewer_radius(sdf.voxel_size));
    for (class, &reached) in sdf.class.iter_mut().zip(&reach.mask) {
        if *class == sdf::VoxelClass::Free && !reached {
            *class = sdf::VoxelClass::Outside;
        }
    }
    Some(reach)
}

/// Refuses, before any of it runs, an SDF or a coverage reference whose
/// estimated work exceeds [`limits::work_limit_seconds`] (errors name the
/// field, unprefixed).
fn check_work(config: &Config, domain: &Bounds, voxel_size: f32) -> Result<()> {
    let dims = sdf::grid_dims(domain, voxel_size)?;
    let voxels = dims.x as f64 * dims.y as f64 * dims.z as f64;
    // The rate is at the default 32 classification rays a voxel.
    let rays = config.sdf.rays_per_voxel.0 as f64;
    limits::check_work(
        "voxel_size",
        &format!(
            "the SDF of {} voxels at {rays} rays each (sdf.rays_per_voxel)",
            crate::config::short(voxels)
        ),
        voxels * (rays / 32.0).max(1.0),
        limits::rate::SDF_VOXELS,
    )?;
    crate::coverage::check_work(&config.coverage, voxels)
}

/// The voxel size of `config` for `domain` of `scene`: the config's, or
/// the one [`resolution::auto`] chooses.
pub fn resolve_voxel_size(
    config: &Config,
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
) -> Resolution {
    match config.voxel_size {
        VoxelSize::Fixed(v) => Resolution::fixed(v.0),
        VoxelSize::Auto => resolution::auto(scene, bvh, domain, config.seed),
    }
}

/// The domain box in the scene's local coordinates: the scene bounds, or
/// the config's box (world coordinates), which must overlap the scene.
pub fn resolve_domain(domain: &Domain, scene: &Scene) -> Result<Bounds> {
    match domain {
        Domain::Auto => Ok(scene.bounds),
        Domain::Box(b) => {
            let d = Bounds {
                min: scene.to_local(DVec3::from_array(b.min)),
                max: scene.to_local(DVec3::from_array(b.max)),
            };
            let overlap =
                d.min.cmplt(scene.bounds.max).all() && d.max.cmpgt(scene.bounds.min).all();
            if !overlap {
                return Err(Error::User(format!(
                    "domain: box {}..{} does not overlap the scene bounds {}..{}",
                    short_all(&b.min),
                    short_all(&b.max),
                    short_all(&scene.to_world(scene.bounds.min).to_array()),
                    short_all(&scene.to_world(scene.bounds.max).to_array())
                )));
            }
            Ok(d)
        }
    }
}
