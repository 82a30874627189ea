//! Sparse inputs and options on the command line (issue 44: `--sparse`, `--lipschitz`, `--level`,
//! `--follow`, `--seed`, OpenVDB files) and the caps that are refused before the work (issue 50).

mod common;

use std::path::Path;

use common::{fails, isoforge, p, stderr, testdata};

/// `isoforge check` of a mesh: its text report.
fn check(mesh: &Path) -> String {
    String::from_utf8_lossy(&isoforge(&["check", p(mesh)]).stdout).into_owned()
}

/// The `N triangles` count of a report.
fn triangles(report: &str) -> u64 {
    let line = report.lines().find(|l| l.starts_with("mesh:")).unwrap_or_else(|| panic!("no mesh line: {report}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = words.iter().position(|w| w.starts_with("triangles")).unwrap();
    words[at - 1].trim_end_matches(',').parse().unwrap()
}

#[test]
fn sparse_sampling_meshes_the_field_as_the_dense_path_counts_it() {
    let dir = tempfile::tempdir().unwrap();
    let (dense, sparse) = (dir.path().join("d.ply"), dir.path().join("s.ply"));
    for (out, extra) in [(&dense, None), (&sparse, Some("--sparse"))] {
        let mut args = vec!["extract", "-i", "field:torus?n=90", "--method", "mc", "-o", p(out)];
        args.extend(extra);
        let o = isoforge(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let (d, s) = (check(&dense), check(&sparse));
    assert!(s.contains("closed: yes   manifold: yes   oriented: yes"), "{s}");
    // Crossings differ (the dense path refines each on the field, sparse samples interpolate):
    // the same cells, so the same triangle count.
    assert_eq!(triangles(&d), triangles(&s));
}

#[test]
fn levels_coarsen_and_following_keeps_the_components_around_the_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let out = |n: &str| dir.path().join(n);
    let run = |args: &[&str]| {
        let o = isoforge(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    };
    run(&["extract", "-i", "field:sphere?n=97", "--sparse", "--method", "mc", "-o", p(&out("l0.ply"))]);
    run(&["extract", "-i", "field:sphere?n=97", "--sparse", "--level", "2", "--method", "mc", "-o", p(&out("l2.ply"))]);
    let (l0, l2) = (triangles(&check(&out("l0.ply"))), triangles(&check(&out("l2.ply"))));
    assert!(l2 * 10 < l0 && l2 > 0, "level 2: {l2} triangles, level 0: {l0}");
    // The gyroid clipped to a ball: following from every block is the whole mesh; from a seed at
    // the centre, the cells connected to it (closed, part of the whole).
    run(&["extract", "-i", "field:gyroid?n=80&clip=0.8", "--follow", "-o", p(&out("all.ply"))]);
    run(&["extract", "-i", "field:gyroid?n=80&clip=0.8", "--sparse", "-o", p(&out("sparse.ply"))]);
    assert_eq!(triangles(&check(&out("all.ply"))), triangles(&check(&out("sparse.ply"))));
    let seeded = out("seed.ply");
    run(&["extract", "-i", "field:gyroid?n=80&clip=0.8", "--seed", "0,0,0", "-o", p(&seeded)]);
    let r = check(&seeded);
    assert!(r.contains("closed: yes"), "{r}");
    let (part, all) = (triangles(&r), triangles(&check(&out("all.ply"))));
    assert!(part > 0 && part <= all, "seeded {part} of {all} triangles");
    fails(
        &["extract", "-i", "field:sphere?n=40", "--seed", "0.99,0.99,0.99", "-o", p(&out("none.ply"))],
        "no surface",
        &out("none.ply"),
    );
    fails(&["extract", "-i", "field:sphere?n=40", "--seed", "1,2", "-o", p(&out("x.ply"))], "--seed", &out("x.ply"));
    fails(
        &["extract", "-i", "field:sphere?n=40", "--lipschitz", "0", "-o", p(&out("x.ply"))],
        "--lipschitz",
        &out("x.ply"),
    );
}

#[test]
fn openvdb_files_are_read_as_sparse_grids() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = testdata().join("vdb/sphere.vdb");
    let out = dir.path().join("v.ply");
    let o = isoforge(&["extract", "-i", p(&vdb), "--iso", "0", "-o", p(&out), "--require", "watertight"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let info = String::from_utf8_lossy(&isoforge(&["info", p(&vdb)]).stdout).into_owned();
    for words in ["sparse f32", "level set", "active points", "leaves of 8³", "index:"] {
        assert!(info.contains(words), "info lacks {words:?}: {info}");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&isoforge(&["info", p(&vdb), "--json"]).stdout).expect("info --json");
    assert_eq!(json["sparse"]["active_points"], 2424);
    fails(
        &["extract", "-i", p(&vdb), "--iso", "0", "--roi", "0:5,:,:", "-o", p(&out.with_extension("x.ply"))],
        "--roi",
        &out.with_extension("x.ply"),
    );
    let frustum = testdata().join("vdb/frustum.vdb");
    fails(
        &["extract", "-i", p(&frustum), "--iso", "0", "-o", p(&dir.path().join("f.ply"))],
        "frustum",
        &dir.path().join("f.ply"),
    );
}

#[test]
fn caps_that_cannot_hold_are_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.ply");
    // A field does not stream: its table and largest mesh must fit.
    fails(&["extract", "-i", "field:gyroid?n=400", "--max-memory", "10M", "-o", p(&out)], "fields do not stream", &out);
    // A stream holds its slabs whatever the cap.
    let raw = dir.path().join("v.raw");
    std::fs::write(&raw, vec![0u8; 300 * 300 * 4]).unwrap();
    fails(
        &[
            "extract",
            "-i",
            p(&raw),
            "--dims",
            "300,300,4",
            "--dtype",
            "u8",
            "--iso",
            "1",
            "--max-memory",
            "1K",
            "-o",
            p(&out),
        ],
        "at least",
        &out,
    );
    // A sparse file is read whole and meshed in memory: the read stops at the cap, and a mesh
    // that could exceed it is refused before the work; a cap that holds is honoured.
    let sphere = testdata().join("vdb/sphere.vdb");
    let vdb = |cap: &'static str| ["extract", "-i", p(&sphere), "--iso", "0", "--max-memory", cap, "-o", p(&out)];
    fails(&vdb("10K"), "its grid needs more than --max-memory 10 KiB", &out);
    fails(&vdb("1M"), "more than --max-memory 1 MiB", &out);
    let o = isoforge(&vdb("200M"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(triangles(&check(&out)) > 1000);
    std::fs::remove_file(&out).unwrap();
    // More isos than files one run writes: refused at once.
    let isos: Vec<String> = (0..1100).map(|i| format!("{}", -0.5 + i as f64 / 1000.0)).collect();
    fails(&["extract", "-i", "field:sphere?n=16", "--iso", &isos.join(","), "-o", p(&out)], "at most 1024", &out);
}

#[test]
fn many_labels_are_announced_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, out) = (dir.path().join("l.raw"), dir.path().join("l.ply"));
    // 100 labels in a 10×10×3 volume: a warning names the count, and all are meshed.
    let mut bytes = vec![0u8; 10 * 10 * 3];
    for (i, b) in bytes.iter_mut().enumerate().skip(100).take(100) {
        *b = (i - 99) as u8;
    }
    std::fs::write(&raw, bytes).unwrap();
    let o =
        isoforge(&["extract", "-i", p(&raw), "--dims", "10,10,3", "--dtype", "u8", "--labels", "all", "-o", p(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("100 labels"), "{}", stderr(&o));
}
