//! Issue 45 (first part): dual contouring on uniform lattices, and the cell's frame it is built on
//! (crossings and normals in the coordinates `place_vertex` takes).

mod common;

use isoforge::cube::{CubeEdge, CASE_EDGES};
use isoforge::extract::{Cell, DualContouring, Extractor, SurfaceNets};
use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use isoforge::math::Vec3;
use isoforge::mesh::{Mesh, MeshBuilder, Normals};
use isoforge::pipeline::{self, Adaptivity, Method, Options};
use isoforge::topo;
use isoforge::volume::{Field, GridVolume, Iso, Linear, Sampled};
use isoforge::walk::{FlyingEdgesWalker, ReferenceWalker, SlabWalker, Walker};

/// A box rotated about the origin: exact signed distance and gradient.
#[derive(Debug, Clone, Copy)]
struct RotatedBox {
    center: Vec3,
    half: Vec3,
    /// Rows: the box's axes in world coordinates (orthonormal).
    axes: [Vec3; 3],
}

impl RotatedBox {
    fn new(center: Vec3, half: Vec3, yaw: f32, pitch: f32, roll: f32) -> Self {
        let r = glam::Mat3::from_euler(glam::EulerRot::ZYX, yaw, pitch, roll);
        RotatedBox { center, half, axes: [r.x_axis, r.y_axis, r.z_axis] }
    }
    /// `p` in the box's frame, relative to its centre.
    fn local(&self, p: Vec3) -> Vec3 {
        let d = p - self.center;
        Vec3::new(self.axes[0].dot(d), self.axes[1].dot(d), self.axes[2].dot(d))
    }
    /// The eight corners in world coordinates.
    fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|c| {
            let s = [0, 1, 2].map(|a| if c >> a & 1 == 1 { 1.0 } else { -1.0 });
            self.center + (0..3).map(|a| self.axes[a] * self.half[a] * s[a]).sum::<Vec3>()
        })
    }
}

impl Field for RotatedBox {
    fn value(&self, p: Vec3) -> f32 {
        let q = self.local(p).abs() - self.half;
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let l = self.local(p);
        let q = l.abs() - self.half;
        let g = if q.max_element() > 0.0 {
            q.max(Vec3::ZERO).normalize_or_zero() * l.signum()
        } else {
            // Inside: the nearest face's normal.
            let a = if q.x >= q.y && q.x >= q.z {
                0
            } else if q.y >= q.z {
                1
            } else {
                2
            };
            let mut g = Vec3::ZERO;
            g[a] = l[a].signum();
            g
        };
        self.axes[0] * g.x + self.axes[1] * g.y + self.axes[2] * g.z
    }
}

/// The distance from `p` to triangle `abc` (the closest point by regions, as in Ericson's
/// Real-Time Collision Detection §5.1.5), in `f64`.
fn point_triangle_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let sub = |u: [f64; 3], v: [f64; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let at = |o: [f64; 3], u: [f64; 3], s: f64| [o[0] + u[0] * s, o[1] + u[1] * s, o[2] + u[2] * s];
    let dist = |q: [f64; 3]| dot(sub(p, q), sub(p, q)).sqrt();
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return dist(a);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return dist(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return dist(at(a, ab, d1 / (d1 - d3)));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return dist(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return dist(at(a, ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return dist(at(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    dist(at(at(a, ab, v), ac, w))
}

/// The distance from `p` to the mesh's surface (every polygon, quads split).
fn distance_to_mesh(m: &Mesh, p: Vec3) -> f64 {
    let p = p.to_array().map(f64::from);
    let pos = |v: u32| m.positions[v as usize].map(f64::from);
    m.all_triangles().map(|t| point_triangle_distance(p, pos(t[0]), pos(t[1]), pos(t[2]))).fold(f64::INFINITY, f64::min)
}

fn extract_field(field: RotatedBox, lattice: Lattice, method: Method) -> Mesh {
    let opts = Options { method, ..Options::default() };
    pipeline::extract(&Sampled::new(field, lattice), Iso::below(0.0), &opts).unwrap().mesh
}

/// Dual contouring of a field whose vertices may leave their cells by one cell width.
fn dc_with_margin(field: RotatedBox, lattice: Lattice) -> Mesh {
    let x = DualContouring { margin: 1.0, ..DualContouring::default() };
    common::walk_with(&mut SlabWalker::new(), &Sampled::new(field, lattice), Iso::below(0.0), &x).0
}

/// The worst corner of a rotated box, in cell widths, from dc's, emc's and mc's meshes: dc and emc
/// put a vertex on each corner (its three planes meet there: the default margin lets a vertex
/// leave its cell for it), mc cuts every corner by most of a cell.
#[test]
fn issue_45_dc_keeps_the_corners_of_a_rotated_box_that_mc_cuts() {
    let n = 32;
    let lattice = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let h = 2.0 / (n - 1) as f64;
    let boxes = [
        RotatedBox::new(Vec3::new(0.03, -0.02, 0.011), Vec3::new(0.52, 0.41, 0.33), 0.41, 0.23, 0.67),
        RotatedBox::new(Vec3::new(-0.05, 0.04, 0.02), Vec3::new(0.45, 0.5, 0.38), 1.1, -0.5, 0.3),
    ];
    for (i, b) in boxes.into_iter().enumerate() {
        let worst = |m: &Mesh| b.corners().iter().map(|&c| distance_to_mesh(m, c)).fold(0.0, f64::max) / h;
        let dc = extract_field(
            b,
            lattice.clone(),
            Method::DualContouring { quads: false, split: false, manifold: true, adaptivity: Adaptivity::UNIFORM },
        );
        let wide = dc_with_margin(b, lattice.clone());
        let mc = extract_field(b, lattice.clone(), Method::MarchingCubes);
        let emc = extract_field(b, lattice.clone(), Method::parse("emc").unwrap());
        let plain = extract_field(
            b,
            lattice.clone(),
            Method::DualContouring { quads: false, split: false, manifold: false, adaptivity: Adaptivity::UNIFORM },
        );
        let (e_dc, e_wide, e_mc, e_emc, e_plain) = (worst(&dc), worst(&wide), worst(&mc), worst(&emc), worst(&plain));
        eprintln!(
            "rotated box {i}: worst corner error dc {e_dc:.4} h (margin 1: {e_wide:.4} h, plain: {e_plain:.4} h), \
             emc {e_emc:.4} h, mc {e_mc:.4} h"
        );
        // Exact normals (a field): vertices may leave their cells for the corner their planes
        // meet at (`DEFAULT_MARGIN`), so every corner is on the mesh.
        assert!(e_emc < 0.05 && e_dc < 0.05, "box {i}: emc {e_emc:.3} cells, dc {e_dc:.3}");
        assert!(e_wide < 0.05, "box {i}: dc with a margin misses a corner by {e_wide:.3} cells");
        assert!(e_dc < e_mc, "box {i}: dc {e_dc:.3} cells, mc {e_mc:.3}");
        assert!(e_mc > 0.5, "box {i}: mc cuts corners by {e_mc:.3} cells (expected about one)");
        for m in [&dc, &wide, &emc] {
            let r = topo::check(m);
            assert!(r.is_closed() && r.is_oriented() && r.volume > 0.0, "box {i}: {r:?}");
            assert_eq!(r.euler, 2, "box {i}");
        }
    }
}

/// A sphere (a grid's central-difference normals and a field's exact ones): closed, oriented
/// outward, Euler characteristic 2, vertices close to the surface; `--quads` gives the quads the
/// triangles were split from (`Mesh::triangulate` of them is the same mesh).
#[test]
fn issue_45_dc_sphere_is_closed_oriented_and_on_the_surface() {
    let n = 28;
    let lattice = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let h = 2.0 / (n - 1) as f32;
    let r0 = 0.71;
    let sphere = move |p: Vec3| p.length() - r0;
    let g = DenseGrid::from_fn(lattice.clone(), |[i, j, k]| {
        sphere(Vec3::from([i, j, k].map(|x| -1.0 + 2.0 * x as f32 / (n - 1) as f32)))
    });
    let tri = Options {
        method: Method::DualContouring { quads: false, split: false, manifold: true, adaptivity: Adaptivity::UNIFORM },
        ..Options::default()
    };
    let quad = Options {
        method: Method::DualContouring { quads: true, split: false, manifold: true, adaptivity: Adaptivity::UNIFORM },
        ..Options::default()
    };
    let from_grid =
        |o: &Options| pipeline::extract_grid(&AnyGrid::F32(g.clone()), Iso::below(0.0), o, None).unwrap().mesh;
    let from_field =
        |o: &Options| pipeline::extract(&Sampled::new(sphere, lattice.clone()), Iso::below(0.0), o).unwrap().mesh;
    for (what, m, q) in [("grid", from_grid(&tri), from_grid(&quad)), ("field", from_field(&tri), from_field(&quad))] {
        assert!(m.quads.is_empty() && q.triangles.is_empty());
        let mut split = q.clone();
        split.triangulate();
        assert_eq!(split.triangles, m.triangles, "{what}: triangles are the quads split");
        assert_eq!(split.positions, m.positions, "{what}");
        let r = topo::check(&m);
        assert!(r.is_closed() && r.is_manifold() && r.is_oriented(), "{what}: {r:?}");
        assert_eq!(r.euler, 2, "{what}");
        assert!(r.volume > 0.0, "{what}: oriented outward");
        let off = m.positions.iter().map(|p| (Vec3::from(*p).length() - r0).abs()).fold(0.0, f32::max);
        eprintln!("sphere from a {what}: vertices at most {:.4} h off the surface", off / h);
        // The truncation keeps a curved patch's vertex on the mean tangent plane: about the
        // sagitta of a cell's chord.
        assert!(off < 0.05 * h, "{what}: a vertex {off} off the sphere");
    }
}

/// On random lattices plain dc (`manifold: false`) has surface nets' connectivity (the same quads, vertex for vertex) with
/// each vertex inside its cell; its triangles are closed and oriented wherever surface nets' quads
/// are, on every walker alike.
#[test]
fn issue_45_dc_has_the_connectivity_of_surface_nets_on_random_lattices() {
    let mut rng = common::Rng(0x000d_c045);
    let mut closed = 0;
    for trial in 0..300 {
        let dims = [0; 3].map(|_| 3 + rng.below(5) as u32);
        let g = DenseGrid::from_fn(Lattice::new(dims).unwrap(), |[i, j, k]| {
            let border = i == 0 || j == 0 || k == 0 || i + 1 == dims[0] || j + 1 == dims[1] || k + 1 == dims[2];
            if border {
                1.0
            } else {
                rng.uniform() - 0.2
            }
        });
        let vol = GridVolume::new(&g);
        let iso = Iso::below(0.0);
        let sn = common::walk_with(&mut FlyingEdgesWalker::new(), &vol, iso, &SurfaceNets).0;
        let dcq = DualContouring { quads: true, manifold: false, ..DualContouring::default() };
        let dc = common::walk_with(&mut FlyingEdgesWalker::new(), &vol, iso, &dcq).0;
        assert_eq!(dc.quads, sn.quads, "trial {trial}: the quads of surface nets");
        assert_eq!(dc.positions.len(), sn.positions.len(), "trial {trial}");
        let dct = DualContouring { manifold: false, ..DualContouring::default() };
        let tri = common::walk_with(&mut FlyingEdgesWalker::new(), &vol, iso, &dct).0;
        assert_eq!(tri.triangles.len(), 2 * sn.quads.len(), "trial {trial}");
        for (name, other) in [
            ("slab", common::walk_with(&mut SlabWalker::new(), &vol, iso, &dct).0),
            ("reference", common::walk_with(&mut ReferenceWalker, &vol, iso, &dct).0),
        ] {
            assert_eq!(other.canonical_triangles(), tri.canonical_triangles(), "trial {trial}: {name} walker");
        }
        let (rs, rd) = (topo::check(&sn), topo::check(&tri));
        if rs.is_closed() {
            closed += 1;
            assert!(rd.is_closed(), "trial {trial}: surface nets closed, dc not: {rd:?}");
        }
        if rs.is_oriented() {
            assert!(rd.is_oriented(), "trial {trial}: surface nets oriented, dc not: {rd:?}");
        }
    }
    assert!(closed > 250, "the lattices have a positive border: {closed} closed");
}

/// The cell's frame: on a rotated, anisotropic lattice every walker hands an extractor the
/// crossing in cell coordinates (`Cell::crossing` = `Hermite::local`, on the asking cell's edge,
/// at the world point `Hermite::point`) and the normal as a covector that measures world
/// distances (`m_a = spacing_a · direction_a · n`).
#[test]
fn issue_45_cells_give_crossings_and_normals_in_their_frame() {
    let (a, b) = (0.5f64, 0.3f64);
    let dir = [
        [a.cos(), a.sin(), 0.0],
        [-a.sin() * b.cos(), a.cos() * b.cos(), b.sin()],
        [a.sin() * b.sin(), -a.cos() * b.sin(), b.cos()],
    ];
    let lattice =
        Lattice::with_geometry([7, 6, 5], [0.5, 0.8, 1.3], [0.2, -1.0, 0.5]).unwrap().with_direction(dir).unwrap();
    struct Frame {
        lattice: Lattice,
    }
    impl Extractor for Frame {
        fn process<C: Cell>(&self, cell: &mut C) {
            let crossed = CASE_EDGES[cell.case() as usize];
            for e in (0..12u8).filter(|e| crossed & (1 << e) != 0).map(CubeEdge) {
                let h = cell.hermite(e);
                assert_eq!(cell.crossing(e), h.local, "edge {}", e.0);
                let axis = e.axis().index();
                let origin = e.origin_offset();
                for x in 0..3 {
                    if x == axis {
                        assert!((0.0..=1.0).contains(&h.local[x]));
                    } else {
                        assert_eq!(h.local[x], origin[x] as f32, "edge {}: on the cell's edge", e.0);
                    }
                }
                let ijk = cell.ijk();
                let w = self.lattice.to_world([0, 1, 2].map(|x| ijk[x] as f64 + h.local[x] as f64));
                assert!((0..3).all(|x| (w[x] - h.point[x] as f64).abs() < 1e-5), "{w:?} vs {:?}", h.point);
                let (d, s) = (self.lattice.direction(), self.lattice.spacing());
                for x in 0..3 {
                    let m = s[x] * (0..3).map(|y| d[x][y] * h.normal[y] as f64).sum::<f64>();
                    assert!((m - h.local_normal[x] as f64).abs() < 1e-5, "{m} vs {:?}", h.local_normal);
                }
            }
        }
    }
    let field = |p: Vec3| (p - Vec3::new(1.0, 1.0, 2.5)).length() - 1.9;
    let vol = Sampled::new(field, lattice.clone());
    let x = Frame { lattice: lattice.clone() };
    let mut out = MeshBuilder::new(Normals::None);
    ReferenceWalker.walk(&vol, Iso::below(0.0), &x, &mut out).unwrap();
    SlabWalker::new().walk(&vol, Iso::below(0.0), &x, &mut out).unwrap();
    let g = DenseGrid::from_fn(lattice.clone(), |ijk| {
        field(Vec3::from(lattice.to_world(ijk.map(f64::from)).map(|c| c as f32)))
    });
    let gv = GridVolume::new(&g);
    FlyingEdgesWalker::new().walk(&gv, Iso::below(0.0), &x, &mut out).unwrap();
}

/// Surface nets place their vertices at the mean of the volume's crossings: on a field, the
/// refined roots (the points mc's vertices sit on), not the linear interpolation of the samples.
#[test]
fn issue_45_surface_nets_use_the_volume_crossings() {
    let n = 12;
    let lattice = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let h = 2.0 / (n - 1) as f32;
    let r0 = 0.63f32;
    // Not a distance: linear interpolation of its samples misses the sphere.
    let field = move |p: Vec3| p.length_squared() - r0 * r0;
    let sn = Options { method: Method::SurfaceNets, ..Options::default() };
    let mc = Options { method: Method::MarchingCubes, ..Options::default() };
    let exact =
        |o: &Options| pipeline::extract(&Sampled::new(field, lattice.clone()), Iso::below(0.0), o).unwrap().mesh;
    let linear =
        pipeline::extract(&Sampled::with_oracle(field, lattice.clone(), Linear), Iso::below(0.0), &sn).unwrap().mesh;
    let worst = |m: &Mesh| m.positions.iter().map(|p| (Vec3::from(*p).length() - r0).abs()).fold(0.0, f32::max) / h;
    let (e_mc, e_sn, e_linear) = (worst(&exact(&mc)), worst(&exact(&sn)), worst(&linear));
    eprintln!("sphere field p² − r²: vertices off by mc {e_mc:.5} h, surface nets {e_sn:.4} h (linear crossings {e_linear:.4} h)");
    // mc's vertices are on the sphere; surface nets' are means of them, inside it by about the
    // sagitta of a cell's chord; linear crossings of p² − r² add their own error.
    assert!(e_mc < 1e-4, "{e_mc}");
    assert!(e_sn < e_linear, "exact crossings {e_sn} h, linear {e_linear} h");
}

/// Corners of 30 random rotated boxes at 32³: with a margin of one cell every corner is on the
/// mesh (a corner that pokes into a cell without crossing its edges is reached from the neighbour
/// whose three planes meet there); clamping into the cell itself (the default) misses such corners.
#[test]
fn issue_45_corners_of_random_boxes_and_the_margin() {
    let n = 32;
    let lattice = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let h = 2.0 / (n - 1) as f64;
    let mut rng = common::Rng(77);
    let boxes: Vec<RotatedBox> = (0..30)
        .map(|_| {
            RotatedBox::new(
                Vec3::new(rng.uniform() * 0.1, rng.uniform() * 0.1, rng.uniform() * 0.1),
                Vec3::new(0.4 + rng.uniform() * 0.1, 0.4 + rng.uniform() * 0.1, 0.35 + rng.uniform() * 0.1),
                rng.uniform() * 3.0,
                rng.uniform() * 1.5,
                rng.uniform() * 3.0,
            )
        })
        .collect();
    for margin in [0.0f32, 0.5, 1.0] {
        let x = DualContouring { margin, ..DualContouring::default() };
        let mut errs = Vec::new();
        let mut outside = 0usize;
        let mut total = 0usize;
        for b in &boxes {
            let vol = Sampled::new(*b, lattice.clone());
            let mut out = MeshBuilder::new(Normals::None).with_keys(isoforge::mesh::KeyRecord::All);
            SlabWalker::new().walk(&vol, Iso::below(0.0), &x, &mut out).unwrap();
            let (m, keys) = out.finish_keyed().unwrap();
            for (v, k) in keys {
                if let isoforge::cube::VertexKey::Cell { ijk, .. } = k {
                    total += 1;
                    let p = lattice.to_index(m.positions[v as usize].map(f64::from));
                    if (0..3).any(|a| p[a] < ijk[a] as f64 - 1e-4 || p[a] > ijk[a] as f64 + 1.0 + 1e-4) {
                        outside += 1;
                    }
                }
            }
            for c in b.corners() {
                errs.push(distance_to_mesh(&m, c) / h);
            }
        }
        errs.sort_by(f64::total_cmp);
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        eprintln!(
            "margin {margin}: corner error mean {mean:.3} h, median {:.3}, 90% {:.3}, max {:.3}; vertices outside their cell {outside}/{total}",
            errs[errs.len() / 2],
            errs[errs.len() * 9 / 10],
            errs[errs.len() - 1]
        );
        if margin == 0.0 {
            assert_eq!(outside, 0, "a margin of 0 keeps every vertex in its cell");
        }
        if margin == 1.0 {
            assert!(errs[errs.len() - 1] < 0.05, "worst corner {} h", errs[errs.len() - 1]);
        } else {
            assert!(errs[errs.len() / 2] < 0.05, "median corner {} h", errs[errs.len() / 2]);
        }
    }
}

/// Non-manifold edges and vertices of plain dc (one vertex per cell, surface nets' connectivity)
/// and of split dc (one vertex per marching-cubes patch) on random lattices: printed, and split
/// dc has no more of them, stays closed and oriented, and has marching cubes' components.
#[test]
fn issue_45_split_vertices_on_random_lattices() {
    let mut rng = common::Rng(0x5b11_7045);
    let (mut plain, mut split) = ([0usize; 3], [0usize; 3]);
    let mut lattices_with = [0usize; 2];
    let trials = 1000;
    for trial in 0..trials {
        let dims = [0; 3].map(|_| 3 + rng.below(5) as u32);
        let g = DenseGrid::from_fn(Lattice::new(dims).unwrap(), |[i, j, k]| {
            let border = i == 0 || j == 0 || k == 0 || i + 1 == dims[0] || j + 1 == dims[1] || k + 1 == dims[2];
            if border {
                1.0
            } else {
                rng.uniform() - 0.2
            }
        });
        let vol = GridVolume::new(&g);
        let iso = Iso::below(0.0);
        let dc = |split: bool| {
            let x = DualContouring { split, manifold: false, ..DualContouring::default() };
            topo::check(&common::walk_with(&mut FlyingEdgesWalker::new(), &vol, iso, &x).0)
        };
        let (a, b) = (dc(false), dc(true));
        let mc = topo::check(&common::fe(&g, iso).0);
        for (sum, r) in [(&mut plain, &a), (&mut split, &b)] {
            sum[0] += r.non_manifold_edges.count;
            sum[1] += r.non_manifold_vertices.count;
            sum[2] += r.inconsistent_edges.count;
        }
        lattices_with[0] += usize::from(!a.is_manifold());
        lattices_with[1] += usize::from(!b.is_manifold());
        assert!(b.is_closed(), "trial {trial}: split dc open: {b:?}");
        assert!(
            b.non_manifold_edges.count <= a.non_manifold_edges.count,
            "trial {trial}: split adds non-manifold edges"
        );
        if b.is_manifold() {
            assert!(b.is_oriented(), "trial {trial}");
            assert_eq!(b.components.len(), mc.components.len(), "trial {trial}: marching cubes' components");
        }
    }
    eprintln!(
        "{trials} random lattices: plain dc {} non-manifold edges, {} vertices, {} inconsistent edges \
         ({} lattices non-manifold); split dc {} edges, {} vertices, {} inconsistent ({} lattices)",
        plain[0], plain[1], plain[2], lattices_with[0], split[0], split[1], split[2], lattices_with[1]
    );
    assert!(plain[0] > 0, "random lattices have cells with two sheets");
}
