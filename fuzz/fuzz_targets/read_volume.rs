//! Arbitrary bytes as a volume file: the first byte picks the format, the rest is the file.
//! Every outcome but a panic (or an allocation past the limit) is fine.
#![no_main]

use libfuzzer_sys::fuzz_target;

const EXTENSIONS: [&str; 5] = ["nrrd", "nhdr", "nii", "nii.gz", "mha"];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else { return };
    let dir = std::env::temp_dir().join(format!("isoforge-fuzz-volume-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("f.{}", EXTENSIONS[pick as usize % EXTENSIONS.len()]));
    if std::fs::write(&path, body).is_ok() {
        let _ = isoforge_io::read_volume(&path, &isoforge_io::Limits::new(16 << 20));
    }
});
