//! A run's inputs: which files it reads ([`input_files`]) and the hashes
//! of them and of its config that make its [`Provenance`].

use super::{fnv1a, Fnv, Overrides, Provenance, TOOL};
use crate::config::Config;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

impl Provenance {
    /// The provenance of a run of `config` (read from `config_path`, whose
    /// text was `config_text`, then changed by `overrides`).
    ///
    /// Contract: reads the scene's files (and the probe file); a missing one
    /// is a user error naming it. Paths in the config and the output
    /// directory do not enter the config hash, so the same run started from
    /// another directory has the same provenance.
    pub fn of(
        config: &Config,
        config_path: &Path,
        config_text: &str,
        overrides: &Overrides,
    ) -> Result<Provenance> {
        let files = input_files(config, overrides);
        Provenance::of_files(config, config_path, config_text, overrides, &files)
    }

    /// [`Provenance::of`] for a caller that has the run's input files,
    /// [`input_files`]`(config, overrides)`, already (finding them reads
    /// the whole scene file for its `mtllib` lines).
    pub fn of_files(
        config: &Config,
        config_path: &Path,
        config_text: &str,
        overrides: &Overrides,
        files: &[InputFile],
    ) -> Result<Provenance> {
        let mut scene = Fnv::default();
        let gltf = crate::scene::is_gltf(&config.scene);
        for (i, InputFile { path: file, what }) in files.iter().enumerate() {
            let what = *what;
            // Text: an OBJ and its MTLs; binary by nature: the rest.
            let binary = !matches!(what, "scene file" | "material library") || gltf;
            let (mut f, size) = crate::input::open(file, what, u64::MAX)?;
            scene.write(&size.to_le_bytes());
            let mut chunk = vec![0u8; 1 << 16];
            let mut read = 0u64;
            while read < size {
                let n = std::io::Read::read(&mut f, &mut chunk)
                    .map_err(|e| Error::user_file(file, format!("cannot read {what}: {e}")))?;
                if n == 0 {
                    break;
                }
                let n = n.min((size - read) as usize);
                // A binary scene is refused here, before hashing gigabytes
                // of it, with the line the loader would name.
                if let (false, Some(at)) = (binary, memchr::memchr(0, &chunk[..n])) {
                    let line = crate::input::line_at(file, read + at as u64);
                    return Err(crate::input::not_text(
                        file,
                        line,
                        if i == 0 { "an OBJ" } else { "an MTL" },
                    ));
                }
                scene.write(&chunk[..n]);
                read += n as u64;
            }
        }
        Ok(Provenance {
            tool: TOOL.to_string(),
            config_hash: format!("{:016x}", config_hash(config)),
            seed: config.seed,
            scene_hash: format!("{:016x}", scene.finish()),
            config_given: config_path.to_path_buf(),
            cwd: std::env::current_dir().unwrap_or_default(),
            config_text: config_text.to_string(),
            overrides: overrides.clone(),
        })
    }
}

/// FNV-1a of the config's parameters: its `Debug` form with the scene and
/// output paths blanked (the scene enters by content, the output not at
/// all) and the `export` list left out (it changes no output of the run,
/// only which files are written beside them, so `--from` reuses a run
/// whatever exports either asks for).
pub fn config_hash(config: &Config) -> u64 {
    let mut c = config.clone();
    c.scene = PathBuf::new();
    c.output = PathBuf::new();
    c.export = Vec::new();
    fnv1a(format!("{c:?}").as_bytes())
}

/// One file a run reads, and what it is to the run (in messages: "scene
/// file", "material library", "texture", "glTF buffer", "probe file").
#[derive(Debug, Clone, PartialEq)]
pub struct InputFile {
    /// Where it is.
    pub path: PathBuf,
    /// What it is.
    pub what: &'static str,
}

/// The files a run of `config` reads: the scene file, the MTL libraries an
/// OBJ names that exist (relative to the OBJ) and the textures they map
/// ([`texture_files`]), or the buffers and images a glTF names
/// ([`crate::scene::gltf::external_files`]), and the probe file of
/// `--probes`.
pub fn input_files(config: &Config, overrides: &Overrides) -> Vec<InputFile> {
    let file = |what| move |path| InputFile { path, what };
    let mut files = vec![file("scene file")(config.scene.clone())];
    if crate::scene::is_gltf(&config.scene) {
        files.extend(
            crate::scene::gltf::external_files(&config.scene)
                .into_iter()
                .map(file("glTF buffer")),
        );
    } else {
        let libraries = material_libraries(&config.scene);
        let textures = texture_files(&libraries);
        files.extend(libraries.into_iter().map(file("material library")));
        files.extend(textures.into_iter().map(file("texture")));
    }
    files.extend(overrides.probes.iter().cloned().map(file("probe file")));
    files
}

/// The image files the `map_Kd` and `map_Ke` statements of the MTL files
/// `libraries` name that exist (relative to each MTL, in the name's case
/// or another: [`crate::scene::texture::locate`]), each once. Best
/// effort, as [`material_libraries`]: a library that cannot be read names
/// none, and the loader says why.
pub fn texture_files(libraries: &[PathBuf]) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = Vec::new();
    for lib in libraries {
        let Ok(bytes) =
            crate::input::read(lib, "material library", crate::scene::obj::MAX_MTL_BYTES)
        else {
            continue;
        };
        let text = String::from_utf8_lossy(&bytes);
        let (_, maps, _) = crate::scene::obj::parse_mtl(&text, lib);
        for m in maps {
            // Where the loader finds it (another letter case included).
            if let Some((file, _)) = crate::scene::texture::locate(&m.file) {
                if !out.contains(&file) {
                    out.push(file);
                }
            }
        }
    }
    out
}

/// The `mtllib` files `obj` names that exist, relative to its directory.
pub fn material_libraries(obj: &Path) -> Vec<PathBuf> {
    let Ok((file, _)) = crate::input::open(obj, "scene file", u64::MAX) else {
        return Vec::new();
    };
    let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
    let dir = obj.parent().unwrap_or(Path::new(""));
    let mut out: Vec<PathBuf> = Vec::new();
    let mut line = Vec::new();
    // A line too long or binary ends the scan; the loader reports it.
    let mtllib = memchr::memmem::Finder::new(b"mtllib");
    while let Ok(Ok(true)) = crate::input::next_line(&mut reader, &mut line) {
        // Most lines name no library: only those holding the word are
        // decoded (a scene's millions of vertex lines were most of the
        // time before its load).
        if mtllib.find(&line).is_none() {
            continue;
        }
        let line = String::from_utf8_lossy(&line);
        let Some(rest) = line.trim_start().strip_prefix("mtllib") else {
            continue;
        };
        if !rest.starts_with(char::is_whitespace) {
            continue;
        }
        for name in rest.split('#').next().unwrap_or("").split_whitespace() {
            let p = dir.join(name);
            if p.is_file() && !out.contains(&p) {
                out.push(p);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_libraries_are_the_mtllib_lines_that_name_existing_files() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["a.mtl", "b.mtl", "c.mtl", "d.mtl", "e.mtl"] {
            std::fs::write(dir.path().join(name), "newmtl m\n").unwrap();
        }
        let mut obj = Vec::new();
        obj.extend_from_slice(b"v 0 0 0\n\xff\xfe not UTF-8 mtllibx\n");
        // Named after `#`, by a longer word, or not first: not libraries.
        obj.extend_from_slice(b"usemtl mtllib\nmtllibs d.mtl\n# mtllib d.mtl\n");
        obj.extend_from_slice(b"  mtllib b.mtl a.mtl # e.mtl\r\n");
        // Unicode whitespace before the keyword, a missing file, a repeat.
        obj.extend_from_slice("\u{3000}mtllib\tc.mtl missing.mtl b.mtl\n".as_bytes());
        obj.extend_from_slice(b"\xffmtllib e.mtl\nf 1 1 1\n");
        let path = dir.path().join("scene.obj");
        std::fs::write(&path, obj).unwrap();
        let names: Vec<String> = material_libraries(&path)
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["b.mtl", "a.mtl", "c.mtl"]);
    }

    /// The scene hash of a run of `config` reading `files`.
    fn scene_hash(config: &Config, files: &[InputFile]) -> String {
        Provenance::of_files(config, Path::new("x.ron"), "", &Overrides::default(), files)
            .unwrap()
            .scene_hash
    }

    #[test]
    fn an_obj_reads_the_textures_its_libraries_map() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("a.mtl"),
            "newmtl m\nmap_Kd -s 2 2 tex.png\nmap_Ke gone.png\nnewmtl n\nmap_Kd tex.png\n",
        )
        .unwrap();
        std::fs::write(dir.path().join("tex.png"), b"\x89PNG\0\x01").unwrap();
        let obj = dir.path().join("scene.obj");
        std::fs::write(&obj, "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let config = Config::parse(
            &format!("(scene: {:?})", obj.display().to_string()),
            Path::new("x.ron"),
        )
        .unwrap();
        let files = input_files(&config, &Overrides::default());
        let kinds: Vec<(String, &str)> = files
            .iter()
            .map(|f| {
                (
                    f.path.file_name().unwrap().to_string_lossy().into_owned(),
                    f.what,
                )
            })
            .collect();
        assert_eq!(
            kinds,
            [
                ("scene.obj".to_string(), "scene file"),
                ("a.mtl".to_string(), "material library"),
                ("tex.png".to_string(), "texture")
            ]
        );
        // The image is hashed as binary, and a changed image changes the hash.
        let hash = || scene_hash(&config, &files);
        let before = hash();
        std::fs::write(dir.path().join("tex.png"), b"\x89PNG\0\x02").unwrap();
        assert_ne!(before, hash());
    }

    #[test]
    fn a_gltf_reads_the_buffers_and_images_it_names_beside_it() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["a b.bin", "tex.png"] {
            std::fs::write(dir.path().join(name), b"\0\x01").unwrap();
        }
        let doc = r#"{"asset": {"version": "2.0"},
            "buffers": [{"byteLength": 2, "uri": "a%20b.bin"}, {"byteLength": 1, "uri": "data:application/octet-stream;base64,AA=="},
                        {"byteLength": 1, "uri": "missing.bin"}, {"byteLength": 1, "uri": "https://example.com/x.bin"}],
            "images": [{"uri": "tex.png"}, {"uri": "a%20b.bin"}]}"#;
        let gltf = dir.path().join("scene.gltf");
        std::fs::write(&gltf, doc).unwrap();
        let config = Config::parse(
            &format!("(scene: {:?})", gltf.display().to_string()),
            Path::new("x.ron"),
        )
        .unwrap();
        let files = input_files(&config, &Overrides::default());
        let names: Vec<String> = files
            .iter()
            .map(|f| f.path.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["scene.gltf", "a b.bin", "tex.png"]);
        // Binary files are hashed, not refused as text with a NUL byte.
        let hash = || scene_hash(&config, &files);
        let before = hash();
        std::fs::write(dir.path().join("a b.bin"), b"\0\x02").unwrap();
        assert_ne!(before, hash(), "a changed buffer changes the scene's hash");
    }

    #[test]
    fn the_config_hash_ignores_paths_but_not_parameters() {
        let text = "(scene: \"a.obj\", seed: 1)";
        let a = Config::parse(text, Path::new("x.ron")).unwrap();
        let mut b = a.clone();
        b.scene = PathBuf::from("/elsewhere/a.obj");
        b.output = PathBuf::from("/tmp/out");
        assert_eq!(config_hash(&a), config_hash(&b));
        // Exports change no output of the run, only what is written beside.
        b.export = vec![crate::config::Export::Glb, crate::config::Export::Ddgi];
        assert_eq!(config_hash(&a), config_hash(&b));
        b.bake.samples.0 = a.bake.samples.0 + 1;
        assert_ne!(config_hash(&a), config_hash(&b));
    }
}
