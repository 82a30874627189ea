//! The command line end to end: exit codes, one-line errors naming the file, no partial output,
//! the peer-benchmark contract, and the real volumes in ../shared/data when present.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{fails, isoforge, p, stderr, testdata};

#[test]
fn demo_writes_a_watertight_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo.ply");
    let o = isoforge(&["demo", "-o", p(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("closed: yes   manifold: yes   oriented: yes"), "{text}");
    assert!(out.exists());
    let c = isoforge(&["check", p(&out), "--require", "watertight,no-degenerate"]);
    assert_eq!(c.status.code(), Some(0), "{}", String::from_utf8_lossy(&c.stdout));
}

#[test]
fn peer_contract_raw_f32_with_time_json() {
    // The exact command line of bench/peers: raw f32, voxel-index units, timing JSON.
    let dir = tempfile::tempdir().unwrap();
    let (raw, out, t) = (dir.path().join("v.raw"), dir.path().join("o.ply"), dir.path().join("t.json"));
    let n = 12u32;
    let mut bytes = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let d = [i, j, k].map(|x| x as f32 - 5.5);
                bytes.extend_from_slice(&((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 4.0).to_le_bytes());
            }
        }
    }
    std::fs::write(&raw, bytes).unwrap();
    let o = isoforge(&[
        "extract",
        "--input",
        p(&raw),
        "--dims",
        "12,12,12",
        "--dtype",
        "f32",
        "--iso",
        "0.0",
        "--method",
        "mc",
        "--output",
        p(&out),
        "--time-json",
        p(&t),
        "--threads",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&t).unwrap()).unwrap();
    assert!(j["seconds"].as_f64().unwrap() >= 0.0);
    let mesh = isoforge_io_read(&out);
    assert_eq!(j["triangles"].as_u64().unwrap() as usize, mesh.1);
    assert_eq!(j["vertices"].as_u64().unwrap() as usize, mesh.0);
    // Index units: every vertex within the lattice box [0, 11].
    let c = isoforge(&["check", p(&out), "--json", "--require", "watertight"]);
    assert_eq!(c.status.code(), Some(0));
    let r: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    for a in 0..3 {
        assert!(r["bounds"]["min"][a].as_f64().unwrap() > 1.0 && r["bounds"]["max"][a].as_f64().unwrap() < 10.0);
    }
    assert_eq!(r["genus"], 0);
}

/// (vertices, triangles) of a PLY as reported by `check --json`.
fn isoforge_io_read(path: &Path) -> (usize, usize) {
    let c = isoforge(&["check", p(path), "--json"]);
    let r: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    (r["vertices"].as_u64().unwrap() as usize, r["triangles"].as_u64().unwrap() as usize)
}

#[test]
fn bad_input_is_one_line_exit_2_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply");
    let bad = testdata().join("bad");
    let o = p(&out);
    fails(&["extract", "-i", "/nonexistent/vol.nrrd", "--iso", "1", "-o", o], "/nonexistent/vol.nrrd", &out);
    fails(
        &["extract", "-i", p(&bad.join("nrrd_truncated_raw.nrrd")), "--iso", "1", "-o", o],
        "nrrd_truncated_raw.nrrd: raw data ends after 10 of the 64 bytes",
        &out,
    );
    fails(
        &["extract", "-i", p(&bad.join("nrrd_unknown_type.nrrd")), "--iso", "1", "-o", o],
        "type \"complex128\"",
        &out,
    );
    fails(&["extract", "-i", p(&bad.join("nrrd_overflow_sizes.nrrd")), "--iso", "1", "-o", o], "overflows", &out);
    fails(&["extract", "-i", p(&bad.join("nrrd_nan.nrrd")), "--iso", "1", "-o", o], "sample (1, 1, 0) is NaN", &out);
    let vol = testdata().join("volumes/u8_raw.nrrd");
    fails(&["extract", "-i", p(&vol), "--iso", "1000", "-o", o], "iso 1000 is outside the value range [0, 22]", &out);
    fails(&["extract", "-i", p(&vol), "--iso", "nan", "-o", o], "--iso", &out);
    fails(&["extract", "-i", p(&vol), "-o", o], "--iso is required", &out);
    let raw = dir.path().join("x.raw");
    std::fs::write(&raw, [0u8; 64]).unwrap();
    fails(
        &["extract", "-i", p(&raw), "--dims", "4,4,4", "--dtype", "q16", "--iso", "1", "-o", o],
        "--dtype \"q16\": unknown sample type",
        &out,
    );
    fails(
        &["extract", "-i", p(&raw), "--dims", "4,4,5", "--dtype", "u8", "--iso", "1", "-o", o],
        "file has 64 bytes",
        &out,
    );
    fails(
        &[
            "extract",
            "-i",
            p(&raw),
            "--dims",
            "4294967295,4294967295,4294967295",
            "--dtype",
            "f64",
            "--iso",
            "1",
            "-o",
            o,
        ],
        "overflows",
        &out,
    );
    fails(&["extract", "-i", "field:sphere", "--iso", "5", "-o", o], "gives no surface", &out);
    fails(&["extract", "-i", "field:nosuch", "-o", o], "field:nosuch: unknown field", &out);
    fails(
        &["extract", "-i", "field:sphere", "-o", p(&dir.path().join("out.xyz"))],
        "unknown output format",
        &dir.path().join("out.xyz"),
    );
    fails(&["check", p(&bad.join("ply_index_out_of_range.ply"))], "ply_index_out_of_range.ply: face 0", &out);
    // The argument parser's own errors are one line too, tips kept.
    fails(&["extract", "-i", "field:sphere", "--is", "3", "-o", o], "similar argument exists: '--iso'", &out);
    fails(&["extract", "-i", "field:sphere"], "not provided: --output <OUTPUT>", &out);
    fails(&["extract", "-i", "field:sphere", "--threads", "x", "-o", o], "invalid value 'x' for '--threads", &out);
    // Unwritable output: an error naming it, nothing left.
    fails(&["extract", "-i", "field:sphere", "-o", "/nonexistent-dir/out.ply"], "/nonexistent-dir/out.ply", &out);
}

#[test]
fn check_exits_1_when_a_requested_guarantee_fails() {
    let dir = tempfile::tempdir().unwrap();
    let open = dir.path().join("open.off");
    std::fs::write(&open, "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n").unwrap();
    let o = isoforge(&["check", p(&open), "--require", "closed"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stdout).contains("boundary edges: 3"));
    let o = isoforge(&["check", p(&open), "--require", "oriented,manifold"]);
    assert_eq!(o.status.code(), Some(0));
}

#[test]
fn info_reports_geometry_and_a_suggested_iso() {
    let o = isoforge(&["info", p(&testdata().join("volumes/i16_sform_scaled.nii")), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["dims"], serde_json::json!([6, 5, 7]));
    assert_eq!(v["value_range"], serde_json::json!([-100.0, -56.0]));
    let iso = v["suggested_iso"].as_f64().unwrap();
    assert!(iso > -100.0 && iso < -56.0);
    let t = isoforge(&["info", "field:gyroid?n=16"]);
    assert!(String::from_utf8_lossy(&t.stdout).contains("16 x 16 x 16"));
}

#[test]
fn world_coordinates_follow_the_file_geometry() {
    // i16_sform_scaled.nii: x flipped (−0.8), origin (30, −12, 4): the mesh lies inside the world box.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ply");
    let vol = testdata().join("volumes/i16_sform_scaled.nii");
    let o = isoforge(&["extract", "-i", p(&vol), "--iso", "-80", "-o", p(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let c = isoforge(&["check", p(&out), "--json"]);
    let r: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    let (lo, hi) = ([26.0, -12.0, 4.0], [30.0, -8.8, 13.0]);
    for a in 0..3 {
        let (mn, mx) = (r["bounds"]["min"][a].as_f64().unwrap(), r["bounds"]["max"][a].as_f64().unwrap());
        assert!(mn >= lo[a] - 1e-4 && mx <= hi[a] + 1e-4, "axis {a}: [{mn}, {mx}] outside [{}, {}]", lo[a], hi[a]);
    }
    assert_eq!(r["oriented"], true);
}

/// Real CT volumes from ../shared/data: closed or open only at the lattice faces, manifold,
/// oriented, and inside the world box from the file's spacing and origin.
#[test]
fn real_volumes_mesh_cleanly() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/volumes");
    if !data.exists() {
        eprintln!("skipping: {} is absent", data.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Triangle counts of vtkFlyingEdges3D 9.7.2 at the same iso (bench/peers/real_volumes.py reproduces them).
    for (name, iso, triangles) in [
        ("vtk_headsq_quarter.nrrd", "500", Some(57_698)),
        ("volvis_engine_256x256x128.nrrd", "71.22", Some(590_984)),
        ("emd3197_subtomo_20.nrrd", "3.184", Some(4_332)),
        ("cthead_8bit_256x256x99.nrrd", "52.29", Some(484_602)),
    ] {
        let out = dir.path().join(format!("{name}.ply"));
        let o = isoforge(&[
            "extract",
            "-i",
            p(&data.join(name)),
            "--iso",
            iso,
            "-o",
            p(&out),
            "--normals",
            "none",
            "--method",
            "mc",
        ]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let info: serde_json::Value =
            serde_json::from_slice(&isoforge(&["info", p(&data.join(name)), "--json"]).stdout).unwrap();
        let c = isoforge(&["check", p(&out), "--json", "--examples", "100000", "--require", "manifold,oriented"]);
        assert_eq!(c.status.code(), Some(0), "{name}");
        let r: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
        if let Some(t) = triangles {
            assert_eq!(r["triangles"], t, "{name}: triangle count");
        }
        let (lo, hi) = (&info["world_bounds"]["min"], &info["world_bounds"]["max"]);
        let sp = &info["spacing"];
        for a in 0..3 {
            assert!(r["bounds"]["min"][a].as_f64().unwrap() >= lo[a].as_f64().unwrap() - 1e-3);
            assert!(r["bounds"]["max"][a].as_f64().unwrap() <= hi[a].as_f64().unwrap() + 1e-3);
        }
        // Every boundary edge lies on a face of the world box.
        for e in r["findings"]["boundary_edges"]["examples"].as_array().unwrap() {
            let m = &e["midpoint"];
            let on_face = (0..3).any(|a| {
                let x = m[a].as_f64().unwrap();
                let tol = 1e-3 * sp[a].as_f64().unwrap();
                (x - lo[a].as_f64().unwrap()).abs() < tol || (x - hi[a].as_f64().unwrap()).abs() < tol
            });
            assert!(on_face, "{name}: boundary edge inside the volume: {e}");
        }
    }
}

/// Issue 3: the output is byte-identical for every thread count (Flying Edges writes at offsets
/// fixed by prefix sums, not in completion order).
#[test]
fn output_is_byte_identical_for_1_and_2_threads() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("g.raw");
    let n = 72u32;
    let mut bytes = Vec::with_capacity((n * n * n * 4) as usize);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let [x, y, z] = [i, j, k].map(|c| c as f32 * 0.35);
                bytes.extend_from_slice(&(x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos()).to_le_bytes());
            }
        }
    }
    std::fs::write(&raw, bytes).unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        for normals in ["none", "gradient"] {
            let out = dir.path().join(format!("t{threads}-{normals}.ply"));
            let o = isoforge(&[
                "extract",
                "-i",
                p(&raw),
                "--dims",
                "72,72,72",
                "--dtype",
                "f32",
                "--iso",
                "0.1",
                "--normals",
                normals,
                "-o",
                p(&out),
                "--threads",
                threads,
            ]);
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
            outputs.push((threads, normals, std::fs::read(&out).unwrap()));
        }
    }
    assert!(outputs[0].2.len() > 100_000, "the test volume should give a sizeable mesh");
    assert_eq!(outputs[0].2, outputs[2].2, "normals none: threads 1 vs 2 differ");
    assert_eq!(outputs[1].2, outputs[3].2, "normals gradient: threads 1 vs 2 differ");
    let bad = isoforge(&["--threads", "0", "demo", "-o", p(&dir.path().join("d.ply"))]);
    assert_eq!(bad.status.code(), Some(2));
}

/// Issue 3: with a memory budget the volume is meshed slab by slab, and the streamed mesh equals
/// the in-memory one (same vertices, normals and triangles, in the same order).
#[test]
fn streamed_mesh_equals_in_memory_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("ct.raw");
    let [nx, ny, nz] = [70u32, 40, 33];
    let mut bytes = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (x, y, z) = (i as f32 - 35.0, j as f32 - 20.0, k as f32 - 16.0);
                let v = 1000.0 + 600.0 * ((x * 0.21).sin() + (y * 0.27).cos() + (z * 0.31).sin())
                    - 2.0 * (x * x + y * y + z * z).sqrt();
                bytes.extend_from_slice(&(v.max(0.0) as u16).to_le_bytes());
            }
        }
    }
    std::fs::write(&raw, &bytes).unwrap();
    let read = |path: &Path| -> isoforge::mesh::Mesh {
        isoforge_io::read_mesh(path, &isoforge_io::Limits::default()).unwrap()
    };
    for normals in ["none", "gradient"] {
        let (mem, streamed) =
            (dir.path().join(format!("mem-{normals}.ply")), dir.path().join(format!("stream-{normals}.ply")));
        let base =
            ["extract", "-i", p(&raw), "--dims", "70,40,33", "--dtype", "u16", "--iso", "1000.5", "--normals", normals];
        let o = isoforge(&[&base[..], &["-o", p(&mem)]].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let t = dir.path().join("t.json");
        let o = isoforge(&[&base[..], &["-o", p(&streamed), "--max-memory", "8M", "--time-json", p(&t)]].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(stderr(&o).contains("streamed slab by slab"), "{}", stderr(&o));
        let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&t).unwrap()).unwrap();
        assert_eq!(j["streamed"], true);
        let (a, b) = (read(&mem), read(&streamed));
        assert!(a.num_triangles() > 1000);
        assert_eq!(a.positions, b.positions, "normals {normals}");
        assert_eq!(a.triangles, b.triangles, "normals {normals}");
    }
    // Out-of-core runs of the raw volume into `out` with `extra` flags.
    let out_of_core = |extra: &[&str], out: &Path| -> Vec<String> {
        let base = ["extract", "-i", p(&raw), "--dims", "70,40,33", "--dtype", "u16", "--max-memory", "8M"];
        base.iter().chain(extra).copied().chain(["-o", p(out)]).map(String::from).collect()
    };
    let fails_out_of_core = |extra: &[&str], name: &str, message: &str| {
        let out = dir.path().join(name);
        let args = out_of_core(extra, &out);
        fails(&args.iter().map(String::as_str).collect::<Vec<_>>(), message, &out);
    };
    // A streamed extraction that fails leaves nothing behind.
    fails_out_of_core(&["--iso", "99999"], "none.ply", "is outside the value range");
    // What samples or colours the whole mesh cannot be honoured slab by slab: refused, not dropped.
    let attr = format!("self={}", p(&raw));
    fails_out_of_core(
        &["--iso", "1000.5", "--attribute", &attr, "--color-by", "self"],
        "attr.ply",
        "--attribute, --color-by need the volume and mesh in memory (drop --max-memory)",
    );
    // A .gltf streams too, its buffer beside it.
    let gltf = dir.path().join("x.gltf");
    let o = isoforge(&out_of_core(&["--iso", "1000.5"], &gltf).iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("streamed slab by slab"), "{}", stderr(&o));
    let json = std::fs::read_to_string(&gltf).unwrap();
    assert!(json.contains(r#""uri":"x.bin""#), "{json}");
    assert!(std::fs::metadata(dir.path().join("x.bin")).unwrap().len() > 10_000);
}

/// Several isos out of core: a file per iso, each streamed (the volume read once per iso), each
/// byte for byte the in-memory run's, all appearing together; several isos into one glTF or OBJ
/// file are refused (their meshes would be held together).
#[test]
fn several_isos_stream_out_of_core_a_file_each() {
    let dir = tempfile::tempdir().unwrap();
    let gz = testdata().join("volumes/i16_gzip.nrrd");
    let (mem_dir, stream_dir) = (dir.path().join("mem"), dir.path().join("stream"));
    std::fs::create_dir_all(&mem_dir).unwrap();
    std::fs::create_dir_all(&stream_dir).unwrap();
    let isos = ["0.5", "-0.25", "1.5"];
    for (method, ext) in [("mc", "ply"), ("mc33", "stl"), ("mt-bcc", "off")] {
        let run = |out: &Path, extra: &[&str]| {
            let (o, t) = (out.join(format!("m.{ext}")), out.join("t.json"));
            let args = [&["extract", "-i", p(&gz), "--iso", "0.5,-0.25,1.5", "--method", method][..], extra]
                .concat()
                .into_iter()
                .chain(["-o", p(&o), "--time-json", p(&t), "--require", "oriented"])
                .collect::<Vec<_>>();
            let o = isoforge(&args);
            assert_eq!(o.status.code(), Some(0), "{method}: {}", stderr(&o));
            (stderr(&o), String::from_utf8_lossy(&o.stdout).into_owned())
        };
        let ((mem, mem_report), (streamed, streamed_report)) =
            (run(&mem_dir, &[]), run(&stream_dir, &["--max-memory", "8M"]));
        assert!(!mem.contains("streamed"), "{mem}");
        assert_eq!(streamed.matches("streamed slab by slab").count(), 3, "{streamed}");
        // --require's report of every file, in iso order, as in memory.
        assert_eq!(streamed_report.matches("components").count(), 3, "{streamed_report}");
        assert_eq!(mem_report, streamed_report, "{method}: the check reports differ");
        for iso in isos {
            let file = format!("m-{iso}.{ext}");
            let (a, b) = (std::fs::read(mem_dir.join(&file)).unwrap(), std::fs::read(stream_dir.join(&file)).unwrap());
            assert!(a.len() > 500 && a == b, "{method} iso {iso}: the streamed {ext} differs from the in-memory one");
            let t: serde_json::Value =
                serde_json::from_slice(&std::fs::read(stream_dir.join(format!("t-{iso}.json"))).unwrap()).unwrap();
            assert_eq!(t["streamed"], true, "{t}");
        }
    }
    // A guarantee that fails (the surfaces reach the lattice's faces): every file is written and
    // named in its own verdict, exit 1.
    let open = dir.path().join("open");
    std::fs::create_dir_all(&open).unwrap();
    let o = isoforge(&[
        "extract",
        "-i",
        p(&gz),
        "--iso",
        "0.5,1.5",
        "--max-memory",
        "8M",
        "--require",
        "closed",
        "-o",
        p(&open.join("m.ply")),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    for iso in ["0.5", "1.5"] {
        let file = open.join(format!("m-{iso}.ply"));
        assert!(file.exists(), "{}", file.display());
        let verdict = format!("{}: required but failed: closed", file.display());
        assert_eq!(stderr(&o).matches(&verdict).count(), 1, "{}", stderr(&o));
    }
    // A failing iso (outside the values) leaves none of the files.
    let none = dir.path().join("none");
    std::fs::create_dir_all(&none).unwrap();
    let o =
        isoforge(&["extract", "-i", p(&gz), "--iso", "0.5,99999", "--max-memory", "8M", "-o", p(&none.join("m.ply"))]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is outside the value range"), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(&none).unwrap().count(), 0, "a failed run leaves nothing");
    for ext in ["glb", "obj"] {
        let out = none.join(format!("m.{ext}"));
        fails(
            &["extract", "-i", p(&gz), "--iso", "0.5,1.5", "--max-memory", "8M", "-o", p(&out)],
            "several isos in one",
            &out,
        );
    }
}

/// Issue 11: a volume file that streams (binary NRRD, raw, NIfTI, …) is meshed slab by slab by
/// default, decoding ahead in a background thread, and the binary PLY, STL, OBJ, OFF or glTF is
/// byte for byte the in-memory one (`--time-json` keeps the extraction in memory: its seconds are the extraction's
/// alone). STL's quads are split after all triangles on both paths.
#[test]
fn streaming_by_default_gives_the_in_memory_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("ct.raw");
    let [nx, ny, nz] = [61u32, 47, 29];
    let mut bytes = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (x, y, z) = (i as f32 - 30.0, j as f32 - 23.0, k as f32 - 14.0);
                let v = 1000.0 + 500.0 * ((x * 0.23).sin() + (y * 0.19).cos() + (z * 0.37).sin())
                    - 3.0 * (x * x + y * y + z * z).sqrt();
                bytes.extend_from_slice(&(v.max(0.0) as i16).to_le_bytes());
            }
        }
    }
    std::fs::write(&raw, &bytes).unwrap();
    let raw_args = ["-i", p(&raw), "--dims", "61,47,29", "--dtype", "i16"];
    let gz = testdata().join("volumes/i16_gzip.nrrd");
    let gz_args = ["-i", p(&gz)];
    // mt-bcc: polygons using the batch before (segments from the centres of the cells below).
    let runs = [
        ("mc", "1", "none"),
        ("mc", "2", "none"),
        ("mc", "2", "gradient"),
        ("surface-nets", "1", "none"),
        ("dc", "2", "gradient"),
        ("emc", "1", "gradient"),
        ("mt-bcc", "2", "none"),
        ("mc33", "2", "none"),
    ];
    let cases = [("raw", &raw_args[..], "1000.5"), ("gzip", &gz_args[..], "0.5")];
    // Each path writes into its own folder, under the same names (a .gltf holds its .bin's name).
    let (stream_dir, mem_dir) = (dir.path().join("stream"), dir.path().join("mem"));
    std::fs::create_dir_all(&stream_dir).unwrap();
    std::fs::create_dir_all(&mem_dir).unwrap();
    for ((name, input, iso), ext) in
        cases.into_iter().flat_map(|c| ["ply", "stl", "obj", "off", "glb", "gltf"].map(|e| (c, e)))
    {
        for (method, threads, normals) in runs {
            let file = format!("{name}-{method}-{threads}-{normals}.{ext}");
            let (streamed, mem, t) = (stream_dir.join(&file), mem_dir.join(&file), dir.path().join("t.json"));
            let flags = ["--iso", iso, "--method", method, "--threads", threads, "--normals", normals];
            let base = [&["extract"][..], input, &flags[..]].concat();
            let o = isoforge(&[&base[..], &["-o", p(&streamed)]].concat());
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
            assert!(stderr(&o).contains("streamed slab by slab"), "{name}: {}", stderr(&o));
            let o = isoforge(&[&base[..], &["-o", p(&mem), "--time-json", p(&t)]].concat());
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
            assert!(!stderr(&o).contains("streamed"), "{}", stderr(&o));
            let (a, b) = (std::fs::read(&streamed).unwrap(), std::fs::read(&mem).unwrap());
            assert!(a.len() > 500, "{name}: a real mesh ({} bytes)", a.len());
            assert!(a == b, "{name} {method} threads {threads} normals {normals}: streamed and in-memory {ext} differ");
            if ext == "gltf" {
                let bin = |path: &Path| std::fs::read(path.with_extension("bin")).unwrap();
                assert!(bin(&streamed) == bin(&mem), "{name} {method}: streamed and in-memory .bin differ");
            }
            if method == "surface-nets" {
                // Quads on both paths (PLY and OBJ take polygons; STL and glTF split them), and
                // the file checks as a closed surface (`check` reads all but glTF; the validator
                // test reads a streamed .glb).
                let t: serde_json::Value = serde_json::from_slice(&std::fs::read(&t).unwrap()).unwrap();
                assert!(t["quads"].as_u64().unwrap() > 50, "{name}: {t}");
                assert_eq!(t["triangles"].as_u64(), Some(0), "{name}: {t}");
                assert!(stderr(&o).contains(" quads"), "{}", stderr(&o));
                if !ext.starts_with("gl") {
                    let c = isoforge(&["check", p(&streamed), "--require", "oriented"]);
                    assert_eq!(c.status.code(), Some(0), "{}", stderr(&c));
                }
            }
        }
    }
    // What needs the whole grid stays in memory, and ASCII-encoded volumes.
    let out = dir.path().join("roi.ply");
    let o = isoforge(
        &[&["extract"][..], &raw_args, &["--iso", "1000.5", "--roi", "0:40,0:40,0:20", "-o", p(&out)]].concat(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("streamed"), "{}", stderr(&o));
    let ascii = testdata().join("volumes/f64_ascii.nrrd");
    let o = isoforge(&["extract", "-i", p(&ascii), "--iso", "0.5", "-o", p(&out)]);
    assert!(!stderr(&o).contains("streamed"), "{}", stderr(&o));
}

/// Runs `contour --json` and returns its summary.
fn contour_summary(args: &[&str]) -> serde_json::Value {
    let o = isoforge(args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("contour --json prints JSON")
}

#[test]
fn contours_agree_with_scikit_image_on_real_slices() {
    // testdata/images/skimage.json: find_contours on the same PNGs (make_images.py). Its
    // fully_connected='low' joins the low (inside = below) corners of saddle cells, 'high' the
    // others; the same fixed rules here must give the same contours.
    let dir = tempfile::tempdir().unwrap();
    let images = testdata().join("images");
    let reference: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(images.join("skimage.json")).unwrap()).unwrap();
    let rows = reference["rows"].as_array().unwrap();
    assert!(rows.len() >= 12);
    for row in rows {
        let file = images.join(row["file"].as_str().unwrap());
        let level = row["level"].as_f64().unwrap().to_string();
        let rule = if row["fully_connected"] == "low" { "join-inside" } else { "join-outside" };
        let out = dir.path().join("c.geojson");
        let s = contour_summary(&["contour", p(&file), "--iso", &level, "--saddle", rule, "-o", p(&out), "--json"]);
        let (want_n, want_len) = (row["contours"].as_u64().unwrap(), row["length"].as_f64().unwrap());
        assert_eq!(s["contours"].as_u64().unwrap(), want_n, "{row}");
        assert_eq!(s["closed"].as_u64().unwrap(), row["closed"].as_u64().unwrap(), "{row}");
        let len = s["length"].as_f64().unwrap();
        assert!((len - want_len).abs() <= 1e-3 * want_len, "{row}: length {len}");
        // The GeoJSON holds those contours.
        let g: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(g["features"].as_array().unwrap().len() as u64, want_n);
    }
}

#[test]
fn contour_reads_png_tiff_and_volume_slices_alike() {
    let dir = tempfile::tempdir().unwrap();
    let images = testdata().join("images");
    let out = dir.path().join("c.csv");
    let o = p(&out);
    let png =
        contour_summary(&["contour", p(&images.join("bunny_z180_u16.png")), "--iso", "32768.5", "-o", o, "--json"]);
    let tif =
        contour_summary(&["contour", p(&images.join("bunny_z180_u16.tif")), "--iso", "32768.5", "-o", o, "--json"]);
    assert_eq!(png["length"], tif["length"]);
    assert_eq!(png["contours"], tif["contours"]);
    // Page 1 of the 3-page stack is engine_z64.png; the middle slice is the default.
    let page = contour_summary(&["contour", p(&images.join("stack3.tif")), "--iso", "150.5", "-o", o, "--json"]);
    let single = contour_summary(&["contour", p(&images.join("engine_z64.png")), "--iso", "150.5", "-o", o, "--json"]);
    assert_eq!(page["slice"], 1);
    assert_eq!(page["length"], single["length"]);
    // The decider closes every contour of the engine slice (its surface stays inside the image).
    assert_eq!(single["open"], 0);
    // A y-slice of a volume; CSV rows = points.
    let vol = testdata().join("volumes/u8_raw.nrrd");
    let s = contour_summary(&["contour", p(&vol), "--iso", "10.5", "--axis", "y", "--slice", "1", "-o", o, "--json"]);
    let rows = std::fs::read_to_string(&out).unwrap().lines().count() as u64;
    assert_eq!(rows, s["points"].as_u64().unwrap() + 1);
}

#[test]
fn contour_rejects_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.svg");
    let o = p(&out);
    let png = testdata().join("images/cthead_z50.png");
    fails(&["contour", p(&png), "--iso", "1000", "-o", o], "outside the value range", &out);
    fails(&["contour", p(&png), "--iso", "50", "--slice", "3", "-o", o], "--slice 3 is outside 0..1", &out);
    fails(&["contour", p(&png), "--iso", "50", "--saddle", "maybe", "-o", o], "--saddle \"maybe\"", &out);
    fails(&["contour", p(&png), "--iso", "50", "-o", p(&dir.path().join("c.pdf"))], "unknown contour format", &out);
    let bad = dir.path().join("bad.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    fails(&["contour", p(&bad), "--iso", "50", "-o", o], "bad.png", &out);
}

#[test]
fn several_isos_roi_close_and_index_space() {
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd"); // 6 x 5 x 7 u8, spacing 0.5 0.75 2, origin 10 -20 5.5
    let v = p(&vol);
    let out = |n: &str| dir.path().join(n);
    let run = |args: &[&str]| {
        let o = isoforge(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    };
    // Several isos: one file per value, each equal to its single-iso run.
    run(&["extract", "-i", v, "--iso", "5.5,10.5", "-o", p(&out("m.ply"))]);
    for iso in ["5.5", "10.5"] {
        run(&["extract", "-i", v, "--iso", iso, "-o", p(&out("single.ply"))]);
        let many = std::fs::read(out(&format!("m-{iso}.ply"))).unwrap();
        assert_eq!(many, std::fs::read(out("single.ply")).unwrap(), "iso {iso}");
    }
    // --close: the surface touches the volume's faces, so only the padded one is watertight.
    let c_ply = out("c.ply");
    let check = |extra: &[&str]| {
        let mut a = vec!["extract", "-i", v, "--iso", "10.5", "-o", p(&c_ply), "--require", "watertight"];
        a.extend_from_slice(extra);
        isoforge(&a).status.code()
    };
    assert_eq!(check(&[]), Some(1));
    assert_eq!(check(&["--close"]), Some(0));
    // --roi in index units and --roi-world covering the same points give the same mesh.
    run(&["extract", "-i", v, "--iso", "10.5", "--roi", "1:4,:,2:", "-o", p(&out("ri.ply"))]);
    run(&["extract", "-i", v, "--iso", "10.5", "--roi-world", "10.4:11.6,-20:-17,9.5:17.5", "-o", p(&out("rw.ply"))]);
    assert_eq!(std::fs::read(out("ri.ply")).unwrap(), std::fs::read(out("rw.ply")).unwrap());
    // --space index: the same surface in voxel indices of the input volume.
    run(&["extract", "-i", v, "--iso", "10.5", "--roi", "1:4,:,2:", "--space", "index", "-o", p(&out("ix.ply"))]);
    let world = isoforge_io::read_mesh(&out("ri.ply"), &isoforge_io::Limits::default()).unwrap();
    let index = isoforge_io::read_mesh(&out("ix.ply"), &isoforge_io::Limits::default()).unwrap();
    assert_eq!(world.triangles, index.triangles);
    for (w, x) in world.positions.iter().zip(&index.positions) {
        let back = [10.0 + 0.5 * x[0] as f64, -20.0 + 0.75 * x[1] as f64, 5.5 + 2.0 * x[2] as f64];
        for a in 0..3 {
            assert!((back[a] - w[a] as f64).abs() < 1e-4, "{x:?} ↦ {back:?}, written {w:?}");
        }
        assert!(x[0] >= 1.0 && x[0] <= 3.0 && x[2] >= 2.0, "{x:?} outside the ROI");
    }
    // Bad requests: one line, exit 2, no file.
    let o = out("bad.ply");
    fails(&["extract", "-i", v, "--iso", "10.5", "--roi", "1:9,:,:", "-o", p(&o)], "must satisfy lo < hi <= 6", &o);
    fails(&["extract", "-i", v, "--iso", "10.5", "--roi", "1:2,:", "-o", p(&o)], "expected three ranges", &o);
    fails(&["extract", "-i", v, "--iso", "10.5", "--space", "voxel", "-o", p(&o)], "--space \"voxel\"", &o);
    fails(&["extract", "-i", v, "--iso", "5.5,99", "-o", p(&o)], "iso 99 is outside the value range", &o);
    fails(&["extract", "-i", "field:sphere", "--close", "-o", p(&o)], "apply to volume files", &o);
}

#[test]
fn convert_keeps_samples_and_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let src = testdata().join("volumes/i16_gzip.nrrd");
    for ext in ["nrrd", "nii.gz"] {
        let out = dir.path().join(format!("c.{ext}"));
        let o = isoforge(&["convert", p(&src), p(&out)]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let info = |f: &Path| String::from_utf8(isoforge(&["info", p(f), "--json"]).stdout).unwrap();
        let (a, b): (serde_json::Value, serde_json::Value) =
            (serde_json::from_str(&info(&src)).unwrap(), serde_json::from_str(&info(&out)).unwrap());
        for key in ["dims", "type", "value_range", "mean"] {
            assert_eq!(a[key], b[key], "{ext}: {key}");
        }
    }
    let bad = dir.path().join("c.stl");
    fails(&["convert", p(&src), p(&bad)], "volumes are written as .nrrd, .nii or .nii.gz", &bad);
}

/// Vertex rows of an ASCII PLY: every number of each vertex line.
fn ascii_ply_vertices(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (head, body) = text.split_once("end_header\n").unwrap();
    let props: Vec<String> = head
        .lines()
        .skip_while(|l| !l.starts_with("element vertex"))
        .skip(1)
        .take_while(|l| l.starts_with("property"))
        .map(|l| l.rsplit(' ').next().unwrap().to_string())
        .collect();
    let n: usize = head.lines().find(|l| l.starts_with("element vertex")).unwrap()[15..].trim().parse().unwrap();
    let rows = body.lines().take(n).map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect()).collect();
    (props, rows)
}

#[test]
fn attributes_are_trilinear_samples_of_a_co_registered_volume() {
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd"); // spacing 0.5 0.75 2, origin 10 -20 5.5
    let src = isoforge_io::read_volume(&vol, &isoforge_io::Limits::default()).unwrap();
    // Two co-registered volumes whose trilinear interpolant is exact: a linear and a trilinear
    // function of world position.
    let lin = |w: [f64; 3]| 2.0 * w[0] - 3.0 * w[1] + 0.5 * w[2] + 7.0;
    let tri = |w: [f64; 3]| (w[0] - 11.0) * (w[1] + 18.0) * (w[2] - 9.0);
    for (name, f) in [("lin.nrrd", &lin as &dyn Fn([f64; 3]) -> f64), ("tri.nrrd", &tri)] {
        let l = src.lattice().clone();
        let g = isoforge::grid::DenseGrid::from_fn(l.clone(), |p| f(l.to_world(p.map(f64::from))) as f32);
        isoforge_io::write_volume(&dir.path().join(name), &g.into()).unwrap();
    }
    let out = dir.path().join("a.ply");
    let lin_path = dir.path().join("lin.nrrd");
    let tri_path = dir.path().join("tri.nrrd");
    let (la, ta) = (format!("lin={}", p(&lin_path)), format!("tri={}", p(&tri_path)));
    let args = ["extract", "-i", p(&vol), "--iso", "5.5,10.5", "--close", "-o", p(&out), "--ascii"];
    let mut all = args.to_vec();
    all.extend_from_slice(&["--attribute", &la, "--attribute", &ta, "--color-by", "lin", "--colormap", "gray"]);
    let o = isoforge(&all);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut checked = 0;
    for iso in ["5.5", "10.5"] {
        let (props, rows) = ascii_ply_vertices(&dir.path().join(format!("a-{iso}.ply")));
        assert_eq!(props, ["x", "y", "z", "red", "green", "blue", "lin", "tri"]);
        let (lo, hi) = rows.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| (a.min(r[6]), b.max(r[6])));
        for r in &rows {
            let w = [r[0], r[1], r[2]];
            // --close puts some vertices in the padding, outside the attribute volume (they get
            // the nearest value); the rest must be exact.
            let inside =
                (10.0..=12.5).contains(&w[0]) && (-20.0..=-17.0).contains(&w[1]) && (5.5..=17.5).contains(&w[2]);
            let grey = ((r[6] - lo) / (hi - lo) * 255.0).round();
            assert!(r[3] == r[4] && r[4] == r[5] && (r[3] - grey).abs() <= 1.0, "colour {r:?}");
            if !inside {
                continue;
            }
            assert!((r[6] - lin(w)).abs() < 1e-3 * (1.0 + lin(w).abs()), "lin at {w:?}: {} vs {}", r[6], lin(w));
            assert!((r[7] - tri(w)).abs() < 1e-3 * (1.0 + tri(w).abs()), "tri at {w:?}: {} vs {}", r[7], tri(w));
            checked += 1;
        }
    }
    assert!(checked >= 300, "only {checked} vertices checked");
    // Bad requests.
    let bad = dir.path().join("b.ply");
    fails(
        &["extract", "-i", p(&vol), "--iso", "5.5", "--color-by", "x", "-o", p(&bad)],
        "no --attribute x=VOLUME",
        &bad,
    );
    fails(
        &["extract", "-i", p(&vol), "--iso", "5.5", "--attribute", "lin", "-o", p(&bad)],
        "expected NAME=VOLUME",
        &bad,
    );
    let missing = format!("m={}", p(&dir.path().join("none.nrrd")));
    fails(&["extract", "-i", p(&vol), "--iso", "5.5", "--attribute", &missing, "-o", p(&bad)], "none.nrrd", &bad);
}

#[test]
fn gltf_output_passes_the_khronos_validator() {
    let tool = testdata().join("../tools/gltf-validator");
    if !tool.join("node_modules/gltf-validator").exists() {
        assert!(
            std::env::var_os("ISOFORGE_REQUIRE_GLTF_VALIDATOR").is_none(),
            "tools/gltf-validator is not installed (cd tools/gltf-validator && npm ci)"
        );
        eprintln!("skipped: tools/gltf-validator not installed (cd tools/gltf-validator && npm ci)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd");
    let v = p(&vol);
    let attr = format!("self={v}");
    let glb = dir.path().join("multi.glb");
    let gltf = dir.path().join("field.gltf");
    let colored = dir.path().join("colored.glb");
    let labels = dir.path().join("labels.glb");
    // One iso from a volume file: streamed, with surface nets' quads split; as .glb and .gltf.
    let streamed = dir.path().join("streamed.glb");
    let streamed_gltf = dir.path().join("streamed.gltf");
    for args in [
        vec!["extract", "-i", v, "--iso", "10.5", "--method", "mc33", "-o", p(&streamed_gltf)],
        vec![
            "extract",
            "-i",
            v,
            "--iso",
            "10.5",
            "--method",
            "surface-nets",
            "--normals",
            "gradient",
            "-o",
            p(&streamed),
        ],
        vec!["extract", "-i", v, "--labels", "5,10", "-o", p(&labels)],
        vec!["extract", "-i", v, "--iso", "5.5,10.5", "--close", "-o", p(&glb)],
        vec!["extract", "-i", "field:gyroid?n=24", "--normals", "gradient", "-o", p(&gltf)],
        vec!["extract", "-i", v, "--iso", "10.5", "--attribute", &attr, "--color-by", "self", "-o", p(&colored)],
    ] {
        let o = isoforge(&args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    }
    assert!(dir.path().join("field.bin").exists(), ".gltf writes its buffer beside it");
    let o = Command::new("node")
        .arg(tool.join("validate.mjs"))
        .args([&glb, &gltf, &colored, &labels, &streamed, &streamed_gltf])
        .output()
        .expect("node");
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "validator: {report}{}", stderr(&o));
    for line in report.lines() {
        let r: serde_json::Value = serde_json::from_str(line).unwrap();
        assert_eq!(r["numErrors"], 0, "{line}");
        assert_eq!(r["numWarnings"], 0, "{line}");
    }
    assert_eq!(report.lines().count(), 6);
}

#[test]
fn a_ct_coloured_by_a_co_registered_volume_samples_it_trilinearly() {
    // The CT head meshed at 70.5 and coloured by a second volume on the same grid, stored as
    // NIfTI: a nonlinear function of the CT plus a trilinear one of position. Needs ../shared/data.
    let ct = testdata().join("../../shared/data/volumes/cthead_8bit_256x256x99.nrrd");
    if !ct.exists() {
        eprintln!("skipped: {} is absent", ct.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let grid = isoforge_io::read_volume(&ct, &isoforge_io::Limits::default()).unwrap();
    let l = grid.lattice().clone();
    let second = isoforge::grid::DenseGrid::from_fn(l.clone(), |q| {
        let v = grid.get_f64(q);
        ((v / 40.0).sin() * 100.0 + 0.01 * (q[0] as f64) * (q[1] as f64) - 0.3 * q[2] as f64) as f32
    });
    let second_path = dir.path().join("second.nii.gz");
    isoforge_io::write_volume(&second_path, &second.clone().into()).unwrap();
    let out = dir.path().join("head.ply");
    let (a1, a2) = (format!("ct={}", p(&ct)), format!("second={}", p(&second_path)));
    let o = isoforge(&[
        "extract",
        "-i",
        p(&ct),
        "--iso",
        "70.5",
        "--attribute",
        &a1,
        "--attribute",
        &a2,
        "--color-by",
        "second",
        "--method",
        "mc", // every vertex on a lattice edge (mc33's interior vertices are not)
        "-o",
        p(&out),
        "--ascii",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (props, rows) = ascii_ply_vertices(&out);
    assert_eq!(props[3..], ["red", "green", "blue", "ct", "second"]);
    assert!(rows.len() > 100_000);
    // Every vertex lies on a lattice edge where the CT's linear interpolation is the iso value.
    for r in rows.iter().step_by(97) {
        assert!((r[6] - 70.5).abs() < 1e-3, "vertex {r:?}");
    }
    // The second volume: trilinear interpolation computed here, at a few hundred vertices.
    let trilinear = |w: [f64; 3]| {
        let p = l.to_index(w);
        let c = p.map(|x| x.floor());
        let mut v = 0.0;
        for k in 0..8u32 {
            let o = [k & 1, (k >> 1) & 1, (k >> 2) & 1];
            let q = [0, 1, 2].map(|a| (c[a] as u32 + o[a]).min(l.dims()[a] - 1));
            let wgt: f64 = (0..3).map(|a| if o[a] == 1 { p[a] - c[a] } else { 1.0 - (p[a] - c[a]) }).product();
            v += wgt * second.get(q) as f64;
        }
        v
    };
    let mut checked = 0;
    for r in rows.iter().step_by(rows.len() / 400) {
        let want = trilinear([r[0], r[1], r[2]]);
        assert!((r[7] - want).abs() < 1e-3 * (1.0 + want.abs()), "vertex {r:?}: {want}");
        checked += 1;
    }
    assert!(checked >= 300);
}

#[test]
fn label_volumes_give_one_tagged_surface_per_label() {
    let dir = tempfile::tempdir().unwrap();
    let l = isoforge::grid::Lattice::new([10, 8, 6]).unwrap();
    let g = isoforge::grid::DenseGrid::from_fn(l, |[i, j, _]| {
        if j > 5 {
            0u8
        } else if i < 4 {
            1
        } else {
            4
        }
    });
    let vol = dir.path().join("labels.nrrd");
    isoforge_io::write_volume(&vol, &g.into()).unwrap();
    let ply = dir.path().join("l.ply");
    let o =
        isoforge(&["extract", "-i", p(&vol), "--labels", "all", "-o", p(&ply), "--ascii", "--require", "watertight"]);
    // Each label surface is closed on its own; together they share the interface, so the
    // combined file is checked per label (the report) and exits 0.
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 label surfaces"), "{}", stderr(&o));
    let text = std::fs::read_to_string(&ply).unwrap();
    assert!(text.contains("property int label\n"));
    let faces: Vec<&str> = text.split_once("end_header\n").unwrap().1.lines().filter(|l| l.starts_with("3 ")).collect();
    assert!(faces.iter().any(|f| f.ends_with(" 1")) && faces.iter().any(|f| f.ends_with(" 4")));
    let bad = dir.path().join("bad.ply");
    fails(&["extract", "-i", p(&vol), "--labels", "2", "-o", p(&bad)], "label 2 does not occur", &bad);
}

#[test]
fn world_bounds_match_nibabel_and_pynrrd() {
    // testdata/world/expect.json: the bounding box of all iso crossings, placed in world space by
    // nibabel's affine or pynrrd's space directions (make_world.py). Rows for ../shared/data skip
    // when it is absent.
    let root = testdata().join("..");
    let expect: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(testdata().join("world/expect.json")).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (mut checked, mut worst) = (0, 0.0f64);
    for row in expect["rows"].as_array().unwrap() {
        let rel = row["file"].as_str().unwrap();
        let file = if let Some(rest) = rel.strip_prefix("shared/") {
            root.join("../shared").join(rest)
        } else {
            root.join(rel)
        };
        if !file.exists() {
            eprintln!("skipped: {} is absent", file.display());
            continue;
        }
        // The two 512² CTs take a minute of mesh checking in a debug build; their placement is
        // the same NRRD code path as the others (and matches VTK's bounds in real_volumes_mesh_cleanly).
        if std::fs::metadata(&file).unwrap().len() > 40 << 20 {
            eprintln!("skipped (size): {}", file.display());
            continue;
        }
        let out = dir.path().join("w.ply");
        let iso = row["iso"].as_f64().unwrap().to_string();
        let o = isoforge(&["extract", "-i", p(&file), "--iso", &iso, "-o", p(&out)]);
        assert_eq!(o.status.code(), Some(0), "{rel}: {}", stderr(&o));
        let report: serde_json::Value =
            serde_json::from_slice(&isoforge(&["check", p(&out), "--json"]).stdout).expect("check --json");
        let half = 0.5 * row["voxel"].as_f64().unwrap();
        for (key, ours) in [("min", &report["bounds"]["min"]), ("max", &report["bounds"]["max"])] {
            for a in 0..3 {
                let (want, got) = (row[key][a].as_f64().unwrap(), ours[a].as_f64().unwrap());
                worst = worst.max((want - got).abs() / (2.0 * half));
                assert!((want - got).abs() <= half, "{rel} ({}): {key}[{a}] {got} vs {want}", row["reader"]);
            }
        }
        checked += 1;
    }
    assert!(checked >= 7, "only {checked} volumes checked");
    eprintln!("world bounds: {checked} volumes, largest difference {worst:.2e} voxel");
}

/// The triangles of a mesh file as sorted position triples (vertex numbering aside).
fn triangle_set(path: &Path) -> Vec<[[u32; 3]; 3]> {
    let m = isoforge_io::read_mesh(path, &isoforge_io::Limits::default()).unwrap();
    let mut t: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let mut v = t.map(|i| m.positions[i as usize].map(f32::to_bits));
            let r = (0..3).min_by_key(|&k| v[k]).unwrap();
            v.rotate_left(r);
            v
        })
        .collect();
    t.sort();
    t
}

#[test]
fn a_mask_keeps_the_cells_whose_corners_are_all_in_it() {
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd"); // 6 x 5 x 7
    let v = p(&vol);
    let src = isoforge_io::read_volume(&vol, &isoforge_io::Limits::default()).unwrap();
    let l = src.lattice().clone();
    let write_mask = |name: &str, f: &dyn Fn([u32; 3]) -> bool| {
        let g = isoforge::grid::DenseGrid::from_fn(l.clone(), |p| u8::from(f(p)));
        let path = dir.path().join(name);
        isoforge_io::write_volume(&path, &g.into()).unwrap();
        path
    };
    let all = write_mask("all.nrrd", &|_| true);
    let boxed = write_mask("box.nrrd", &|[i, j, k]| (1..4).contains(&i) && (0..5).contains(&j) && (2..7).contains(&k));
    let run = |extra: &[&str], out: &str| {
        let o = dir.path().join(out);
        let mut a = vec!["extract", "-i", v, "--iso", "10.5", "-o", p(&o)];
        a.extend_from_slice(extra);
        let r = isoforge(&a);
        assert_eq!(r.status.code(), Some(0), "{a:?}: {}", stderr(&r));
        o
    };
    let plain = run(&[], "plain.ply");
    let masked_all = run(&["--mask", p(&all)], "all.ply");
    assert_eq!(triangle_set(&plain), triangle_set(&masked_all), "a full mask changes nothing");
    // Cells with all corners in the box i 1..4, k 2..7 are exactly the cells of that ROI.
    let masked_box = run(&["--mask", p(&boxed)], "box.ply");
    let roi = run(&["--roi", "1:4,:,2:7"], "roi.ply");
    assert_eq!(triangle_set(&masked_box), triangle_set(&roi));
    assert!(triangle_set(&masked_box).len() < triangle_set(&plain).len());
    let bad = dir.path().join("bad.ply");
    let small = dir.path().join("small.nrrd");
    let g = isoforge::grid::DenseGrid::from_fn(isoforge::grid::Lattice::new([3, 3, 3]).unwrap(), |_| 1u8);
    isoforge_io::write_volume(&small, &g.into()).unwrap();
    fails(&["extract", "-i", v, "--iso", "10.5", "--mask", p(&small), "-o", p(&bad)], "differ from the input's", &bad);
}

#[test]
fn solid_textures_colour_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ply");
    let o = isoforge(&[
        "extract",
        "-i",
        "field:sphere?n=40",
        "--attribute",
        "marble=texture:marble?scale=0.2",
        "--attribute",
        "wood=texture:wood",
        "--color-by",
        "marble",
        "--colormap",
        "hot",
        "-o",
        p(&out),
        "--ascii",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (props, rows) = ascii_ply_vertices(&out);
    assert_eq!(props, ["x", "y", "z", "red", "green", "blue", "marble", "wood"]);
    let marble: Vec<f64> = rows.iter().map(|r| r[6]).collect();
    assert!(marble.iter().all(|v| (0.0..=1.0).contains(v)));
    let spread =
        marble.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - marble.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(spread > 0.5, "marble barely varies ({spread})");
    let bad = dir.path().join("bad.ply");
    fails(
        &["extract", "-i", "field:sphere", "--attribute", "t=texture:plaid", "-o", p(&bad)],
        "unknown texture \"plaid\"",
        &bad,
    );
}

#[test]
fn world_frames_convert_between_lps_and_ras() {
    let dir = tempfile::tempdir().unwrap();
    let nii = testdata().join("volumes/u8_plain.nii"); // RAS
    let (ras, lps) = (dir.path().join("ras.ply"), dir.path().join("lps.ply"));
    for (out, extra) in [(&ras, vec![]), (&lps, vec!["--world", "lps"])] {
        let mut a = vec!["extract", "-i", p(&nii), "--iso", "13.5", "-o", p(out)];
        a.extend(extra);
        let o = isoforge(&a);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let read = |f: &Path| isoforge_io::read_mesh(f, &isoforge_io::Limits::default()).unwrap();
    let (a, b) = (read(&ras), read(&lps));
    assert_eq!(a.triangles, b.triangles);
    for (p, q) in a.positions.iter().zip(&b.positions) {
        assert_eq!([-p[0], -p[1], p[2]], *q);
    }
    // A half turn keeps the orientation: both enclose a positive volume.
    let vol = |m: &isoforge::mesh::Mesh| isoforge::topo::check(m).volume;
    assert!(vol(&a) > 0.0 && (vol(&a) - vol(&b)).abs() < 1e-6 * vol(&a).abs());
    // An LPS copy of the volume as an attribute of the RAS input is re-expressed before sampling:
    // sampling the volume at its own isosurface gives the iso value.
    let g = isoforge_io::read_volume(&nii, &isoforge_io::Limits::default()).unwrap();
    let l = g.lattice().in_space(isoforge::grid::WorldSpace::Lps).unwrap();
    let lps_copy = dir.path().join("copy_lps.nrrd");
    isoforge_io::write_volume(&lps_copy, &g.with_lattice(l).unwrap()).unwrap();
    let out = dir.path().join("attr.ply");
    let attr = format!("self={}", p(&lps_copy));
    // Classic MC: every vertex on a lattice edge, where sampling is exact (not mc33's interior ones).
    let o = isoforge(&[
        "extract",
        "-i",
        p(&nii),
        "--iso",
        "13.5",
        "--method",
        "mc",
        "--attribute",
        &attr,
        "-o",
        p(&out),
        "--ascii",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (_, rows) = ascii_ply_vertices(&out);
    assert!(rows.iter().all(|r| (r[3] - 13.5).abs() < 1e-3), "{:?}", rows.iter().find(|r| (r[3] - 13.5).abs() >= 1e-3));
    // A file without a frame cannot be converted.
    let raw = testdata().join("volumes/f64_external.raw");
    let bad = dir.path().join("bad.ply");
    fails(
        &["extract", "-i", p(&raw), "--dims", "6,5,7", "--dtype", "f64", "--iso", "1", "--world", "ras", "-o", p(&bad)],
        "does not say whether its world coordinates are LPS or RAS",
        &bad,
    );
}

#[test]
fn several_isos_become_objects_of_one_obj_and_colours_reach_off() {
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd");
    let obj = dir.path().join("two.obj");
    let o = isoforge(&["extract", "-i", p(&vol), "--iso", "5.5,10.5", "--close", "-o", p(&obj)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&obj).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("o ")).collect::<Vec<_>>(), ["o iso_5.5", "o iso_10.5"]);
    // Read back as one mesh: two closed surfaces.
    let m = isoforge_io::read_mesh(&obj, &isoforge_io::Limits::default()).unwrap();
    let r = isoforge::topo::check(&m);
    assert!(r.is_watertight());
    assert!(r.components.len() >= 2);
    let off = dir.path().join("c.off");
    let o = isoforge(&[
        "extract",
        "-i",
        p(&vol),
        "--iso",
        "10.5",
        "--attribute",
        "n=texture:noise",
        "--color-by",
        "n",
        "-o",
        p(&off),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&off).unwrap().starts_with("COFF\n"));
    assert!(isoforge(&["check", p(&off)]).status.success());
}

#[test]
fn an_rgb_stack_colours_the_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let vol = testdata().join("volumes/u8_raw.nrrd"); // 6 x 5 x 7, spacing 0.5 0.75 2, origin 10 -20 5.5
    let rgb = testdata().join("images/rgb_6x5x7.tif"); // colour = (10 i + 3, 20 j + 7, 30 k + 1)
    for space in ["world", "index"] {
        let out = dir.path().join(format!("c-{space}.ply"));
        let o = isoforge(&[
            "extract",
            "-i",
            p(&vol),
            "--iso",
            "10.5",
            "--color-volume",
            p(&rgb),
            "--space",
            space,
            "-o",
            p(&out),
            "--ascii",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let (props, rows) = ascii_ply_vertices(&out);
        assert_eq!(props, ["x", "y", "z", "red", "green", "blue"]);
        for r in &rows {
            let ijk = if space == "index" {
                [r[0], r[1], r[2]]
            } else {
                [(r[0] - 10.0) / 0.5, (r[1] + 20.0) / 0.75, (r[2] - 5.5) / 2.0]
            };
            let want = [10.0 * ijk[0] + 3.0, 20.0 * ijk[1] + 7.0, 30.0 * ijk[2] + 1.0];
            for ch in 0..3 {
                assert!((r[3 + ch] - want[ch].round()).abs() <= 1.0, "{space}: vertex {r:?}, want {want:?}");
            }
        }
    }
    let bad = dir.path().join("bad.ply");
    let gray = testdata().join("images/stack3.tif");
    fails(
        &["extract", "-i", p(&vol), "--iso", "10.5", "--color-volume", p(&gray), "-o", p(&bad)],
        "8-bit RGB pages are needed",
        &bad,
    );
}

#[test]
fn render_writes_pictures_of_meshes_volumes_and_fields() {
    let dir = tempfile::tempdir().unwrap();
    let png_size = |f: &Path| {
        let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(f).unwrap()));
        let r = d.read_info().unwrap();
        (r.info().width, r.info().height)
    };
    let mesh = testdata().join("meshes/tetra_ascii.ply");
    let vol = testdata().join("volumes/u8_raw.nrrd");
    for (args, size) in [
        (vec!["render", p(&mesh)], (1024, 768)),
        (vec!["render", p(&vol), "--iso", "10.5", "--size", "160x90", "--view", "top", "--wireframe"], (160, 90)),
        (vec!["render", "field:torus?n=24", "--size", "64x64", "--shading", "normal", "--method", "mc33"], (64, 64)),
    ] {
        let out = dir.path().join("shot.png");
        let mut a = args.clone();
        a.extend(["-o", p(&out)]);
        let o = isoforge(&a);
        assert_eq!(o.status.code(), Some(0), "{a:?}: {}", stderr(&o));
        assert_eq!(png_size(&out), size, "{a:?}");
        std::fs::remove_file(&out).unwrap();
    }
    let bad = dir.path().join("bad.png");
    fails(&["render", p(&mesh), "--size", "0x10", "-o", p(&bad)], "--size \"0x10\"", &bad);
    fails(&["render", p(&mesh), "--view", "side", "-o", p(&bad)], "--view \"side\"", &bad);
    fails(&["render", p(&vol), "-o", p(&bad)], "--iso is required", &bad);
    let jpg = dir.path().join("x.jpg");
    fails(&["render", p(&mesh), "-o", p(&jpg)], "render writes .png", &jpg);
}

/// A u8 gyroid-like volume of `n³` points (period ~31 points), x fastest, as a raw file.
fn gyroid_raw(dir: &Path, n: u32) -> PathBuf {
    let mut bytes = Vec::with_capacity((n * n * n) as usize);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let [x, y, z] = [i, j, k].map(|a| a as f32 * 0.2);
                let v = x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos();
                bytes.push((128.0 + 80.0 * v).clamp(0.0, 255.0) as u8);
            }
        }
    }
    let path = dir.join(format!("gyroid{n}.raw"));
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Text a progress bar or spinner leaves on stderr.
fn has_progress_text(err: &str) -> bool {
    err.contains('\r') || err.contains('\u{1b}') || err.contains("%") || err.contains("] ")
}

/// Issue 10: `mt*` on grids and `check` ran silently for seconds; now a live bar shows on a
/// terminal (a pseudo-terminal from `script`), and nothing at all when stderr is a pipe.
#[test]
fn issue_10_progress_shows_on_a_terminal_only() {
    let dir = tempfile::tempdir().unwrap();
    let raw = gyroid_raw(dir.path(), 160);
    let out = dir.path().join("g.ply");
    let bin = env!("CARGO_BIN_EXE_isoforge");
    let extract = [
        "extract",
        "-i",
        p(&raw),
        "--dims",
        "160,160,160",
        "--dtype",
        "u8",
        "--iso",
        "128.5",
        "--method",
        "mt5",
        "-o",
        p(&out),
    ];
    // No terminal: only the summary line.
    let o = Command::new(bin).args(extract).env_remove("ISOFORGE_PROGRESS").output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!has_progress_text(&stderr(&o)), "progress text without a terminal: {:?}", stderr(&o));
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    let c = Command::new(bin).args(["check", p(&out)]).env_remove("ISOFORGE_PROGRESS").output().unwrap();
    assert!(c.stderr.is_empty(), "{}", stderr(&c));

    if Command::new("script").arg("--version").output().is_err() {
        eprintln!("skipping the terminal half: `script` (util-linux) is not installed");
        return;
    }
    // On a terminal: both commands show their progress (shown at once here, not after a second:
    // the parallel walker makes this run shorter than that).
    let on_tty = |args: &[&str]| -> String {
        let line = std::iter::once(bin).chain(args.iter().copied()).map(|a| format!("'{a}'")).collect::<Vec<_>>();
        let o = Command::new("script")
            .args(["-qec", &line.join(" "), "/dev/null"])
            .env("TERM", "xterm")
            .env("ISOFORGE_PROGRESS_AFTER_MS", "0")
            .env_remove("ISOFORGE_PROGRESS")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stdout));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let tty = on_tty(&extract);
    // A raw file streams by default (a bar per slab); in memory, a bar per extraction.
    assert!(
        (tty.contains("extracting iso 128.5 (mt5) [") || tty.contains("slab by slab [")) && tty.contains('%'),
        "no bar on a terminal: {tty:?}"
    );
    let tty = on_tty(&["check", p(&out)]);
    assert!(
        tty.contains(&format!("reading {}", p(&out))) || tty.contains("checking the mesh ["),
        "no progress on a terminal: {tty:?}"
    );
}

/// Issue 10: every step that can take long reports progress (forced on with
/// `ISOFORGE_PROGRESS=always`, which writes plain lines when stderr is not a terminal), and
/// `ISOFORGE_PROGRESS=never` silences it.
#[test]
fn issue_10_every_long_step_reports_progress() {
    let dir = tempfile::tempdir().unwrap();
    let raw = gyroid_raw(dir.path(), 24);
    let run = |mode: &str, args: &[&str]| -> String {
        let o =
            Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).env("ISOFORGE_PROGRESS", mode).output().unwrap();
        assert!(o.status.code().is_some_and(|c| c <= 1), "{args:?}: {}", stderr(&o));
        stderr(&o)
    };
    let layout = ["--dims", "24,24,24", "--dtype", "u8"];
    let mesh = dir.path().join("m.ply");
    let extract: Vec<&str> =
        [&["extract", "-i", p(&raw)][..], &layout, &["--iso", "128.5", "--method", "mt5", "-o", p(&mesh)]].concat();
    // Streamed by default: opening, then one bar for reading, meshing and writing slab by slab.
    let e = run("always", &extract);
    for step in ["opening", "slab by slab"] {
        assert!(e.contains(step), "extract: no {step:?} in {e}");
    }
    // In memory (`--time-json` keeps extraction apart from reading and writing): a step each.
    let timing = dir.path().join("t.json");
    let e = run("always", &[&extract[..], &["--time-json", p(&timing)]].concat());
    for step in ["opening", "reading", "extracting iso 128.5 (mt5)", "writing"] {
        assert!(e.contains(step), "extract: no {step:?} in {e}");
    }
    assert!(run("always", &["check", p(&mesh)]).contains("checking the mesh ["));
    let labels = dir.path().join("labels.nrrd");
    let o = isoforge(&[&["convert", p(&raw)][..], &[p(&labels)], &layout].concat());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let l =
        run("always", &["extract", "-i", p(&labels), "--labels", "100,128,200", "-o", p(&dir.path().join("l.ply"))]);
    assert!(l.contains("meshing label 3 of 3") && l.contains("checking label"), "{l}");
    let r = run("always", &["render", p(&mesh), "-o", p(&dir.path().join("m.png")), "--size", "64x48"]);
    assert!(r.contains("rendering"), "{r}");
    let s = run(
        "always",
        &[&["extract", "-i", p(&raw)][..], &layout, &["--iso", "128.5", "--max-memory", "8M", "-o", p(&mesh)]].concat(),
    );
    assert!(s.contains("slab by slab ["), "{s}");
    assert!(run("always", &[&["info", p(&raw)][..], &layout].concat()).contains("histogram"));
    let quiet = run("never", &extract);
    assert!(!has_progress_text(&quiet) && quiet.lines().count() == 1, "{quiet}");
}

/// Issue 10: `--help` listed 4 of the 12 inputs and no glTF output; the lists now come from the
/// io crate's format enums.
#[test]
fn issue_10_help_lists_every_format() {
    let help = |args: &[&str]| String::from_utf8_lossy(&isoforge(args).stdout).into_owned();
    let extract = help(&["extract", "--help"]);
    for f in isoforge_io::VolumeFormat::ALL {
        for e in f.extensions() {
            assert!(extract.contains(e), "extract --help lacks {e}");
        }
        assert!(extract.contains(f.name()), "extract --help lacks {}", f.name());
    }
    for e in isoforge_io::MeshFormat::ALL.iter().filter_map(|f| f.extension()) {
        assert!(extract.contains(&format!(".{e}")), "extract --help lacks .{e}");
    }
    for words in ["DICOM", "numbered PNG or TIFF slices", "field:", "gyroid", "metaballs"] {
        assert!(extract.contains(words), "extract --help lacks {words:?}");
    }
    let check = help(&["check", "--help"]);
    for f in isoforge_io::MeshFormat::ALL {
        let e = format!(".{}", f.extension().unwrap());
        assert_eq!(check.contains(&e), f.is_readable(), "check --help and {e}");
    }
    assert!(help(&["render", "--help"]).contains(".off"));
}

/// Issue 10: `info` suggested −1976 on the bunny CT (Otsu split off its −2000 padding); the
/// suggestion now lands near the iso each sidecar gives (its Otsu threshold, computed without
/// padding) on every volume in shared/data.
#[test]
fn issue_10_info_suggests_a_surface_iso_on_real_volumes() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/volumes");
    if !data.exists() {
        eprintln!("skipping: {} is absent", data.display());
        return;
    }
    let mut seen = 0;
    for entry in std::fs::read_dir(&data).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("nrrd") {
            continue;
        }
        let side: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path.with_extension("json")).unwrap()).unwrap();
        let want = side["otsu_threshold"].as_f64().unwrap();
        let o = isoforge(&["info", p(&path), "--json"]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let (lo, hi) = (v["value_range"][0].as_f64().unwrap(), v["value_range"][1].as_f64().unwrap());
        let got = v["suggested_iso"].as_f64().unwrap();
        assert!((got - want).abs() <= 0.01 * (hi - lo), "{}: suggested {got}, sidecar {want}", path.display());
        if path.to_string_lossy().contains("bunny") {
            assert!(v["otsu"].as_f64().unwrap() < -1900.0, "Otsu over all values splits off the padding");
        }
        seen += 1;
    }
    assert_eq!(seen, 7, "volumes in {}", data.display());
}

/// Writes `slices` 4×3 PNG slices numbered 0.. into `dir`, values `base + 10·slice + i`.
fn png_slices(dir: &Path, slices: u8) {
    std::fs::create_dir_all(dir).unwrap();
    for k in 0..slices {
        let f = std::fs::File::create(dir.join(format!("slice_{k:03}.png"))).unwrap();
        let mut e = png::Encoder::new(std::io::BufWriter::new(f), 4, 3);
        e.set_color(png::ColorType::Grayscale);
        e.set_depth(png::BitDepth::Eight);
        let data: Vec<u8> = (0..12u8).map(|i| if k == 1 && (i == 5 || i == 6) { 200 } else { 10 }).collect();
        e.write_header().unwrap().write_image_data(&data).unwrap();
    }
}

/// Issue 10: images took no `--spacing`/`--origin` (raw files only); TIFF stacks, PNGs, folders of
/// slices and `contour` now do, and files with their own geometry refuse them.
#[test]
fn issue_10_images_take_spacing_and_origin() {
    let dir = tempfile::tempdir().unwrap();
    let bounds = |mesh: &Path| -> Vec<f64> {
        let r: serde_json::Value = serde_json::from_slice(&isoforge(&["check", p(mesh), "--json"]).stdout).unwrap();
        ["min", "max"]
            .iter()
            .flat_map(|m| (0..3).map(move |a| (*m, a)))
            .map(|(m, a)| r["bounds"][m][a].as_f64().unwrap())
            .collect()
    };
    let (sp, or) = ([0.5, 0.25, 2.0], [-10.0, 3.0, 100.0]);
    let placed_flags = ["--spacing", "0.5,0.25,2", "--origin", "-10,3,100"];
    let slices = dir.path().join("slices");
    png_slices(&slices, 3);
    for (input, iso) in [(testdata().join("images/stack3.tif"), "150.5"), (slices.clone(), "100")] {
        let (plain, placed) = (dir.path().join("plain.ply"), dir.path().join("placed.ply"));
        let o = isoforge(&["extract", "-i", p(&input), "--iso", iso, "-o", p(&plain)]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let o = isoforge(&[&["extract", "-i", p(&input), "--iso", iso, "-o", p(&placed)][..], &placed_flags].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let (a, b) = (bounds(&plain), bounds(&placed));
        for k in 0..6 {
            let want = or[k % 3] + sp[k % 3] * a[k];
            assert!((b[k] - want).abs() < 1e-4, "{}: bound {k}: {} vs {want}", input.display(), b[k]);
        }
    }
    // contour: GeoJSON coordinates = origin + spacing · pixel coordinates of the in-plane axes.
    let png = testdata().join("images/engine_z64.png");
    let coords = |extra: &[&str]| -> Vec<f64> {
        let out = dir.path().join("c.geojson");
        let o = isoforge(&[&["contour", p(&png), "--iso", "150.5", "-o", p(&out)][..], extra].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let g: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        g["features"][0]["geometry"]["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|q| [q[0].as_f64().unwrap(), q[1].as_f64().unwrap()])
            .collect()
    };
    let (a, b) = (coords(&[]), coords(&placed_flags));
    assert!(!a.is_empty() && a.len() == b.len());
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!((y - (or[k % 2] + sp[k % 2] * x)).abs() < 1e-9, "point {k}: {y} from {x}");
    }
    // Geometry the file states is not overridden; bad spacings are refused.
    let out = dir.path().join("x.ply");
    let nrrd = testdata().join("volumes/i16_gzip.nrrd");
    fails(
        &["extract", "-i", p(&nrrd), "--iso", "1", "--spacing", "1,1,1", "-o", p(&out)],
        "carries its own geometry",
        &out,
    );
    let tif = testdata().join("images/stack3.tif");
    fails(
        &["extract", "-i", p(&tif), "--iso", "150.5", "--spacing", "1,0,1", "-o", p(&out)],
        "--spacing \"1,0,1\"",
        &out,
    );
    fails(&["extract", "-i", p(&tif), "--iso", "150.5", "--spacing", "1,-1,1", "-o", p(&out)], "not a positive", &out);
}

/// Issue 10: `--origin -10,0,0` was taken for an unknown option; negative values now reach the
/// validation in every numeric flag.
#[test]
fn issue_10_negative_numbers_in_numeric_flags() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("v.raw");
    // A sphere of radius 4 around (−6, 0, 0) in a 12³ lattice placed from −12: values −4..
    let mut bytes = Vec::new();
    for k in 0..12 {
        for j in 0..12 {
            for i in 0..12 {
                let d = [(i as f32 - 6.0), (j as f32 - 6.0), (k as f32 - 6.0)];
                bytes.extend_from_slice(&((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 4.0).to_le_bytes());
            }
        }
    }
    std::fs::write(&raw, bytes).unwrap();
    let out = dir.path().join("o.ply");
    let layout = ["--dims", "12,12,12", "--dtype", "f32", "--origin", "-12,-6,-6"];
    let ok = |args: &[&str]| {
        let o = isoforge(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    };
    ok(&[&["extract", "-i", p(&raw)][..], &layout, &["--iso", "-1.5", "-o", p(&out)]].concat());
    let r: serde_json::Value = serde_json::from_slice(&isoforge(&["check", p(&out), "--json"]).stdout).unwrap();
    assert!(r["bounds"]["min"][0].as_f64().unwrap() < -6.0, "{}", r["bounds"]);
    ok(&[
        &["extract", "-i", p(&raw)][..],
        &layout,
        &["--iso", "-1.5", "--roi-world", "-10:-2,-6:6,-6:6", "-o", p(&out)],
    ]
    .concat());
    ok(&[&["contour", p(&raw)][..], &layout, &["--iso", "-2", "-o", p(&dir.path().join("c.svg"))]].concat());
    ok(&["extract", "-i", "field:sphere", "--iso", "-0.25", "-o", p(&out)]);
    // Negative values where they make no sense: the value's own error, naming the flag.
    let bad = |args: &[&str], needle: &str| {
        let o = isoforge(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle) && !err.contains("unexpected argument"), "{args:?}: {err}");
    };
    bad(&[&["contour", p(&raw)][..], &layout, &["--iso", "-2", "--slice", "-1", "-o", p(&out)]].concat(), "--slice");
    bad(&["extract", "-i", p(&raw), "--dims", "12,-12,12", "--dtype", "f32", "--iso", "0", "-o", p(&out)], "--dims");
    bad(&["--threads", "-2", "demo"], "--threads");
    bad(&["demo", "--n", "-5"], "--n");
}

/// Issue 10: `--threads` was passed to rayon's global pool unchecked; it is capped at 4 × the
/// cores (one-line error), 0 is refused, and the output does not depend on it.
#[test]
fn issue_10_threads_are_capped() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.ply");
    let cores = std::thread::available_parallelism().unwrap().get();
    let too_many = (4 * cores + 1).to_string();
    fails(
        &["--threads", &too_many, "extract", "-i", "field:torus", "-o", p(&out)],
        &format!("at most {}", 4 * cores),
        &out,
    );
    fails(&["--threads", "0", "extract", "-i", "field:torus", "-o", p(&out)], "--threads 0: must be at least 1", &out);
    let most = (4 * cores).to_string();
    let mut meshes = Vec::new();
    for t in ["1", most.as_str()] {
        let o = dir.path().join(format!("t{t}.ply"));
        let r = isoforge(&["--threads", t, "extract", "-i", "field:gyroid?n=40", "-o", p(&o)]);
        assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
        meshes.push(std::fs::read(&o).unwrap());
    }
    assert_eq!(meshes[0], meshes[1]);
}

/// Runs isoforge under GNU time and returns (exit code, stdout, stderr, peak resident memory in
/// KiB); `None` when /usr/bin/time is absent. (The child's own `wait4` figures would count this
/// test process too: Linux records the memory of the process image `exec` replaces.)
fn run_measured(args: &[&str], dir: &Path) -> Option<(Option<i32>, String, String, u64)> {
    let time = Path::new("/usr/bin/time");
    if !time.exists() {
        return None;
    }
    let report = dir.join("time.txt");
    let o = Command::new(time)
        .args(["-f", "%M", "-o", p(&report), env!("CARGO_BIN_EXE_isoforge")])
        .args(args)
        .output()
        .unwrap();
    let text = std::fs::read_to_string(&report).unwrap();
    let kib = text.lines().last().unwrap().trim().parse().unwrap();
    Some((o.status.code(), String::from_utf8_lossy(&o.stdout).into_owned(), stderr(&o), kib))
}

/// Issue 10 (hardening 8): `--max-memory` counted the volume only, so a CT that fit ran in memory
/// with a mesh and a check of many times the budget; and `--require` after an out-of-core run read
/// the whole mesh back. Now the worst-case mesh decides, the streamed mesh is checked as it is
/// written, and the process stays within the budget — with the report `check` gives for the file.
#[test]
fn issue_10_max_memory_is_a_real_cap_with_require() {
    let dir = tempfile::tempdir().unwrap();
    let raw = gyroid_raw(dir.path(), 200);
    let out = dir.path().join("g.ply");
    let base = ["extract", "-i", p(&raw), "--dims", "200,200,200", "--dtype", "u8", "--iso", "128.5"];
    let args = [&base[..], &["--max-memory", "64M", "--require", "watertight", "-o", p(&out)]].concat();
    let Some((code, report, err, peak_kib)) = run_measured(&args, dir.path()) else {
        eprintln!("skipping: /usr/bin/time (GNU time) is not installed");
        return;
    };
    // The gyroid reaches the lattice's faces: not closed, exit 1, and the file is written.
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("streamed slab by slab") && err.contains("required but failed: watertight"), "{err}");
    let c = isoforge(&["check", p(&out)]);
    let whole = String::from_utf8_lossy(&c.stdout).into_owned();
    let triangles: u64 = whole.split_whitespace().skip_while(|w| *w != "vertices,").nth(1).unwrap().parse().unwrap();
    assert!(triangles > 1_000_000, "{whole}");
    // Every line but the file name and the volume's last digits is the same.
    let strip = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| !l.starts_with("file:"))
            .map(|l| l.split("enclosed volume").next().unwrap().to_string())
            .collect()
    };
    assert_eq!(strip(&report), strip(&whole));
    // Reading the mesh back and checking it needs > 150 MB (about 130 bytes per triangle).
    assert!(peak_kib < 64 * 1024, "peak {} MiB on a 64 MiB budget", peak_kib / 1024);

    // Every method streams (issue 11): mt5 stayed at 481 MB on a 256 MB budget before.
    let args =
        [&base[..], &["--max-memory", "64M", "--method", "mt5", "--require", "manifold", "-o", p(&out)]].concat();
    let (code, _, err, peak_kib) = run_measured(&args, dir.path()).expect("GNU time was found above");
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("(mt5, streamed slab by slab"), "{err}");
    assert!(peak_kib < 64 * 1024, "mt5: peak {} MiB on a 64 MiB budget", peak_kib / 1024);
    // Readers that decode whole files cannot stream: refused with the reason.
    let o = isoforge(&[
        "extract",
        "-i",
        p(&testdata().join("images/stack3.tif")),
        "--iso",
        "150.5",
        "--max-memory",
        "1M",
        "-o",
        p(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("are read whole") && stderr(&o).contains("--max-memory 1 MiB"), "{}", stderr(&o));
    // A budget that holds the worst case keeps the in-memory path.
    let small = gyroid_raw(dir.path(), 20);
    let o = isoforge(&[
        "extract",
        "-i",
        p(&small),
        "--dims",
        "20,20,20",
        "--dtype",
        "u8",
        "--iso",
        "128.5",
        "--max-memory",
        "1G",
        "-o",
        p(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("(mc"), "{}", stderr(&o));
}

/// Issue 50: a cap is honoured by every format that streams (raw, NRRD, gzip NRRD, NIfTI, gzip
/// NIfTI): the process holds at most the cap above what a tiny extraction holds (the binary, the
/// threads), the files' buffers counted in the cap.
#[test]
fn issue_50_every_streaming_format_holds_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let raw = gyroid_raw(dir.path(), 160);
    let layout = ["--dims", "160,160,160", "--dtype", "u8"];
    let out = dir.path().join("g.ply");
    let Some((code, _, err, baseline_kib)) =
        run_measured(&["extract", "-i", "field:sphere?n=8", "-o", p(&out)], dir.path())
    else {
        eprintln!("skipping: /usr/bin/time (GNU time) is not installed");
        return;
    };
    assert_eq!(code, Some(0), "{err}");
    let mut inputs = vec![(raw.clone(), &layout[..])];
    for ext in ["nrrd", "nii", "nii.gz"] {
        let file = dir.path().join(format!("g.{ext}"));
        let o = isoforge(&[&["convert", p(&raw), p(&file)][..], &layout].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        inputs.push((file, &[][..]));
    }
    for (input, layout) in inputs {
        let args =
            [&["extract", "-i", p(&input)][..], layout, &["--iso", "128.5", "--max-memory", "8M", "-o", p(&out)]]
                .concat();
        let (code, _, err, peak_kib) = run_measured(&args, dir.path()).expect("GNU time was found above");
        assert_eq!(code, Some(0), "{}: {err}", input.display());
        assert!(err.contains("streamed slab by slab"), "{}: {err}", input.display());
        let over = peak_kib.saturating_sub(baseline_kib);
        assert!(over <= 8 * 1024, "{}: {} KiB above a tiny run on an 8 MiB cap", input.display(), over);
    }
    // Below the stream's buffers: refused with the figure it needs.
    let args = [&["extract", "-i", p(&raw)][..], &layout[..], &["--iso", "128.5", "--max-memory", "2M", "-o", p(&out)]]
        .concat();
    std::fs::remove_file(&out).unwrap();
    fails(&args, "streaming it slab by slab holds at least 6 MiB", &out);
    // A file read whole (VTI) over the cap: refused by its header, before its samples are read.
    let n = 64usize;
    let mut vti = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt32\">\n<ImageData WholeExtent=\"0 {m} 0 {m} 0 {m}\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n\
         <Piece Extent=\"0 {m} 0 {m} 0 {m}\"><PointData Scalars=\"v\"><DataArray type=\"UInt8\" Name=\"v\" \
         format=\"appended\" offset=\"0\"/></PointData></Piece>\n</ImageData>\n<AppendedData encoding=\"raw\">_",
        m = n - 1
    )
    .into_bytes();
    vti.extend((n.pow(3) as u32).to_le_bytes());
    vti.extend((0..n.pow(3)).map(|i| (i % 251) as u8));
    vti.extend(b"\n</AppendedData>\n</VTKFile>\n");
    let file = dir.path().join("g.vti");
    std::fs::write(&file, vti).unwrap();
    let args = ["extract", "-i", p(&file), "--iso", "100", "--max-memory", "100K", "-o", p(&out)];
    fails(&args, "are read whole, and its samples need more than --max-memory 100 KiB", &out);
}

/// Collects a streamed mesh and checks it as it streams.
struct CheckedCopy {
    mesh: isoforge::mesh::Mesh,
    check: isoforge::topo::StreamCheck,
}

impl isoforge::mesh::MeshSink for CheckedCopy {
    fn push(&mut self, b: isoforge::mesh::MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        self.mesh.positions.extend_from_slice(b.positions);
        self.mesh.triangles.extend_from_slice(b.triangles);
        isoforge::mesh::MeshSink::push(&mut self.check, b)
    }
}

/// Issue 10 (hardening 8): on real CTs streamed slab by slab, the streaming checker's report is
/// `topo::check`'s for the whole mesh: every count and example, components in order, cells named
/// (the area and volume sums to rounding).
#[test]
fn issue_10_stream_check_equals_check_on_real_cts() {
    use isoforge::topo::{self, CheckOptions};
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/volumes");
    if !data.exists() {
        eprintln!("skipping: {} is absent", data.display());
        return;
    }
    for (name, iso) in [("cthead_8bit_256x256x99.nrrd", 52.29), ("lidc2_chest_ct_u8.nrrd", 59.27)] {
        let mut reader = isoforge_io::open_volume(&data.join(name), &isoforge_io::Limits::new(u64::MAX)).unwrap();
        assert_eq!(reader.dtype(), isoforge::grid::DType::U8);
        let opts =
            CheckOptions { max_examples: 25, lattice: Some(reader.lattice().clone()), ..CheckOptions::default() };
        let mut sink = CheckedCopy { mesh: Default::default(), check: isoforge::topo::StreamCheck::new(&opts) };
        let iso = isoforge::volume::Iso::below(iso);
        isoforge::pipeline::extract_streamed(&mut reader, iso, &Default::default(), &mut sink, None).unwrap();
        let whole = topo::check_with(&sink.mesh, &opts);
        let mut streamed = sink.check.finish().unwrap();
        assert!(whole.triangles > 400_000 && whole.boundary_edges.count > 0 && whole.components.len() > 10, "{name}");
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
        assert!(close(streamed.area, whole.area) && close(streamed.volume, whole.volume), "{name}");
        assert!(close(streamed.min_angle_mean_deg, whole.min_angle_mean_deg), "{name}");
        for (s, w) in streamed.components.iter_mut().zip(&whole.components) {
            assert!(close(s.area, w.area) && close(s.volume, w.volume), "{name}");
            (s.area, s.volume) = (w.area, w.volume);
        }
        (streamed.area, streamed.volume, streamed.min_angle_mean_deg) =
            (whole.area, whole.volume, whole.min_angle_mean_deg);
        assert_eq!(streamed, whole, "{name}");
    }
}

/// Issue 50: a volume of one slice (a single-slice DICOM folder reads as one, as does this NRRD)
/// has no cell, so the walk sees nothing and `extract` wrote an empty mesh with exit 0, where any
/// other volume without a crossing gets "iso … gives no surface" and exit 2. The library's
/// checks now refuse a lattice without cells before the walk, with the same words.
#[test]
fn issue_50_a_volume_of_one_slice_gives_no_surface() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("one.nrrd");
    std::fs::write(&input, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 1\nencoding: ascii\n\n0 1 2 3\n").unwrap();
    let out = dir.path().join("o.ply");
    for extra in [&[][..], &["--max-memory", "10M"][..]] {
        let mut args = vec!["extract", "-i", p(&input), "--iso", "1.5", "-o", p(&out)];
        args.extend_from_slice(extra);
        fails(&args, "gives no surface", &out);
    }
}

/// Issues 46/47: a PolyMender `.sog` reads as its signs (−1 inside, +1 outside) and extracts at
/// iso 0 without `--iso`; `info` describes it.
#[test]
fn sog_files_extract_as_their_sign_grid() {
    let sog = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sog/wisky.5.sog");
    if !sog.exists() {
        eprintln!("skipping: {} is absent", sog.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("w.ply");
    let o = isoforge(&["extract", "-i", p(&sog), "-o", p(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mesh = isoforge_io::read_mesh(&out, &isoforge_io::Limits::default()).unwrap();
    let r = isoforge::topo::check(&mesh);
    assert!(r.is_watertight(), "{r:?}");
    assert_eq!(r.genus(), Some(2));
    let o = isoforge(&["info", p(&sog)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("33"), "{}", String::from_utf8_lossy(&o.stdout));
}

/// Issue 45: `--method emc` (and its `--feature-angle`) and `--method dc` (manifold by default,
/// `--no-manifold` for plain dual contouring): watertight meshes, one-line refusals of options
/// given to the wrong method.
#[test]
fn sharp_methods_and_their_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ply");
    for extra in [
        &["--method", "emc"][..],
        &["--method", "emc", "--feature-angle", "45"],
        &["--method", "dc"],
        &["--method", "dc", "--quads"],
    ] {
        let args =
            [&["extract", "-i", "field:box?n=24", "-o", p(&out)][..], extra, &["--require", "watertight"]].concat();
        let o = isoforge(&args);
        assert_eq!(o.status.code(), Some(0), "{extra:?}: {}", stderr(&o));
    }
    // Plain dual contouring on a field whose cells hold two sheets: runs, promises less.
    let o = isoforge(&["extract", "-i", "field:gyroid?n=24", "--method", "dc", "--no-manifold", "-o", p(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let bad = dir.path().join("bad.ply");
    let field = ["extract", "-i", "field:box?n=16", "-o", p(&bad)];
    fails(&[&field[..], &["--method", "emc", "--feature-angle", "200"]].concat(), "--feature-angle 200", &bad);
    fails(&[&field[..], &["--method", "emc", "--feature-angle", "nan"]].concat(), "--feature-angle", &bad);
    fails(
        &[&field[..], &["--method", "dc", "--feature-angle", "30"]].concat(),
        "--feature-angle applies to --method emc",
        &bad,
    );
    fails(&[&field[..], &["--method", "mc", "--no-manifold"]].concat(), "--no-manifold applies to --method dc", &bad);
    fails(&[&field[..], &["--method", "emc", "--quads"]].concat(), "--quads applies to --method dc", &bad);
}

/// Issue 45: `--method dc --adaptivity E` (adaptive dual contouring, plain mode implied): a
/// closed mesh with fewer vertices than uniform plain dc; bad bounds and wrong companions refused
/// in one line.
#[test]
fn adaptive_dual_contouring_from_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let (uniform, adaptive) = (dir.path().join("u.ply"), dir.path().join("a.ply"));
    let field = "field:rotated-box?n=32";
    let o = isoforge(&["extract", "-i", field, "--method", "dc", "--no-manifold", "-o", p(&uniform)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = isoforge(&[
        "extract",
        "-i",
        field,
        "--method",
        "dc",
        "--adaptivity",
        "0.5",
        "-o",
        p(&adaptive),
        "--require",
        "closed",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let read = |f: &PathBuf| isoforge_io::read_mesh(f, &isoforge_io::Limits::default()).unwrap();
    let (u, a) = (read(&uniform), read(&adaptive));
    assert!(a.positions.len() * 3 < u.positions.len(), "{} vs uniform {}", a.positions.len(), u.positions.len());
    // A volume file, which extraction streams by default: adaptive dc loads it instead (it
    // contours the whole volume at once) and keeps uniform plain dc's topology.
    let vol = dir.path().join("ball.nrrd");
    let n = 32u32;
    let dist = |x: u32| (x as f32 - 15.3).powi(2);
    let data: Vec<u8> = (0..n * n * n)
        .map(|v| ((dist(v % n) + dist(v / n % n) + 1.3 * dist(v / (n * n))).sqrt() * 8.0).min(255.0) as u8)
        .collect();
    let header = format!("NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\n\n");
    std::fs::write(&vol, [header.as_bytes(), &data].concat()).unwrap();
    let (uv, av) = (dir.path().join("uv.ply"), dir.path().join("av.ply"));
    for (e, out) in [("0", &uv), ("0.5", &av)] {
        let args = ["extract", "-i", p(&vol), "--iso", "100", "--method", "dc", "--no-manifold", "--close"];
        let args = [&args[..], &["--adaptivity", e, "-o", p(out)]].concat();
        let o = isoforge(&args);
        assert_eq!(o.status.code(), Some(0), "--adaptivity {e}: {}", stderr(&o));
    }
    let (u, a) = (read(&uv), read(&av));
    let (ru, ra) = (isoforge::topo::check(&u), isoforge::topo::check(&a));
    assert!(a.positions.len() < u.positions.len(), "{} vs uniform {}", a.positions.len(), u.positions.len());
    assert_eq!((ra.components.len(), ra.euler, ra.boundary_edges.count), (ru.components.len(), ru.euler, 0));
    let bad = dir.path().join("bad.ply");
    let args = ["extract", "-i", "field:box?n=16", "-o", p(&bad)];
    fails(&[&args[..], &["--method", "dc", "--adaptivity", "-1"]].concat(), "--adaptivity -1", &bad);
    fails(&[&args[..], &["--method", "dc", "--adaptivity", "x"]].concat(), "--adaptivity", &bad);
    fails(
        &[&args[..], &["--method", "mc", "--adaptivity", "0.5"]].concat(),
        "--adaptivity applies to --method dc",
        &bad,
    );
    fails(
        &[&args[..], &["--method", "dc", "--split", "--adaptivity", "0.5"]].concat(),
        "--adaptivity and --split",
        &bad,
    );
}

#[test]
fn check_counts_self_intersections_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    // Two triangles, the second piercing the first: one pair.
    let obj = dir.path().join("x.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.25 0.2 -1\nv 0.25 0.2 1\nv 0.25 0.9 0\nf 1 2 3\nf 4 5 6\n")
        .unwrap();
    let plain = isoforge(&["check", p(&obj)]);
    assert!(!String::from_utf8_lossy(&plain.stdout).contains("self-intersections"));
    let o = isoforge(&["check", p(&obj), "--self-intersections"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("self-intersections: 1 pairs of triangles (e.g. triangles 0 and 1)"), "{text}");
    let j = isoforge(&["check", p(&obj), "--self-intersections", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&j.stdout).unwrap();
    assert_eq!(v["self_intersections"], 1);
    assert_eq!(v["findings"]["self_intersections"]["examples"][0], serde_json::json!([0, 1]));
    let r = isoforge(&["check", p(&obj), "--require", "no-self-intersections"]);
    assert_eq!(r.status.code(), Some(1));
    assert!(stderr(&r).contains("required but failed: no-self-intersections"), "{}", stderr(&r));
    // An extracted sphere has none, checked after extraction too.
    let out = dir.path().join("s.ply");
    let e =
        isoforge(&["extract", "-i", "field:sphere", "-o", p(&out), "--require", "watertight,no-self-intersections"]);
    assert_eq!(e.status.code(), Some(0), "{}", stderr(&e));
    assert!(String::from_utf8_lossy(&e.stdout).contains("self-intersections: 0 pairs"));
    let c = isoforge(&["check", p(&out), "--require", "no-self-intersections"]);
    assert_eq!(c.status.code(), Some(0), "{}", stderr(&c));
}
