//! Issue 45's sharp CSG shapes at n = 32: what the methods keep of their corners today (measured
//! by `volume::sdf::features::measure`, in cell widths h; the table at 32/64/128 is in
//! docs/BENCHMARKS.md §16), and the inside components of their sign grids.

use isoforge::math::Vec3;
use isoforge::pipeline::{extract_builtin, Adaptivity, Method, Options};
use isoforge::volume::catalog::{parse, Builtin};
use isoforge::volume::sdf::features::{measure, FeatureErrors};
use isoforge::volume::{Field, FieldVisitor};

fn errors(spec: &str, method: Method) -> FeatureErrors {
    struct Go<'a>(&'a isoforge::mesh::Mesh, &'a isoforge::volume::sdf::Features, f64);
    impl FieldVisitor for Go<'_> {
        type Output = FeatureErrors;
        fn visit<F: Field + Clone + Sync>(self, f: &F) -> FeatureErrors {
            measure(self.0, self.1, f, self.2)
        }
    }
    let b = parse(spec).unwrap();
    let h = b.lattice.spacing()[0];
    let features = b.field.sharp_features((h / 8.0) as f32).unwrap();
    let out = extract_builtin(&b, b.iso, &Options { method, ..Default::default() }, None).unwrap();
    b.field.visit(Go(&out.mesh, &features, h))
}

#[test]
fn marching_cubes_cuts_the_corners_by_most_of_a_cell() {
    // Measured: rotated-box 0.89 h, box-minus-sphere 0.74 h (convex 0.48 h), fandisk 0.77 h.
    for spec in ["rotated-box?n=32", "box-minus-sphere?n=32", "fandisk?n=32"] {
        let e = errors(spec, Method::MarchingCubes);
        assert!(e.corner.unwrap() > 0.3, "{spec}: {e:?}");
        assert!(e.crease.unwrap() > 0.3, "{spec}: {e:?}");
        // Classic MC's vertices are the field's roots on the edges.
        assert!(e.field.unwrap() < 1e-3, "{spec}: {e:?}");
    }
}

#[test]
fn dual_contouring_keeps_corners_with_exact_gradients() {
    // Plain dc (Ju 2002, one vertex per cell) at n = 32, measured: box-minus-sphere's 7 convex
    // corners within 0.045 h (the three where the ball meets the edges: 0.14 h); the rotated box's
    // corners within 0.22 h; crease 0.22 h; cylinder's rims 0.09 h — before vertices fitted to
    // exact normals could leave their cells (`DualContouring::margin`): now 0.000 on the box.
    let plain = Method::DualContouring { quads: false, split: false, manifold: false, adaptivity: Adaptivity::UNIFORM };
    let e = errors("box-minus-sphere?n=32", plain);
    assert!(e.convex_corner.unwrap() <= 0.05, "{e:?}");
    assert!(e.corner.unwrap() <= 0.2, "{e:?}");
    let e = errors("rotated-box?n=32", plain);
    assert!(e.corner.unwrap() <= 0.25, "{e:?}");
    assert!(e.crease.unwrap() <= 0.25, "{e:?}");
    let mc = errors("rotated-box?n=32", Method::MarchingCubes);
    assert!(e.corner.unwrap() < mc.corner.unwrap() / 3.0, "{e:?} vs mc {mc:?}");
    let e = errors("cylinder?n=32", plain);
    assert!(e.corner.is_none() && e.crease.unwrap() <= 0.1, "{e:?}");
}

/// Issue 45: emc and manifold dc at n = 32 with exact normals, measured (BENCHMARKS §16): the
/// rotated box's corners and creases on the mesh (0.000 h), every convex corner of
/// box-minus-sphere and fandisk on it (0.000 h), the cylinder's rims within 0.06 h; curved
/// creases (a ball or a cylinder cutting a plane) within 0.14–0.55 h, where marching cubes is
/// 0.6–0.9 h off everywhere; every mesh closed and manifold.
#[test]
fn emc_and_manifold_dc_put_corners_and_creases_on_the_mesh() {
    for method in [Method::parse("emc").unwrap(), Method::parse("dc").unwrap()] {
        let name = method.name();
        let e = errors("rotated-box?n=32", method);
        assert!(e.corner.unwrap() <= 0.05 && e.crease.unwrap() <= 0.1 && e.field.unwrap() <= 0.05, "{name}: {e:?}");
        for spec in ["box-minus-sphere?n=32", "fandisk?n=32"] {
            let e = errors(spec, method);
            assert!(e.convex_corner.unwrap() <= 0.05, "{name} {spec}: {e:?}");
            assert!(e.crease.unwrap() <= 0.6, "{name} {spec}: {e:?}");
        }
        let e = errors("cylinder?n=32", method);
        assert!(e.crease.unwrap() <= 0.1, "{name}: {e:?}");
        for spec in ["rotated-box?n=32", "cylinder?n=32", "box-minus-sphere?n=32", "fandisk?n=32", "two-spheres?n=32"] {
            let b = parse(spec).unwrap();
            let out = extract_builtin(&b, b.iso, &Options { method, ..Default::default() }, None).unwrap();
            let r = isoforge::topo::check(&out.mesh);
            assert!(r.is_watertight(), "{name} {spec}: {r:?}");
            let want = if spec.starts_with("two-spheres") { 2 } else { 1 };
            assert_eq!(r.components.len(), want, "{name} {spec}");
        }
    }
}

/// Components of the sign grid's inside points (value < 0), 6-connected.
fn inside_components(b: &Builtin) -> usize {
    struct Sample(Vec<Vec3>);
    impl FieldVisitor for Sample {
        type Output = Vec<bool>;
        fn visit<F: Field + Clone + Sync>(self, f: &F) -> Vec<bool> {
            self.0.iter().map(|&p| f.value(p) < 0.0).collect()
        }
    }
    let [nx, ny, nz] = b.lattice.dims().map(|d| d as usize);
    let (o, s) = (b.lattice.origin(), b.lattice.spacing());
    let mut points = Vec::with_capacity(nx * ny * nz);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let c = [x, y, z];
                points.push(Vec3::from_array(std::array::from_fn(|k| (o[k] + c[k] as f64 * s[k]) as f32)));
            }
        }
    }
    let inside = b.field.visit(Sample(points));
    let mut seen = vec![false; inside.len()];
    let mut components = 0;
    for start in 0..inside.len() {
        if !inside[start] || seen[start] {
            continue;
        }
        components += 1;
        seen[start] = true;
        let mut stack = vec![start];
        while let Some(i) = stack.pop() {
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            let mut visit = |j: usize| {
                if inside[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < nx {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - nx);
            }
            if y + 1 < ny {
                visit(i + nx);
            }
            if z > 0 {
                visit(i - nx * ny);
            }
            if z + 1 < nz {
                visit(i + nx * ny);
            }
        }
    }
    components
}

#[test]
fn sign_grids_have_the_expected_components() {
    for spec in ["rotated-box?n=32", "cylinder?n=32", "box-minus-sphere?n=32", "fandisk?n=32"] {
        assert_eq!(inside_components(&parse(spec).unwrap()), 1, "{spec}");
    }
    // The gap (0.1 h) is centred on a lattice plane whose points are outside: two components at
    // every n, although the balls are a tenth of a cell apart.
    for n in [32, 33, 64, 100] {
        assert_eq!(inside_components(&parse(&format!("two-spheres?n={n}")).unwrap()), 2, "n={n}");
    }
    // Plates thicker than a 6-connected digital plane needs (|normal|₁ ≤ √3 cells) give one
    // component each. At the default 0.3 h, below the sampling rate, the tilted plates' inside
    // points break into many pieces: the case the sharp methods must not make worse.
    for count in [1, 2, 3] {
        let b = parse(&format!("plates?n=32&count={count}&t=2")).unwrap();
        assert_eq!(inside_components(&b), count, "count={count}");
    }
    let thin = inside_components(&parse("plates?n=32").unwrap());
    assert!(thin > 2, "{thin}");
}
