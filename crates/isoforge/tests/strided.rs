//! Issue 48: samples in any layout (Fortran order, steps, reversed axes, broadcasts) are walked
//! from where they are and give exactly the mesh of a grid holding a copy, for every method,
//! every sample type and with or without normals.

use isoforge::grid::{AnyGrid, DenseGrid, Lattice, Sample};
use isoforge::mesh::Normals;
use isoforge::pipeline::{extract_grid, extract_strided, Extraction, Method, Options};
use isoforge::volume::{Iso, SlabSource, StridedSamples};

/// A layout of an `(n0, n1, n2)` array in memory (axis 2 = x), as numpy would make it.
#[derive(Debug, Clone, Copy)]
enum Layout {
    C,
    Fortran,
    /// Every other point along z and y of a C-ordered array twice as large.
    Stepped,
    /// x and z reversed (negative strides).
    Reversed,
}

/// `values` (x fastest) laid out as `layout`: the memory, the first point's index, the strides.
fn lay_out<S: Sample>(dims: [usize; 3], values: &[S], layout: Layout) -> (Vec<S>, usize, [isize; 3]) {
    let [nx, ny, nz] = dims;
    let at = |x: usize, y: usize, z: usize| values[(z * ny + y) * nx + x];
    let zero = S::from_f64(0.0);
    match layout {
        Layout::C => (values.to_vec(), 0, [1, nx as isize, (nx * ny) as isize]),
        Layout::Fortran => {
            let mut m = vec![zero; nx * ny * nz];
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        m[(x * ny + y) * nz + z] = at(x, y, z);
                    }
                }
            }
            (m, 0, [(ny * nz) as isize, nz as isize, 1])
        }
        Layout::Stepped => {
            let (my, mz) = (2 * ny, 2 * nz);
            let mut m = vec![S::from_f64(7.0); nx * my * mz];
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        m[(2 * z * my + 2 * y) * nx + x] = at(x, y, z);
                    }
                }
            }
            (m, 0, [1, 2 * nx as isize, (2 * nx * my) as isize])
        }
        Layout::Reversed => {
            // Memory in C order of the array reversed along x and z; the view reverses them back.
            let mut m = vec![zero; nx * ny * nz];
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        m[((nz - 1 - z) * ny + y) * nx + (nx - 1 - x)] = at(x, y, z);
                    }
                }
            }
            let first = ((nz - 1) * ny) * nx + (nx - 1);
            (m, first, [-1, nx as isize, -((nx * ny) as isize)])
        }
    }
}

fn same(a: &Extraction, b: &Extraction, what: &str) {
    assert_eq!(a.mesh.positions, b.mesh.positions, "{what}: positions");
    assert_eq!(a.mesh.normals, b.mesh.normals, "{what}: normals");
    assert_eq!(a.mesh.triangles, b.mesh.triangles, "{what}: triangles");
    assert_eq!(a.mesh.quads, b.mesh.quads, "{what}: quads");
    assert_eq!(a.stats, b.stats, "{what}: stats");
}

fn check_type<S: Sample>(wrap: fn(DenseGrid<S>) -> AnyGrid) {
    // A ball of radius 5.5 in a lattice of unequal sides, values 0..=90, with ties at the iso.
    let dims = [17usize, 14, 11];
    let lattice = Lattice::with_geometry(dims.map(|d| d as u32), [1.0, 0.5, 2.0], [0.0; 3]).unwrap();
    let mut values = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let d = [x as f64 - 8.0, y as f64 - 6.5, z as f64 - 5.2];
                values.push(S::from_f64((d.iter().map(|v| v * v).sum::<f64>().sqrt() * 8.0).round().min(90.0)));
            }
        }
    }
    let grid = wrap(DenseGrid::new(lattice.clone(), values.clone()).unwrap());
    for method in Method::ALL {
        for normals in [Normals::None, Normals::Gradient] {
            for threads in [1, 2] {
                let opts = Options { method, normals, threads: Some(threads), ..Options::default() };
                let iso = Iso::below(40.0);
                let want = extract_grid(&grid, iso, &opts, None).unwrap();
                assert!(want.mesh.num_triangles() + want.mesh.quads.len() > 0);
                for layout in [Layout::C, Layout::Fortran, Layout::Stepped, Layout::Reversed] {
                    let (memory, first, strides) = lay_out(dims, &values, layout);
                    let s = StridedSamples::new(lattice.clone(), &memory, first, strides).unwrap();
                    assert_eq!(s.contiguous().is_some(), matches!(layout, Layout::C), "{layout:?}");
                    assert_eq!(s.value_range(), grid.value_range(), "{layout:?}");
                    let got = extract_strided(&s, iso, &opts, None).unwrap();
                    let what =
                        format!("{:?} {} {layout:?} normals {normals:?} threads {threads}", S::DTYPE, method.name());
                    same(&got, &want, &what);
                }
            }
        }
    }
}

#[test]
fn every_layout_gives_the_mesh_of_a_copy_for_every_method_and_type() {
    check_type::<u8>(AnyGrid::U8);
    check_type::<i8>(AnyGrid::I8);
    check_type::<u16>(AnyGrid::U16);
    check_type::<i16>(AnyGrid::I16);
    check_type::<u32>(AnyGrid::U32);
    check_type::<i32>(AnyGrid::I32);
    check_type::<f32>(AnyGrid::F32);
    check_type::<f64>(AnyGrid::F64);
}

#[test]
fn a_broadcast_axis_and_options_that_need_the_whole_grid_give_the_copy_s_mesh() {
    // Stride 0 along z: every slab is the same plane.
    let lattice = Lattice::new([9, 8, 6]).unwrap();
    let plane: Vec<f32> = (0..72).map(|i| ((i % 9) as f32 - 4.0).abs() + ((i / 9) as f32 - 3.5).abs()).collect();
    let s = StridedSamples::new(lattice.clone(), &plane, 0, [1, 9, 0]).unwrap();
    let copy = s.to_grid().unwrap();
    assert_eq!(copy.data()[..72], plane[..]);
    assert_eq!(copy.data()[72 * 5..], plane[..]);
    let grid = AnyGrid::F32(copy);
    let iso = Iso::below(3.0);
    let opts = Options::default();
    same(&extract_strided(&s, iso, &opts, None).unwrap(), &extract_grid(&grid, iso, &opts, None).unwrap(), "broadcast");
    // A range is walked on a copy (the streamed walk takes the whole lattice).
    let range = isoforge::cube::CellRange { lo: [1, 1, 1], hi: [6, 5, 4] };
    let opts = Options { range: Some(range), ..Options::default() };
    same(&extract_strided(&s, iso, &opts, None).unwrap(), &extract_grid(&grid, iso, &opts, None).unwrap(), "range");
}

#[test]
fn layouts_reaching_outside_the_samples_are_refused_and_slabs_are_counted() {
    let lattice = Lattice::new([4, 3, 2]).unwrap();
    let memory = vec![0u8; 24];
    let e = StridedSamples::new(lattice.clone(), &memory, 0, [1, 4, 13]).unwrap_err().to_string();
    assert!(e.contains("reach indices 0..=24 of 24 samples"), "{e}");
    let e = StridedSamples::new(lattice.clone(), &memory, 2, [-1, 4, 12]).unwrap_err().to_string();
    assert!(e.contains("reach indices -1..=22"), "{e}");
    // Overlapping strides whose reach is as long as the points are many: the range is the
    // points' (index 4, the largest value, is never reached), not the memory's.
    let overlap: Vec<u8> = (0..8).map(|i| if i == 4 { 200 } else { i }).collect();
    let s = StridedSamples::new(Lattice::new([2, 2, 2]).unwrap(), &overlap, 0, [1, 1, 5]).unwrap();
    let r = s.value_range().unwrap();
    assert_eq!((r.min, r.max), (0.0, 7.0));
    let s = StridedSamples::new(lattice, &memory, 0, [1, 4, 12]).unwrap();
    let mut slabs = s.slabs();
    let mut out = vec![0u8; 12];
    for _ in 0..2 {
        SlabSource::<u8>::read_slab(&mut slabs, &mut out).unwrap();
    }
    let e = SlabSource::<u8>::read_slab(&mut slabs, &mut out).unwrap_err().to_string();
    assert!(e.contains("slab 2 asked for, the volume has 2"), "{e}");
    let e = SlabSource::<u8>::read_slab(&mut slabs, &mut out[..5]).unwrap_err().to_string();
    assert!(e.contains("a slab of 5 samples asked for, slabs hold 12"), "{e}");
}
