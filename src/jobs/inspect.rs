//! The `inspect` job: reads an output directory's `svo.bin` (and its
//! `lightfield.bin`), checks them, that every file of the directory comes
//! from one run and that none of the run's data files is missing, that
//! every file is the one its `manifest.json` records (and none is there
//! that it does not), and summarizes them.

use crate::error::{Error, Result};
use crate::output::manifest;
use crate::svo::Svo;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// What `probeplace inspect` found.
#[derive(Debug)]
pub struct Inspection {
    /// The `svo.bin` read.
    pub path: PathBuf,
    /// Its contents.
    pub svo: Svo,
    /// The `lightfield.bin` beside it, when there is one, checked too.
    pub light_field: Option<(PathBuf, crate::lightfield::LightField)>,
    /// The `svo.bin` was given alone, with no `report.json` beside it: only
    /// the file itself (and any `probes.json` or `lightfield.bin` beside
    /// it) was checked, not that a run is whole.
    pub alone: bool,
}

impl std::fmt::Display for Inspection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.svo;
        writeln!(
            f,
            "{}: {} probes, {} nodes ({} leaves), depth {}, {} bytes (a dense RGBA8 texture: {} bytes, {:.1}x more)",
            self.path.display(),
            s.probe_count,
            s.nodes(),
            s.leaves(),
            s.depth,
            s.bytes(),
            s.dense_bytes(),
            s.dense_bytes() as f64 / s.bytes() as f64
        )?;
        write!(
            f,
            "  leaf size {} over {} x {} x {} leaves from {:?}; at most {} probes per leaf; {} distinct lists; {} leaves without a visible probe",
            s.leaf_size,
            s.dims.x,
            s.dims.y,
            s.dims.z,
            s.world_origin().as_vec3().to_array(),
            s.max_probes,
            s.distinct_lists(),
            s.leaves_without_visible_probe
        )?;
        if self.alone {
            write!(
                f,
                "\n  no report.json beside it: checked alone, not as an output directory"
            )?;
        }
        if let Some((path, lf)) = &self.light_field {
            write!(
                f,
                "\n{}: {} probes, {}² maps with {} pyramid levels, {}² irradiance, {} bytes",
                path.display(),
                lf.positions.len(),
                lf.resolution,
                lf.pyramid.len(),
                lf.irradiance_resolution,
                lf.bytes()
            )?;
        }
        Ok(())
    }
}

/// Reads the `svo.bin` at `path`, or in the output directory `path`, and
/// checks it against the `probes.json` beside it. An output directory (one
/// given as `path`, or holding a `report.json` beside the file given) must
/// hold the whole run: a renderer given the directory would otherwise load
/// an octree without its probes.
///
/// Contract: a missing, truncated, corrupted or wrong-version file, an SVO
/// whose probe count disagrees with `probes.json`, or a file of the run
/// missing from an output directory (`report.json`, `probes.json`,
/// `lightfield.bin` when the report has a bake, any file it lists as
/// reused) is an [`Error::User`] naming the file.
pub fn inspect(path: &Path) -> Result<Inspection> {
    let file = if path.is_dir() {
        let f = path.join("svo.bin");
        if !f.exists() {
            return Err(Error::user_file(
                path,
                "holds no svo.bin (write one with probeplace place)",
            ));
        }
        f
    } else {
        path.to_path_buf()
    };
    let svo = Svo::read(&file)?;
    check_one_run(&file, &svo)?;
    let alone = !path.is_dir() && !file.with_file_name("report.json").exists();
    if !alone {
        check_whole(&file)?;
    }
    let probes_json = file.with_file_name("probes.json");
    // Read through `input::read` when it is there at all: a FIFO beside an
    // `svo.bin` given alone would block `read_to_string` for ever.
    let probes_text = match std::fs::metadata(&probes_json) {
        Ok(_) => Some(crate::input::read(
            &probes_json,
            "probes.json",
            crate::limits::memory_budget(),
        )?),
        Err(_) => None,
    };
    if let Some(text) = probes_text {
        let count = serde_json::from_slice::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v.get("probes").and_then(|p| p.as_array()).map(Vec::len));
        match count {
            Some(n) if n == svo.probe_count as usize => {}
            Some(n) => {
                return Err(Error::user_file(
                    &file,
                    format!(
                        "indexes {} probes but {} has {n}: the two come from different runs",
                        svo.probe_count,
                        probes_json.display()
                    ),
                ))
            }
            None => {
                return Err(Error::user_file(
                    &probes_json,
                    "is not a probeplace probes file",
                ))
            }
        }
    }
    let lf_path = file.with_file_name("lightfield.bin");
    let light_field = if lf_path.exists() {
        let field = crate::lightfield::LightField::read(&lf_path)?;
        if field.provenance != svo.provenance {
            return Err(Error::user_file(
                &lf_path,
                format!(
                    "comes from another run than {}: the two come from different runs",
                    file.display()
                ),
            ));
        }
        if field.positions.len() != svo.probe_count as usize {
            return Err(Error::user_file(
                &lf_path,
                format!(
                    "holds {} probes but {} indexes {}: the two come from different runs",
                    field.positions.len(),
                    file.display(),
                    svo.probe_count
                ),
            ));
        }
        Some((lf_path, field))
    } else {
        None
    };
    // Last: the checks above name what a damaged data file is; the
    // manifest then catches every other change, and files put there.
    if !alone {
        check_manifest(file.parent().unwrap_or(Path::new(".")), &svo)?;
    }
    Ok(Inspection {
        path: file,
        svo,
        light_field,
        alone,
    })
}

/// Checks that the output directory of `file` (an `svo.bin`) holds every
/// data file of its run: `report.json`, `probes.json`, `lightfield.bin`
/// when the report has a bake, and the files the report lists as reused.
fn check_whole(file: &Path) -> Result<()> {
    let missing = |name: &str, why: &str| {
        let path = file.with_file_name(name);
        match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => None,
            // There, but a FIFO, a directory or a device: say what it is
            // (in `input::open`'s words, which opens it without blocking),
            // not that it is missing.
            Ok(_) => Some(
                crate::input::open(&path, name, u64::MAX)
                    .err()
                    .unwrap_or_else(|| Error::user_file(&path, "is not a regular file")),
            ),
            Err(_) => Some(Error::user_file(
                &path,
                format!("missing, {why}: the directory holds part of a run (run the job again)"),
            )),
        }
    };
    let beside = format!("though {} is there", file.display());
    for name in ["report.json", "probes.json"] {
        if let Some(e) = missing(name, &beside) {
            return Err(e);
        }
    }
    let report_path = file.with_file_name("report.json");
    let report: Value = std::fs::read(&report_path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .ok_or_else(|| Error::user_file(&report_path, "is not a probeplace report"))?;
    if report["bake"].is_object() {
        if let Some(e) = missing("lightfield.bin", "though report.json records a bake") {
            return Err(e);
        }
    }
    for name in report["reused"].as_array().into_iter().flatten() {
        let Some(name) = name.as_str() else { continue };
        // Only a plain file name of the directory; anything else is not ours to look up.
        if Path::new(name).file_name() != Some(std::ffi::OsStr::new(name)) {
            continue;
        }
        if let Some(e) = missing(name, "though report.json lists it as reused") {
            return Err(e);
        }
    }
    Ok(())
}

/// Checks `dir` against its `manifest.json` ([`manifest::verify`]): every
/// file listed is there, whole and unchanged; no file is there that the
/// run did not write (a reference image copied in from another run would
/// pass for this one's); and the manifest records the run `svo` does.
fn check_manifest(dir: &Path, svo: &Svo) -> Result<()> {
    let listing = manifest::verify(dir, "run the job again")?;
    if let Some(stray) = manifest::unlisted(dir, &listing).first() {
        return Err(Error::user_file(
            stray,
            format!(
                "is not a file of the run ({} does not list it): remove it, or run the job again",
                manifest::NAME
            ),
        ));
    }
    if listing.provenance.as_ref().map(|p| p.to_bytes()) != Some(svo.provenance) {
        return Err(Error::user_file(
            &dir.join(manifest::NAME),
            "records another run than svo.bin: the two come from different runs",
        ));
    }
    Ok(())
}

/// Checks that the JSON files beside `file` (an `svo.bin`) carry the
/// provenance its header does: the directory holds one run.
fn check_one_run(file: &Path, svo: &Svo) -> Result<()> {
    for name in ["report.json", "probes.json", "compare.json"] {
        let path = file.with_file_name(name);
        let Ok(bytes) = crate::input::read(&path, name, crate::limits::memory_budget()) else {
            continue;
        };
        let value: Value = serde_json::from_slice(&bytes)
            .map_err(|e| Error::user_file(&path, format!("not JSON: {e}")))?;
        let provenance: Option<crate::provenance::Provenance> =
            serde_json::from_value(value["provenance"].clone()).ok();
        if provenance.map(|p| p.to_bytes()) != Some(svo.provenance) {
            return Err(Error::user_file(
                &path,
                format!(
                    "comes from another run than {}: the two come from different runs",
                    file.display()
                ),
            ));
        }
    }
    Ok(())
}
