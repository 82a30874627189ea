//! PolyMender's signed octree grids (`.sog`, issues 46 and 47): the real files of
//! `../shared/data/sog` read, re-encode byte for byte (as read, and rebuilt by
//! `SignedOctree::from_cells` from their signs and vertices), contour to closed oriented surfaces
//! of the manifest's genus; trees of analytic sign functions round-trip; every malformed input
//! gets its one-line message.
#![cfg(feature = "sog")]

use std::path::{Path, PathBuf};
use std::time::Instant;

use isoforge::extract::contour_octree;
use isoforge::grid::{OctreeNode, SignedOctree};
use isoforge::topo;
use isoforge_io::read::sog::read_sog_bytes;
use isoforge_io::write::sog::write_sog;
use isoforge_io::Limits;

/// The shared SOG folder, next to the project's checkout (or at /work/shared).
fn sog_dir() -> Option<PathBuf> {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sog");
    [beside, PathBuf::from("/work/shared/data/sog")].into_iter().find(|d| d.is_dir())
}

/// Each real file with the genus the manifest gives it (`None`: not stated).
const REAL: [(&str, Option<i64>); 4] =
    [("sogfile.sog", Some(1)), ("wisky.5.sog", Some(2)), ("knot_6.sog", None), ("clip_7.sog", None)];

fn bytes_of(tree: &SignedOctree) -> Vec<u8> {
    let mut out = Vec::new();
    write_sog(&mut out, tree).unwrap();
    out
}

/// The tree rebuilt from its signs at points and its leaves' vertices, as PolyMender builds it.
fn rebuilt(tree: &SignedOctree) -> SignedOctree {
    let outside = |p: [u32; 3]| tree.corner_outside(p);
    let vertex = |c: [u32; 3]| tree.leaf_at(c).map(|l| l.vertex);
    SignedOctree::from_cells(tree.depth(), tree.origin(), tree.edge(), &outside, &vertex).unwrap()
}

#[test]
fn real_files_read_re_encode_and_contour_with_their_genus() {
    let Some(dir) = sog_dir() else {
        eprintln!("sog: skipped, no data folder at ../shared/data/sog or /work/shared/data/sog");
        return;
    };
    for (name, genus) in REAL {
        let path = dir.join(name);
        let file = std::fs::read(&path).unwrap();
        let t0 = Instant::now();
        let tree = isoforge_io::read_sog(&path, &Limits::default()).unwrap();
        let read = t0.elapsed();
        assert_eq!(bytes_of(&tree), file, "{name}: written again, the bytes differ");
        assert_eq!(rebuilt(&tree), tree, "{name}: from_cells does not rebuild the file's tree");
        let grid = tree.to_sign_grid().unwrap();
        let leaves_agree = tree.leaves().all(|l| {
            (0..8u32).all(|c| {
                let p = [l.ijk[0] + (c >> 2 & 1), l.ijk[1] + (c >> 1 & 1), l.ijk[2] + (c & 1)];
                (grid.get(p) > 0.0) == l.corner_outside([c >> 2 & 1, c >> 1 & 1, c & 1])
            })
        });
        assert!(leaves_agree, "{name}: a leaf's corner disagrees with the sign grid");

        let t0 = Instant::now();
        let out = contour_octree(&tree);
        let contour = t0.elapsed();
        let r = topo::check(&out.mesh);
        println!(
            "{name}: depth {}, {} nodes, {} leaves; read {:.1} ms, contour {:.1} ms; {} vertices, {} quads \
             ({} triangles); closed {}, oriented {}, non-manifold edges {}, vertices {}; components {}, genus {:?}",
            tree.depth(),
            tree.node_count(),
            tree.leaves().len(),
            read.as_secs_f64() * 1e3,
            contour.as_secs_f64() * 1e3,
            r.vertices,
            r.quads,
            2 * r.quads,
            r.is_closed(),
            r.is_oriented(),
            r.non_manifold_edges.count,
            r.non_manifold_vertices.count,
            r.components.len(),
            r.components.iter().map(|c| c.genus).collect::<Vec<_>>(),
        );
        assert_eq!(out.open_edges, 0, "{name}");
        assert!(r.is_closed() && r.is_oriented(), "{name}: {r:?}");
        assert!(r.volume > 0.0, "{name}: volume {} (normals inwards?)", r.volume);
        if let Some(g) = genus {
            assert_eq!(r.genus(), Some(g), "{name}");
        }
    }
}

#[test]
fn a_sog_file_reads_as_its_sign_grid() {
    let Some(dir) = sog_dir() else {
        eprintln!("sog: skipped, no data folder at ../shared/data/sog or /work/shared/data/sog");
        return;
    };
    let path = dir.join("wisky.5.sog");
    let grid = isoforge_io::read_volume(&path, &Limits::default()).unwrap();
    let l = grid.lattice();
    assert_eq!(l.dims(), [33; 3]);
    assert!((l.spacing()[0] - 2.222_222_328_186_035 / 32.0).abs() < 1e-9);
    assert_eq!(grid.value_range().map(|r| (r.min, r.max)), Some((-1.0, 1.0)));
    // One empty node at dim 64: a tiny file, a large grid, refused before it is made.
    let tmp = tempfile::tempdir().unwrap();
    let big = tmp.path().join("big.sog");
    std::fs::write(&big, file(1.0, 64, &[1, 1])).unwrap();
    let err = isoforge_io::read_volume(&big, &Limits::new(1_000_000)).unwrap_err().to_string();
    assert!(
        err.ends_with("big.sog: the sign grid of 65³ points needs 1098500 bytes, over the limit of 1000000 bytes (raise it with --max-bytes)"),
        "{err}"
    );
}

/// A solid torus about the centre of `2^depth` cells (axis z, radii in cells), vertices at
/// the cells' centres; or a ball when `small` is 0.
fn analytic(depth: u32, big: f64, small: f64) -> SignedOctree {
    let c = (1u32 << depth) as f64 / 2.0;
    let inside = move |p: [u32; 3]| {
        let [x, y, z] = p.map(|v| v as f64 - c);
        if small == 0.0 {
            return x * x + y * y + z * z < big * big;
        }
        let q = (x * x + y * y).sqrt() - big;
        q * q + z * z < small * small
    };
    let h = 2.0 / (1u32 << depth) as f32;
    let vertex = move |ijk: [u32; 3]| {
        let n: u32 =
            (0..8).map(|c| inside([ijk[0] + (c >> 2 & 1), ijk[1] + (c >> 1 & 1), ijk[2] + (c & 1)]) as u32).sum();
        (n != 0 && n != 8).then(|| ijk.map(|x| -1.0 + (x as f32 + 0.5) * h))
    };
    SignedOctree::from_cells(depth, [-1.0; 3], 2.0, &move |p| !inside(p), &vertex).unwrap()
}

#[test]
fn analytic_trees_round_trip_and_contour_with_their_genus() {
    for (depth, big, small, genus) in [(5, 11.0, 0.0, 0), (5, 9.0, 4.0, 1), (6, 18.0, 6.5, 1), (3, 2.5, 0.0, 0)] {
        let tree = analytic(depth, big, small);
        let bytes = bytes_of(&tree);
        let back = read_sog_bytes(Path::new("t.sog"), &bytes, &Limits::default()).unwrap();
        assert_eq!(back, tree);
        assert_eq!(rebuilt(&back), tree);
        let out = contour_octree(&tree);
        let r = topo::check(&out.mesh);
        assert!(r.is_closed() && r.is_oriented() && out.open_edges == 0, "depth {depth}: {r:?}");
        assert_eq!(r.genus(), Some(genus), "depth {depth}, radii {big}, {small}");
    }
}

#[test]
fn write_sog_is_atomic_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ball.sog");
    let tree = analytic(4, 5.0, 0.0);
    isoforge_io::write_sog(&path, &tree).unwrap();
    assert_eq!(isoforge_io::read_sog(&path, &Limits::default()).unwrap(), tree);
}

/// A file: magic, origin [0, 0, 0], edge `edge`, zero padding, `dim`, then `nodes`.
fn file(edge: f32, dim: i32, nodes: &[u8]) -> Vec<u8> {
    let mut b = b"SOG.Format 1.0\0".to_vec();
    for v in [0.0f32, 0.0, 0.0, edge] {
        b.extend(v.to_le_bytes());
    }
    b.resize(128, 0);
    b.extend(dim.to_le_bytes());
    b.extend(nodes);
    b
}

/// A leaf's bytes: signs, then the vertex.
fn leaf(signs: u8, v: [f32; 3]) -> Vec<u8> {
    let mut b = vec![2, signs];
    for x in v {
        b.extend(x.to_le_bytes());
    }
    b
}

fn error(bytes: &[u8]) -> String {
    read_sog_bytes(Path::new("t.sog"), bytes, &Limits::default()).unwrap_err().to_string()
}

#[test]
fn malformed_files_name_the_byte_the_field_and_the_value() {
    // A valid depth-1 tree: one leaf and seven empty cells.
    let mut good = vec![0u8];
    good.extend(leaf(0x7f, [0.5; 3]));
    for _ in 0..7 {
        good.extend([1, 1]);
    }
    let tree = read_sog_bytes(Path::new("t.sog"), &file(2.0, 2, &good), &Limits::default()).unwrap();
    assert_eq!((tree.depth(), tree.node_count(), tree.leaves().len()), (1, 9, 1));
    assert!(!tree.corner_outside([1, 1, 1]));

    let mut magic = file(2.0, 2, &good);
    magic[11] = b'2';
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (file(2.0, 2, &good)[..100].to_vec(), "t.sog: the header needs 132 bytes, the file has 100 (truncated or not a SOG file?)"),
        (magic, "t.sog: byte 0: magic \"SOG.Format 2.0\\x00\": expected \"SOG.Format 1.0\" and a NUL byte (not a SOG file?)"),
        (file(2.0, 3, &good), "t.sog: byte 128: dim 3: must be a power of two from 1 to 65536"),
        (file(2.0, 0, &good), "t.sog: byte 128: dim 0: must be a power of two from 1 to 65536"),
        (file(2.0, -4, &good), "t.sog: byte 128: dim -4: must be a power of two from 1 to 65536"),
        (file(2.0, 1 << 17, &good), "t.sog: byte 128: dim 131072: must be a power of two from 1 to 65536"),
        (file(0.0, 2, &good), "t.sog: byte 15: edge length 0: must be finite and positive"),
        (file(f32::NAN, 2, &good), "t.sog: byte 15: edge length NaN: must be finite and positive"),
        (file(2.0, 2, &good[..5]), "t.sog: byte 133: a leaf needs 14 bytes, only 4 are left (truncated file?)"),
        (
            file(2.0, 2, &good[..19]),
            "t.sog: byte 151: the tree ends early: after 4 nodes, the node at level 1, cell [0, 1, 1] is missing (truncated file?)",
        ),
        (file(2.0, 2, &[]), "t.sog: byte 132: the tree ends early: after 0 nodes, the node at level 0, cell [0, 0, 0] is missing (truncated file?)"),
        (file(2.0, 2, &[good.as_slice(), &[1, 1]].concat()), "t.sog: byte 161: 2 bytes after the end of the tree (not a SOG file of dim 2?)"),
        (file(2.0, 2, &[3]), "t.sog: byte 132: node type 3: expected 0 (internal), 1 (empty) or 2 (leaf)"),
        (file(2.0, 2, &[1, 2]), "t.sog: byte 133: empty node sign 2: expected 0 (inside) or 1 (outside)"),
        (file(2.0, 2, &[1]), "t.sog: byte 132: an empty node needs 2 bytes, only 1 are left (truncated file?)"),
        (
            file(2.0, 2, &leaf(1, [0.5; 3])),
            "t.sog: byte 132: node 0 (level 0, cell [0, 0, 0]): a leaf above the finest level (level 0 of 1)",
        ),
        (
            file(2.0, 1, &[0]),
            "t.sog: byte 132: node 0 (level 0, cell [0, 0, 0]): an internal node at the finest level (depth 0)",
        ),
        (
            file(2.0, 2, &[&[0u8][..], &leaf(1, [0.5, f32::NAN, 0.5])].concat()),
            "t.sog: byte 133: node 1 (level 1, cell [0, 0, 0]): vertex coordinate NaN is not finite",
        ),
        (
            file(2.0, 2, &[&[0u8][..], &leaf(1, [0.5, 0.5, 1.25])].concat()),
            "t.sog: byte 133: node 1 (level 1, cell [0, 0, 0]): vertex [0.5, 0.5, 1.25] lies outside the cell: its z is 1.2500 cells from the cell's low face (0 to 1)",
        ),
    ];
    for (bytes, want) in cases {
        assert_eq!(error(&bytes), want);
    }
    // A non-finite origin.
    let mut nan_origin = file(2.0, 2, &good);
    nan_origin[19..23].copy_from_slice(&f32::INFINITY.to_le_bytes());
    assert_eq!(error(&nan_origin), "t.sog: byte 15: origin coordinate inf: must be finite");
    // The tree's memory, bounded by the file's length, checked before reading.
    let small = read_sog_bytes(Path::new("t.sog"), &file(2.0, 2, &good), &Limits::new(100)).unwrap_err();
    assert_eq!(
        small.to_string(),
        "t.sog: a tree of 29 bytes of nodes needs 1160 bytes, over the limit of 100 bytes (raise it with --max-bytes)"
    );
    assert_eq!(
        isoforge_io::read_sog(Path::new("/nonexistent/x.sog"), &Limits::default()).unwrap_err().to_string(),
        "/nonexistent/x.sog: No such file or directory"
    );
}

#[test]
fn every_prefix_of_a_file_is_refused_without_a_panic() {
    let bytes = bytes_of(&analytic(3, 2.5, 0.0));
    for n in 0..bytes.len() {
        let e = read_sog_bytes(Path::new("t.sog"), &bytes[..n], &Limits::default()).unwrap_err().to_string();
        assert!(e.starts_with("t.sog: ") && !e.contains('\n'), "{n}: {e}");
    }
    // Flipping any byte of the tree gives a tree or one line, never a panic.
    for i in 128..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0xa5;
        if let Err(e) = read_sog_bytes(Path::new("t.sog"), &b, &Limits::default()) {
            assert!(!e.to_string().contains('\n'));
        }
    }
}

#[test]
fn the_file_order_is_pre_order() {
    let tree = analytic(2, 1.5, 0.0);
    let nodes: Vec<OctreeNode> = tree.preorder().collect();
    assert_eq!(nodes[0], OctreeNode::Internal);
    assert_eq!(nodes.len(), tree.node_count());
}
