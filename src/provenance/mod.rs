//! Provenance: what ties every file of a run to the inputs that made it.
//!
//! Each output carries the same four facts: the tool's version, a hash of
//! the config as resolved (command-line overrides applied), the seed, and a
//! hash of the scene's contents (the OBJ file, the MTL libraries it names
//! and, with `--probes`, the probe file). The JSON files write them as an
//! object; `svo.bin` and `lightfield.bin` as 32 bytes in their headers
//! (docs/formats.md). `--from DIR` reuses a file only when its provenance
//! equals the run's, so a light field can never be traced through an SVO of
//! another placement, nor a bake resumed on an edited scene.
//!
//! The hashes are 64-bit FNV-1a: fingerprints that tell runs apart, not a
//! defence against someone forging a file.

pub mod inputs;

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The tool and version every output names.
pub const TOOL: &str = concat!("probeplace ", env!("CARGO_PKG_VERSION"));

/// 64-bit FNV-1a, fed in pieces.
#[derive(Debug, Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xCBF2_9CE4_8422_2325)
    }
}

impl Fnv {
    /// Feeds `bytes`.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01B3);
        }
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// FNV-1a of `bytes`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = Fnv::default();
    h.write(bytes);
    h.finish()
}

/// What the command line changed in a config, kept so `--from DIR` can
/// rebuild the very config a directory was made with.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Overrides {
    /// `--method`.
    pub method: Option<String>,
    /// `--seed`.
    pub seed: Option<u64>,
    /// `--no-refine`.
    pub no_refine: bool,
    /// `--probes`, absolute.
    pub probes: Option<PathBuf>,
}

/// The provenance of a run's outputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// [`TOOL`] of the run.
    pub tool: String,
    /// FNV-1a of the resolved config, 16 hex digits.
    pub config_hash: String,
    /// The seed.
    pub seed: u64,
    /// FNV-1a of the scene's files (module docs), 16 hex digits.
    pub scene_hash: String,
    /// The config file as the command line named it, and the directory the
    /// run started in: with the text, what `--from DIR` reloads.
    pub config_given: PathBuf,
    /// The working directory of the run.
    pub cwd: PathBuf,
    /// The config file's text as read.
    pub config_text: String,
    /// The command line's overrides.
    pub overrides: Overrides,
}

/// What tells runs apart, without the config text: the four facts of
/// [`Provenance::to_bytes`], as `manifest.json` and the metadata of the
/// PNG and EXR files record them.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stamp {
    /// The tool and its version.
    pub tool: String,
    /// The config hash, 16 hex digits.
    pub config_hash: String,
    /// The scene hash, 16 hex digits.
    pub scene_hash: String,
    /// The seed.
    pub seed: u64,
}

impl Stamp {
    /// The four facts of `p`.
    pub fn of(p: &Provenance) -> Stamp {
        Stamp {
            tool: p.tool.clone(),
            config_hash: p.config_hash.clone(),
            scene_hash: p.scene_hash.clone(),
            seed: p.seed,
        }
    }

    /// The binary form written into `svo.bin` and `lightfield.bin`: config
    /// hash, scene hash, seed and the FNV-1a of the tool, each a
    /// little-endian u64.
    pub fn to_bytes(&self) -> ProvenanceBytes {
        let hex = |s: &str| u64::from_str_radix(s, 16).unwrap_or(0);
        let mut out = [0u8; 32];
        for (i, w) in [
            hex(&self.config_hash),
            hex(&self.scene_hash),
            self.seed,
            fnv1a(self.tool.as_bytes()),
        ]
        .iter()
        .enumerate()
        {
            out[8 * i..8 * i + 8].copy_from_slice(&w.to_le_bytes());
        }
        out
    }

    /// The facts as key–value text, the form EXR header attributes and PNG
    /// text chunks keep them in (`probeplace.config_hash`, …), in the order
    /// [`Provenance::mismatch`] names a difference: seed before config, so
    /// a file of another seed says so.
    pub fn pairs(&self) -> [(&'static str, String); 4] {
        [
            ("probeplace.tool", self.tool.clone()),
            ("probeplace.seed", self.seed.to_string()),
            ("probeplace.scene_hash", self.scene_hash.clone()),
            ("probeplace.config_hash", self.config_hash.clone()),
        ]
    }

    /// Why `found` (read back from a file's metadata) is not this stamp,
    /// in words; `None` when it is.
    pub fn mismatch(&self, found: &[(String, String)]) -> Option<String> {
        for (key, want) in self.pairs() {
            match found.iter().find(|(k, _)| k == key) {
                Some((_, v)) if *v == want => {}
                Some((_, v)) => {
                    return Some(format!(
                        "its {key} is {v} where this run has {want}: it comes from another run"
                    ))
                }
                None => {
                    return Some(format!(
                        "carries no {key}: not written by this version of probeplace"
                    ))
                }
            }
        }
        None
    }
}

/// The 32 provenance bytes of the binary files: config hash, scene hash,
/// seed and the FNV-1a of [`TOOL`], each a little-endian u64.
pub type ProvenanceBytes = [u8; 32];

impl Provenance {
    /// The binary form written into `svo.bin` and `lightfield.bin`
    /// ([`Stamp::to_bytes`]).
    pub fn to_bytes(&self) -> ProvenanceBytes {
        Stamp::of(self).to_bytes()
    }

    /// Why outputs of `earlier` cannot be reused by this run, in words;
    /// `None` when they can. The first difference found is named, seed
    /// before config so `--seed 77` on a seed-1 directory says so.
    pub fn mismatch(&self, earlier: &Provenance) -> Option<String> {
        if earlier.tool != self.tool {
            return Some(format!(
                "was written by {}, this is {}",
                earlier.tool, self.tool
            ));
        }
        if earlier.seed != self.seed {
            return Some(format!(
                "was written with seed {}, this run has seed {}",
                earlier.seed, self.seed
            ));
        }
        if earlier.scene_hash != self.scene_hash {
            return Some(format!(
                "was written from other scene contents (scene hash {} against {} now)",
                earlier.scene_hash, self.scene_hash
            ));
        }
        if earlier.config_hash != self.config_hash {
            return Some(format!(
                "was written from another config (config hash {} against {} now)",
                earlier.config_hash, self.config_hash
            ));
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_matches_its_published_vectors() {
        assert_eq!(fnv1a(b""), 0xCBF2_9CE4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xAF63_DC4C_8601_EC8C);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_F739_67E8);
    }

    #[test]
    fn a_stamp_names_the_first_fact_that_differs() {
        let s = Stamp {
            tool: "probeplace 0.1.0".into(),
            config_hash: "00000000000000aa".into(),
            scene_hash: "00000000000000bb".into(),
            seed: 7,
        };
        let mut found: Vec<(String, String)> = s
            .pairs()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        assert_eq!(s.mismatch(&found), None);
        found[1].1 = "8".into();
        let m = s.mismatch(&found).unwrap();
        assert!(
            m.contains("probeplace.seed is 8 where this run has 7"),
            "{m}"
        );
        found[1].1 = "7".into();
        found.remove(3);
        assert!(s
            .mismatch(&found)
            .unwrap()
            .contains("carries no probeplace.config_hash"));
    }

    #[test]
    fn a_seed_mismatch_is_named_before_a_config_mismatch() {
        let p = Provenance {
            tool: TOOL.into(),
            config_hash: "00000000000000aa".into(),
            seed: 1,
            scene_hash: "0000000000000001".into(),
            config_given: PathBuf::from("c.ron"),
            cwd: PathBuf::new(),
            config_text: String::new(),
            overrides: Overrides::default(),
        };
        assert_eq!(p.mismatch(&p), None);
        let q = Provenance {
            seed: 77,
            config_hash: "00000000000000bb".into(),
            ..p.clone()
        };
        let why = q.mismatch(&p).unwrap();
        assert!(why.contains("seed 1") && why.contains("seed 77"), "{why}");
        assert_eq!(p.to_bytes()[16..24], 1u64.to_le_bytes());
    }
}
