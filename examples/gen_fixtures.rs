//! Regenerates the procedural fixtures in fixtures/ from src/fixtures/mod.rs:
//! `cargo run --example gen_fixtures`. A test checks the committed files match.

fn main() -> std::io::Result<()> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    std::fs::create_dir_all(&dir)?;
    for f in probeplace::fixtures::all() {
        std::fs::write(dir.join(format!("{}.obj", f.name)), &f.obj)?;
        std::fs::write(dir.join(format!("{}.mtl", f.name)), &f.mtl)?;
        println!("wrote fixtures/{}.obj and .mtl", f.name);
    }
    Ok(())
}
