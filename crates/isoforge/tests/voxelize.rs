//! Issue 46: voxelizing broken meshes. Each analytic solid is meshed, damaged (faces removed,
//! flipped, duplicated; pieces that cross each other), voxelized, and the grid's signs are
//! checked against the analytic shape at every lattice point more than one cell from its
//! surface; the band's distances are checked against a brute-force distance to every triangle.

use glam::DVec3;
use isoforge::grid::Lattice;
use isoforge::math::Vec3;
use isoforge::mesh::distance::distance_squared;
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, Options};
use isoforge::volume::{Iso, Sampled};
use isoforge::voxelize::{self, Resolution, VoxelizeOptions};

/// A closed, outward mesh of the zero set of `f` on [-1.2, 1.2]³.
fn mesh_of(f: impl Fn(Vec3) -> f32 + Sync + Send, n: u32) -> Mesh {
    let lattice = Lattice::spanning([n; 3], [-1.2; 3], [1.2; 3]).unwrap();
    let out = pipeline::extract(&Sampled::new(f, lattice), Iso::below(0.0), &Options::default()).unwrap();
    out.mesh
}

fn torus(p: Vec3, r: f32, t: f32) -> f32 {
    let q = ((p.x * p.x + p.y * p.y).sqrt() - r, p.z);
    (q.0 * q.0 + q.1 * q.1).sqrt() - t
}

/// A splitmix64 stream: the same damage every run.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Removes `holes` of the faces, flips `flips` of them, appends `dups` of them again (separate
/// vertices, reversed half the time).
fn damage(mesh: &Mesh, holes: f64, flips: f64, dups: f64, seed: u64) -> Mesh {
    let mut rng = Rng(seed);
    let mut out = Mesh { positions: mesh.positions.clone(), ..Mesh::default() };
    for t in mesh.all_triangles() {
        if rng.next() < holes {
            continue;
        }
        let t = if rng.next() < flips { [t[0], t[2], t[1]] } else { t };
        out.triangles.push(t);
        if rng.next() < dups {
            let base = out.positions.len() as u32;
            out.positions.extend(t.map(|v| mesh.positions[v as usize]));
            out.triangles.push(if rng.next() < 0.5 { [base, base + 1, base + 2] } else { [base, base + 2, base + 1] });
        }
    }
    out
}

fn merge(parts: &[Mesh]) -> Mesh {
    let mut out = Mesh::default();
    for m in parts {
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&m.positions);
        out.triangles.extend(m.all_triangles().map(|t| t.map(|v| v + base)));
    }
    out
}

/// The fraction of lattice points more than one cell from the analytic surface whose side is right.
fn sign_accuracy(mesh: &Mesh, sdf: &dyn Fn(DVec3) -> f64) -> (f64, usize) {
    let lattice = voxelize::lattice_for(mesh, Resolution::Cells(64), 4).unwrap();
    let grid = voxelize::voxelize(mesh, lattice.clone(), &VoxelizeOptions::default()).unwrap().grid;
    let h = lattice.spacing()[0];
    let (mut right, mut total) = (0usize, 0usize);
    let dims = lattice.dims();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = DVec3::from_array(lattice.to_world([x as f64, y as f64, z as f64]));
                let truth = sdf(p);
                if truth.abs() <= h {
                    continue;
                }
                total += 1;
                right += ((grid.get([x, y, z]) < 0.0) == (truth < 0.0)) as usize;
            }
        }
    }
    (right as f64 / total as f64, total - right)
}

struct Shape {
    name: &'static str,
    mesh: Mesh,
    sdf: Box<dyn Fn(DVec3) -> f64>,
}

fn shapes() -> Vec<Shape> {
    let t = |p: DVec3, c: DVec3, r: f64, s: f64| {
        let q = p - c;
        let a = (q.x * q.x + q.y * q.y).sqrt() - r;
        (a * a + q.z * q.z).sqrt() - s
    };
    let inner = {
        let mut m = mesh_of(|p| p.length() - 0.45, 40);
        m.flip();
        m
    };
    vec![
        Shape {
            name: "torus",
            mesh: mesh_of(|p| torus(p, 0.7, 0.3), 48),
            sdf: Box::new(move |p| t(p, DVec3::ZERO, 0.7, 0.3)),
        },
        Shape {
            name: "genus-2 (two tori crossing each other, not merged)",
            mesh: merge(&[
                mesh_of(|p| torus(p - Vec3::new(-0.42, 0.0, 0.0), 0.45, 0.18), 56),
                mesh_of(|p| torus(p - Vec3::new(0.42, 0.0, 0.0), 0.45, 0.18), 56),
            ]),
            sdf: Box::new(move |p| {
                t(p, DVec3::new(-0.42, 0.0, 0.0), 0.45, 0.18).min(t(p, DVec3::new(0.42, 0.0, 0.0), 0.45, 0.18))
            }),
        },
        Shape {
            name: "nested shells (a hollow ball)",
            mesh: merge(&[mesh_of(|p| p.length() - 0.9, 40), inner]),
            sdf: Box::new(|p| (p.length() - 0.9).max(0.45 - p.length())),
        },
        Shape {
            name: "thin plate",
            mesh: mesh_of(|p| (p.x.abs() - 0.9).max(p.y.abs() - 0.9).max(p.z.abs() - 0.06), 81),
            sdf: Box::new(|p| {
                let q = DVec3::new(p.x.abs() - 0.9, p.y.abs() - 0.9, p.z.abs() - 0.06);
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }),
        },
    ]
}

#[test]
fn issue_46_signs_are_right_on_damaged_solids() {
    let mut worst = 1.0f64;
    for shape in shapes() {
        for (holes, flips, dups) in
            [(0.0, 0.0, 0.0), (0.05, 0.05, 0.0), (0.2, 0.0, 0.0), (0.0, 0.2, 0.0), (0.2, 0.2, 0.1)]
        {
            let broken = damage(&shape.mesh, holes, flips, dups, 46);
            let (acc, wrong) = sign_accuracy(&broken, &*shape.sdf);
            println!(
                "{:<50} holes {holes:.2} flips {flips:.2} dups {dups:.2}: {:.5}% right ({wrong} wrong)",
                shape.name,
                100.0 * acc
            );
            worst = worst.min(acc);
        }
    }
    assert!(worst >= 0.9999, "worst sign accuracy {worst}");
}

#[test]
fn issue_46_band_distances_are_exact() {
    let mesh = damage(&mesh_of(|p| torus(p, 0.7, 0.3), 32), 0.1, 0.1, 0.0, 7);
    let lattice = voxelize::lattice_for(&mesh, Resolution::Cells(40), 4).unwrap();
    let opts = VoxelizeOptions { band: 2.5, ..VoxelizeOptions::default() };
    let grid = voxelize::voxelize(&mesh, lattice.clone(), &opts).unwrap().grid;
    let tris: Vec<[DVec3; 3]> =
        mesh.all_triangles().map(|t| t.map(|v| DVec3::from_array(mesh.positions[v as usize].map(f64::from)))).collect();
    let h = lattice.spacing()[0];
    let diag = (lattice.dims()[0] as f64 * h) * 3f64.sqrt();
    let (mut checked, mut worst) = (0, 0.0f64);
    let dims = lattice.dims();
    for z in (0..dims[2]).step_by(2) {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = DVec3::from_array(lattice.to_world([x as f64, y as f64, z as f64]));
                let exact = tris.iter().map(|t| distance_squared(p, t)).fold(f64::INFINITY, f64::min).sqrt();
                let got = grid.get([x, y, z]).abs() as f64;
                if exact < opts.band * h * 0.999 {
                    worst = worst.max((got - exact).abs() / diag);
                    checked += 1;
                } else {
                    assert!(got >= opts.band * h * 0.999 - 1e-6, "{p}: {got} vs {exact}");
                }
            }
        }
    }
    assert!(checked > 1000);
    assert!(worst <= 1e-5, "worst relative distance error {worst}");
}

#[test]
fn issue_46_a_signed_octree_written_from_a_mesh_contours_to_its_surface() {
    let mesh = damage(&mesh_of(|p| torus(p, 0.7, 0.3), 40), 0.05, 0.05, 0.0, 3);
    let lattice = voxelize::lattice_for_octree(&mesh, 6, 4).unwrap();
    let h = lattice.spacing()[0];
    assert_eq!(lattice.dims(), [65; 3]);
    let v = voxelize::voxelize(&mesh, lattice, &VoxelizeOptions::default()).unwrap();
    let tree = v.to_signed_octree().unwrap();
    assert_eq!(tree.depth(), 6);
    let out = isoforge::extract::contour_octree(&tree);
    assert_eq!(out.open_edges, 0);
    let r = isoforge::topo::check(&out.mesh);
    assert!(r.is_closed() && r.is_oriented(), "{r:?}");
    assert_eq!(r.genus(), Some(1));
    // Within a cell of the mesh we voxelized, both ways (its holes are smaller than a cell).
    let d = isoforge::topo::hausdorff(&out.mesh, &mesh);
    assert!(d.max() <= h, "{d:?}, cell {h}");
    // Not a cube of 2^depth cells: refused.
    let l = voxelize::lattice_for(&mesh, Resolution::Cells(40), 4).unwrap();
    assert!(voxelize::voxelize(&mesh, l, &VoxelizeOptions::default()).unwrap().to_signed_octree().is_err());
}
