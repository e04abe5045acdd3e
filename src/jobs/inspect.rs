//! The `inspect` job: reads an output directory's `svo.bin` (and its
//! `lightfield.bin`), checks them and that every file of the directory
//! comes from one run, and summarizes them.

use crate::error::{Error, Result};
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
/// checks it against the `probes.json` beside it when there is one.
///
/// Contract: a missing, truncated, corrupted or wrong-version file, or an
/// SVO whose probe count disagrees with `probes.json`, is an
/// [`Error::User`] naming the file.
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
    let probes_json = file.with_file_name("probes.json");
    if let Ok(text) = std::fs::read_to_string(&probes_json) {
        let count = serde_json::from_str::<serde_json::Value>(&text)
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
    Ok(Inspection {
        path: file,
        svo,
        light_field,
    })
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
