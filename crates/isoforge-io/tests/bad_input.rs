//! Bad input never panics: the must-fail corpus errors, every prefix of a valid file errors or
//! reads, and arbitrary bytes error or read.

use std::path::{Path, PathBuf};

use isoforge_io::{read_mesh, read_volume, Limits, MeshFormat};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata")
}

fn read_any(path: &Path) -> Result<(), String> {
    let limits = Limits::new(64 << 20);
    let r = if MeshFormat::from_path(path).is_some() {
        read_mesh(path, &limits).map(|_| ())
    } else {
        read_volume(path, &limits).map(|_| ())
    };
    r.map_err(|e| e.to_string())
}

#[test]
fn must_fail_corpus_fails_with_a_message_naming_the_file() {
    let dir = testdata().join("bad");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match read_any(&path) {
            Ok(()) => panic!("{name}: read without error, but it is in the must-fail corpus"),
            Err(msg) => {
                assert!(
                    msg.contains(&name) || msg.contains("does_not_exist") || msg.contains("nowhere"),
                    "{name}: message does not name the file: {msg}"
                );
                assert!(!msg.contains('\n'), "{name}: message is not one line: {msg}");
            }
        }
        n += 1;
    }
    assert!(n >= 50, "corpus has only {n} files");
}

/// Specific messages users will see: field, value, and what to do.
#[test]
fn messages_name_the_field_and_value() {
    let bad = testdata().join("bad");
    let msg = |f: &str| read_any(&bad.join(f)).unwrap_err();
    assert!(
        msg("nrrd_negative_size.nrrd").contains("line 4: sizes \"512 512 -3\": sizes must be positive integers"),
        "{}",
        msg("nrrd_negative_size.nrrd")
    );
    assert!(msg("nrrd_truncated_raw.nrrd").contains("10 of the 64 bytes"));
    assert!(msg("nrrd_unknown_type.nrrd").contains("type \"complex128\""));
    assert!(msg("nrrd_huge_sizes.nrrd").contains("over the limit"));
    assert!(msg("nrrd_overflow_sizes.nrrd").contains("overflows"));
    assert!(msg("nrrd_nan.nrrd").contains("sample (1, 1, 0) is NaN"), "{}", msg("nrrd_nan.nrrd"));
    assert!(msg("nifti_complex_datatype.nii").contains("datatype 32"));
    assert!(msg("ply_index_out_of_range.ply").contains("face 0: vertex index 7"));
    assert!(msg("mrc_negative_nx.mrc").contains("NX = -4"));
    assert!(msg("mrc_complex_mode.mrc").contains("MODE 4"));
    assert!(msg("mrc_permuted_axes.mrc").contains("MAPC MAPR MAPS = [3, 1, 2]"));
    assert!(
        msg("mrc_truncated_data.mrc").contains("map data ends after 100 of the 256 bytes"),
        "{}",
        msg("mrc_truncated_data.mrc")
    );
    assert!(msg("mrc_nan.mrc").contains("sample (1, 1, 0) is NaN"), "{}", msg("mrc_nan.mrc"));
    assert!(msg("vtk_point_count_mismatch.vtk").contains("POINT_DATA 9"));
    assert!(msg("vtk_bad_number.vtk").contains("value 3 \"x\""), "{}", msg("vtk_bad_number.vtk"));
    assert!(msg("vtk_polydata.vtk").contains("DATASET POLYDATA"));
    assert!(msg("vtk_bad_dims.vtk").contains("line 5: DIMENSIONS"));
    assert!(msg("vti_polydata.vti").contains("VTKFile type \"PolyData\""));
    assert!(msg("vti_bad_extent.vti").contains("WholeExtent"));
    assert!(msg("vti_lz4.vti").contains("vtkLZ4DataCompressor"));
    assert!(msg("vti_vectors.vti").contains("3 components"));
    assert!(msg("vti_appended_offset_past_end.vti").contains("offset 999"));
    assert!(msg("vti_nan.vti").contains("is NaN"), "{}", msg("vti_nan.vti"));
}

/// Every prefix of each small valid file: an error or a value, never a panic.
#[test]
fn every_prefix_of_a_valid_file_errors_or_reads() {
    let dir = std::env::temp_dir().join(format!("isoforge-prefix-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files: Vec<PathBuf> = Vec::new();
    for sub in ["volumes", "meshes", "images"] {
        for e in std::fs::read_dir(testdata().join(sub)).unwrap() {
            let p = e.unwrap().path();
            let n = p.file_name().unwrap().to_string_lossy().into_owned();
            if !(n.ends_with(".json")
                || n.ends_with(".raw")
                || n.ends_with(".py")
                || n.starts_with("bunny")
                || n.starts_with("rgb"))
            {
                files.push(p);
            }
        }
    }
    for src in files {
        let bytes = std::fs::read(&src).unwrap();
        let name = src.file_name().unwrap().to_string_lossy().into_owned();
        // Detached headers need their data file beside them.
        for companion in ["u16_detached.raw", "f64_external.raw"] {
            let _ = std::fs::copy(src.with_file_name(companion), dir.join(companion));
        }
        let target = dir.join(&name);
        // Images are tens of kilobytes: every byte of the first 2 KB (headers), then a stride.
        let step = if bytes.len() > 16 << 10 { 61 } else { 1 };
        let lens = (0..=bytes.len()).filter(|&l| l < 2048 || l % step == 0 || l + 64 > bytes.len());
        for len in lens {
            std::fs::write(&target, &bytes[..len]).unwrap();
            let _ = read_any(&target); // a panic fails the test
        }
        assert!(read_any(&target).is_ok(), "{name}: the whole file must read");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn config() -> Config {
    Config { cases: 400, rng_seed: RngSeed::Fixed(0x000b_ad1e), failure_persistence: None, ..Config::default() }
}

proptest! {
    #![proptest_config(config())]

    /// Arbitrary bytes behind a valid-looking start, for every reader: never a panic.
    #[test]
    fn arbitrary_bytes_never_panic(prefix in 0usize..6, tail in prop::collection::vec(any::<u8>(), 0..600)) {
        let starts: [(&str, &[u8]); 6] = [
            ("x.nrrd", b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\n\n"),
            ("x.nii", b""),
            ("x.mha", b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n"),
            ("x.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"),
            ("x.off", b"OFF\n3 1 0\n"),
            ("x.stl", b"solid s\n"),
        ];
        let dir = std::env::temp_dir().join(format!("isoforge-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (name, start) = starts[prefix];
        let p = dir.join(name);
        let mut bytes = start.to_vec();
        bytes.extend_from_slice(&tail);
        std::fs::write(&p, &bytes).unwrap();
        let _ = read_any(&p);
        // NIfTI: a header with random fields.
        let mut nii = vec![0u8; 352];
        nii[..4].copy_from_slice(&348i32.to_le_bytes());
        nii[344..348].copy_from_slice(b"n+1\0");
        for (i, b) in tail.iter().enumerate() {
            let at = [40, 42, 44, 46, 70, 72, 76, 80, 108, 112, 252, 254, 256, 280][i % 14] + (i / 14) % 4;
            if at < 344 { nii[at] = *b; }
        }
        let q = dir.join("y.nii");
        std::fs::write(&q, &nii).unwrap();
        let _ = read_any(&q);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
