//! The list of export formats: one line per format, `Variant => Type`,
//! where `Type` implements [`super::format::Format`] in the format's own
//! file. The config's `export` list (`export: [Variant, …]`), `--format`,
//! the file names, the refusals and docs/formats.md's table of formats
//! (`docs::`) derive from it (docs/layout.md, "Adding an export format").

use super::format::formats;

formats! {
    Glb => super::gltf::Glb,
    GlbWithScene => super::gltf::GlbWithScene,
    Tscn => super::godot::Tscn,
    Unity => super::unity::Unity,
    Ddgi => super::ddgi::Ddgi,
}

/// Adding a format, walked through with a toy: the type in `toy` (its own
/// file in the crate) and the one line `Toy => super::toy::Toy` of a list
/// give it a config form, a `--format` word, a file name, its refusals and
/// its bytes.
#[cfg(test)]
mod tests {
    mod toy {
        use crate::export::format::{Format, Planned};
        use crate::export::source::Source;
        use crate::scene::Scene;

        /// One line per probe: its position.
        pub struct Toy;

        impl Format for Toy {
            const WORD: &'static str = "toy";
            const FILE: &'static str = "probes.txt";
            const ABOUT: &'static str = "one line of text per probe";

            fn refuses_plan(plan: &Planned) -> Option<String> {
                plan.probes_file.then(|| "needs placed probes".to_string())
            }

            fn encode(source: &Source, _: Option<&Scene>) -> Result<Vec<u8>, String> {
                let lines: Vec<String> = source
                    .probes
                    .iter()
                    .map(|p| format!("{:?}\n", p.position))
                    .collect();
                Ok(lines.concat().into_bytes())
            }
        }
    }

    mod list {
        use crate::export::format::formats;

        formats! {
            Tscn => crate::export::godot::Tscn,
            Toy => super::toy::Toy,
        }
    }

    use crate::export::format::Planned;
    use crate::export::source::{Source, SourceProbe, WorldBox};
    use list::{Export, FORMATS};

    /// A source of two probes, as a run's files would give.
    fn source() -> Source {
        let probe = |x: f64| SourceProbe {
            position: [x, 1.0, 2.0],
            clearance: Some(0.5),
            influence: None,
            fixed: false,
        };
        Source {
            provenance: crate::provenance::Provenance {
                tool: crate::provenance::TOOL.into(),
                config_hash: "00000000000000aa".into(),
                seed: 1,
                scene_hash: "00000000000000bb".into(),
                config_given: "toy.ron".into(),
                cwd: ".".into(),
                config_text: String::new(),
                overrides: Default::default(),
            },
            method: "toy".into(),
            domain: WorldBox {
                min: [0.0; 3],
                max: [4.0; 3],
            },
            probes: vec![probe(0.5), probe(3.5)],
            stats: Default::default(),
            light: None,
            direct_included: false,
        }
    }

    #[test]
    fn a_toy_format_is_one_type_and_one_line_of_the_list() {
        // The config form.
        let list: Vec<Export> = ron::from_str("[Toy, Tscn]").unwrap();
        assert_eq!(list, [Export::Toy, Export::Tscn]);
        assert!(ron::from_str::<Vec<Export>>("[Fbx]").is_err());
        // The `--format` word, the file, the docs' row.
        assert_eq!(Export::of_word("toy", false), Some(Export::Toy));
        assert_eq!(Export::of_word("fbx", false), None);
        assert_eq!(Export::Toy.entry().file, "probes.txt");
        let words: Vec<&str> = FORMATS.iter().map(|f| f.word).collect();
        assert_eq!(words, ["tscn", "toy"]);
        // Its refusal of a plan, and its bytes.
        let placement = crate::placement::registry::Placement::default();
        let mut plan = Planned {
            placement: &placement,
            refined: true,
            controlled: false,
            probes_file: false,
        };
        assert_eq!(Export::Toy.refuses_plan(&plan), None);
        plan.probes_file = true;
        assert_eq!(
            Export::Toy.refuses_plan(&plan).as_deref(),
            Some("needs placed probes")
        );
        assert_eq!(Export::Toy.refuses(&source()), None);
        let bytes = Export::Toy.encode(&source(), None).unwrap();
        assert_eq!(bytes, b"[0.5, 1.0, 2.0]\n[3.5, 1.0, 2.0]\n");
        assert!(Export::Tscn.encode(&source(), None).is_ok());
    }

    /// The crate's own list: the config's variants and `--format`'s words
    /// that docs/config.md and the README name, and `--scene`'s pick.
    #[test]
    fn the_list_reads_the_config_and_command_line_forms_it_always_read() {
        use super::{Export, FORMATS};
        let variants: Vec<&str> = FORMATS.iter().map(|f| f.variant).collect();
        assert_eq!(variants, ["Glb", "GlbWithScene", "Tscn", "Unity", "Ddgi"]);
        let list: Vec<Export> = ron::from_str("[Glb, GlbWithScene, Tscn, Unity, Ddgi]").unwrap();
        assert_eq!(list, Export::ALL);
        assert_eq!(Export::of_word("glb", false), Some(Export::Glb));
        assert_eq!(Export::of_word("glb", true), Some(Export::GlbWithScene));
        assert_eq!(Export::of_word("tscn", true), Some(Export::Tscn));
        let files: Vec<&str> = Export::ALL.iter().map(|e| e.entry().file).collect();
        assert_eq!(
            files,
            [
                "probes.glb",
                "probes.glb",
                "probes.tscn",
                "probes.unity.json",
                "ddgi.json"
            ]
        );
        // A format holding the scene refuses to encode without it.
        assert!(Export::GlbWithScene.encode(&source(), None).is_err());
    }

    /// docs/formats.md's table of export formats is this list: a format
    /// added without its row, or a row left for a removed one, fails here
    /// with the block to paste.
    #[test]
    fn the_formats_table_is_the_registrys_list() {
        use super::FORMATS;
        let mut block =
            String::from("| config `export` | `--format` | file | what |\n|---|---|---|---|\n");
        for f in FORMATS {
            let word = match f.scene {
                true => format!("`{} --scene`", f.word),
                false => format!("`{}`", f.word),
            };
            block += &format!(
                "| `{}` | {word} | `{}` | {} |\n",
                f.variant, f.file, f.about
            );
        }
        crate::doc_blocks::assert_doc_block("formats.md", "formats", &block);
    }
}
