//! Arbitrary bytes as a mesh file: the first byte picks the format, the rest is the file.
#![no_main]

use libfuzzer_sys::fuzz_target;

const EXTENSIONS: [&str; 4] = ["ply", "obj", "stl", "off"];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else { return };
    let dir = std::env::temp_dir().join(format!("isoforge-fuzz-mesh-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("f.{}", EXTENSIONS[pick as usize % EXTENSIONS.len()]));
    if std::fs::write(&path, body).is_ok() {
        let _ = isoforge_io::read_mesh(&path, &isoforge_io::Limits::new(16 << 20));
    }
});
