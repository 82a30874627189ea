//! Helpers shared by the integration tests.
#![allow(dead_code)]

use isoforge::extract::{Extractor, MarchingCubes};
use isoforge::grid::{DenseGrid, Lattice, Sample};
use isoforge::mesh::{Mesh, MeshBuilder, Normals};
use isoforge::volume::{GridVolume, Iso, Volume};
use isoforge::walk::{FlyingEdgesWalker, ReferenceWalker, SlabWalker, WalkStats, Walker};

/// Extracts with marching cubes through the given walker.
pub fn mc_with<V, W: Walker<V>>(walker: &mut W, vol: &V, iso: Iso) -> (Mesh, WalkStats) {
    walk_with(walker, vol, iso, &MarchingCubes)
}

/// Extracts with `x` through the given walker (normals on).
pub fn walk_with<V, W: Walker<V>, X: Extractor + Sync>(walker: &mut W, vol: &V, iso: Iso, x: &X) -> (Mesh, WalkStats) {
    let mut out = MeshBuilder::new(Normals::Gradient);
    let stats = walker.walk(vol, iso, x, &mut out).expect("walk");
    (out.finish().expect("finish"), stats)
}

/// Marching cubes through the parallel Flying Edges walker.
pub fn fe<S: Sample>(g: &DenseGrid<S>, iso: Iso) -> (Mesh, WalkStats) {
    mc_with(&mut FlyingEdgesWalker::new(), &GridVolume::new(g), iso)
}

/// Marching cubes through the slab walker.
pub fn mc<V: Volume>(vol: &V, iso: Iso) -> Mesh {
    mc_with(&mut SlabWalker::new(), vol, iso).0
}

/// Marching cubes through the reference walker.
pub fn mc_reference<V: Volume>(vol: &V, iso: Iso) -> Mesh {
    mc_with(&mut ReferenceWalker, vol, iso).0
}

/// A grid from values in x-fastest order.
pub fn grid(dims: [u32; 3], values: Vec<f32>) -> DenseGrid<f32> {
    DenseGrid::new(Lattice::new(dims).unwrap(), values).unwrap()
}

/// Number of lattice edges whose ends differ in class (value < iso vs not).
pub fn crossed_edges(g: &DenseGrid<f32>, iso: f32) -> usize {
    let [nx, ny, nz] = g.lattice().dims();
    let mut n = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let a = g.get([i, j, k]) < iso;
                for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (x, y, z) = (i + di, j + dj, k + dk);
                    if x < nx && y < ny && z < nz && (g.get([x, y, z]) < iso) != a {
                        n += 1;
                    }
                }
            }
        }
    }
    n
}

/// Wraps a grid as a volume.
pub fn vol(g: &DenseGrid<f32>) -> GridVolume<'_, f32> {
    GridVolume::new(g)
}
