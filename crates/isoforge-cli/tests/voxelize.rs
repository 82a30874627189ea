//! `isoforge voxelize` and `isoforge repair` (issue 46): a mesh with a hole becomes a closed
//! solid, its volume files read back with the mesh's geometry, and bad requests exit 2 with one
//! line, leaving no file (and an existing one untouched).

mod common;

use std::path::Path;

use common::{fails, isoforge, p};

use isoforge::grid::AnyGrid;
use isoforge_io::Limits;

/// A unit cube as OBJ, its top face missing (two triangles) and one side face flipped.
fn open_cube(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("open_cube.obj");
    let mut s = String::new();
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..2 {
                s += &format!("v {x} {y} {z}\n");
            }
        }
    }
    // Corners 1 + x + 2y + 4z (OBJ counts from 1); faces wound outward, top (z = 1) left out.
    let faces = [
        [1, 3, 4],
        [1, 4, 2], // bottom
        [1, 2, 6],
        [1, 6, 5], // y = 0
        [3, 7, 8],
        [3, 8, 4], // y = 1
        [1, 5, 7],
        [1, 7, 3], // x = 0
        [2, 6, 8],
        [2, 4, 8], // x = 1, its first triangle flipped
    ];
    for f in faces {
        s += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(&path, s).unwrap();
    path
}

#[test]
fn issue_46_an_open_cube_repairs_to_a_closed_box_and_voxelizes_with_its_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let cube = open_cube(dir.path());
    let out = dir.path().join("cube.ply");
    let o = isoforge(&["repair", p(&cube), "-o", p(&out), "--resolution", "24", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["closed"], true, "{j}");
    assert_eq!(j["manifold"], true, "{j}");
    assert_eq!(j["genus"], 0, "{j}");
    assert_eq!(j["voxelize"]["repairs"]["flipped_faces"], 1, "{j}");
    // Every input vertex is within a cell and a half of the output (marching cubes cuts the
    // corners); the patch across the open top is at
    // most half the top's width from the input.
    let h = 1.0 / 24.0;
    assert!(j["hausdorff"]["from_input"].as_f64().unwrap() < 1.5 * h, "{j}");
    assert!(j["hausdorff"]["to_input"].as_f64().unwrap() < 0.5 + h, "{j}");
    // Enclosed volume of the unit box, within a cell's worth of area.
    assert!((j["volume"].as_f64().unwrap() - 1.0).abs() < 6.0 * h, "{j}");

    // Dense signed distances: negative inside, the box's centre half a unit deep.
    let nrrd = dir.path().join("cube.nrrd");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&nrrd), "--resolution", "16", "--band", "10"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let AnyGrid::F32(g) = isoforge_io::read_volume(&nrrd, &Limits::default()).unwrap() else { panic!("f32 expected") };
    let l = g.lattice();
    let centre = l.to_index([0.5; 3]).map(|v| v.round() as u32);
    assert!((g.get(centre) + 0.5).abs() < 1e-6, "{}", g.get(centre));
    assert!(g.get([0, 0, 0]) > 0.0);
    // Occupancy: the inside count is the box's volume in cells, within a layer.
    let occ = dir.path().join("occ.nii");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&occ), "--resolution", "16", "--values", "occupancy"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let AnyGrid::U8(g) = isoforge_io::read_volume(&occ, &Limits::default()).unwrap() else { panic!("u8 expected") };
    let inside = g.data().iter().filter(|&&v| v == 1).count();
    assert!((15usize.pow(3)..=17usize.pow(3)).contains(&inside), "{inside}");
    // Sparse: a level set OpenVDB files hold.
    let vdb = dir.path().join("cube.vdb");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&vdb)]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let f = isoforge_io::read_sparse(&vdb, None, &Limits::default()).unwrap();
    assert_eq!(f.class.as_deref(), Some("level set"));
    // PolyMender's signed octree: 20 cells round up to depth 5; its contour is the closed box.
    let sog = dir.path().join("cube.sog");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&sog), "--resolution", "20"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let tree = isoforge_io::read_sog(&sog, &Limits::default()).unwrap();
    assert_eq!(tree.depth(), 5);
    let r = isoforge::topo::check(&isoforge::extract::contour_octree(&tree).mesh);
    assert!(r.is_closed() && r.is_oriented() && r.genus() == Some(0), "{r:?}");
    // PolyMender's --depth: 2^D cells, the same octree as the resolution it stands for.
    let by_depth = dir.path().join("depth.sog");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&by_depth), "--depth", "5"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let by_resolution = dir.path().join("resolution.sog");
    let o = isoforge(&["voxelize", p(&cube), "-o", p(&by_resolution), "--resolution", "32"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(&by_depth).unwrap(), std::fs::read(&by_resolution).unwrap());
    let o = isoforge(&["repair", p(&cube), "-o", p(&dir.path().join("d.ply")), "--depth", "4", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["genus"], 0, "{j}");
}

#[test]
fn issue_46_bad_requests_exit_2_with_one_line_and_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let cube = open_cube(dir.path());
    let out = dir.path().join("out.nrrd");
    let c = p(&cube);
    fails(&["voxelize", c, "-o", p(&out), "--resolution", "0"], "--resolution \"0\"", &out);
    fails(&["voxelize", c, "-o", p(&out), "--resolution", "x"], "--resolution \"x\"", &out);
    fails(&["voxelize", c, "-o", p(&out), "--depth", "15"], "--depth \"15\"", &out);
    fails(&["voxelize", c, "-o", p(&out), "--depth", "4", "--resolution", "8"], "--depth", &out);
    fails(&["voxelize", c, "-o", p(&out), "--voxel-size", "-1"], "--voxel-size \"-1\"", &out);
    fails(&["voxelize", c, "-o", p(&out), "--band", "0.5"], "--band \"0.5\"", &out);
    fails(&["voxelize", c, "-o", p(&out), "--values", "mass"], "--values \"mass\"", &out);
    let vdb = dir.path().join("out.vdb");
    fails(&["voxelize", c, "-o", p(&vdb), "--values", "occupancy"], "occupancy", &vdb);
    let ply = dir.path().join("out.ply");
    fails(&["voxelize", c, "-o", p(&ply)], "voxelize writes .vdb, .sog, .nrrd", &ply);
    let sog = dir.path().join("out.sog");
    fails(&["voxelize", c, "-o", p(&sog), "--voxel-size", "0.1"], "needs --resolution", &sog);
    fails(&["repair", c, "-o", p(&out)], "unknown output format", &out);
    // A grid that does not fit the budget is refused before it is allocated, with the figures.
    fails(&["voxelize", c, "-o", p(&out), "--resolution", "1000", "--max-bytes", "10M"], "over the limit", &out);
    // Input problems name the file.
    let missing = dir.path().join("missing.obj");
    fails(&["repair", p(&missing), "-o", p(&ply)], "missing.obj", &ply);
    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, "v 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
    fails(&["voxelize", p(&empty), "-o", p(&out)], "empty.obj", &out);
    let nan = dir.path().join("nan.obj");
    std::fs::write(&nan, "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fails(&["voxelize", p(&nan), "-o", p(&out)], "nan.obj", &out);
    // An existing output survives a failed run.
    std::fs::write(&out, "keep").unwrap();
    let o = isoforge(&["voxelize", c, "-o", p(&out), "--resolution", "1000", "--max-bytes", "10M"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep");
}
