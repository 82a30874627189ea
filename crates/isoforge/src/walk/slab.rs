use super::segment::{self, CellPoint, SegmentCache};
use super::{hermite, Cell, Progress, WalkStats, Walker};
use crate::error::Result;
use crate::extract::cube::{case_of, Axis, CubeEdge, EdgeKey};
use crate::extract::Extractor;
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// Walks z-slab by z-slab keeping O(nx·ny) state: the values of slabs k and k + 1, and the vertex
/// ids of x- and y-edges on both slabs and of the z-edges between them. Every value is read once
/// and every crossing vertex is created once, by the first cell that asks for it.
///
/// ```text
///   slab k+1:  above, x_ids[1], y_ids[1]      z_ids[j·nx + i]: edge (i, j, k) → (i, j, k+1)
///   slab k:    below, x_ids[0], y_ids[0]      after slab k: above → below, ids[1] → ids[0]
/// ```
#[derive(Default)]
pub struct SlabWalker<'p> {
    below: Vec<f32>,
    above: Vec<f32>,
    x_ids: [Vec<VertexId>; 2],
    y_ids: [Vec<VertexId>; 2],
    z_ids: Vec<VertexId>,
    segs: SegmentCache,
    progress: Option<&'p dyn Progress>,
}

impl<'p> SlabWalker<'p> {
    /// A walker with empty caches (sized on the first walk, then reused).
    pub fn new() -> Self {
        SlabWalker::default()
    }

    /// Reports progress once per slab.
    pub fn with_progress(mut self, progress: &'p dyn Progress) -> Self {
        self.progress = Some(progress);
        self
    }
}

impl Walker for SlabWalker<'_> {
    fn walk<V: Volume, X: Extractor>(
        &mut self,
        vol: &V,
        iso: Iso,
        x: &mut X,
        out: &mut MeshBuilder,
    ) -> Result<WalkStats> {
        let lattice = vol.lattice();
        let mut stats = WalkStats::default();
        if !lattice.has_cells() {
            return Ok(stats);
        }
        out.set_reverse_winding(lattice.is_mirrored());
        let [nx, ny, nz] = lattice.dims();
        let n = lattice.slab_len();
        for buf in [&mut self.below, &mut self.above] {
            buf.clear();
            buf.resize(n, 0.0);
        }
        for ids in self.x_ids.iter_mut().chain(self.y_ids.iter_mut()).chain(std::iter::once(&mut self.z_ids)) {
            ids.clear();
            ids.resize(n, VertexId::NONE);
        }
        self.segs.clear();
        vol.fill_slab(0, iso, &mut self.below);
        let normals = out.wants_normals();
        let uniform_too = x.visits_uniform_cells();
        let nxu = nx as usize;
        for k in 0..nz - 1 {
            // PASS 1: values of the next slab; fresh id slots for its edges and the z-edges below it.
            vol.fill_slab(k + 1, iso, &mut self.above);
            self.x_ids[1].fill(VertexId::NONE);
            self.y_ids[1].fill(VertexId::NONE);
            self.z_ids.fill(VertexId::NONE);
            // PASS 2: every cell between the two slabs.
            for j in 0..ny - 1 {
                let (r0, r1) = (j as usize * nxu, (j as usize + 1) * nxu);
                let (b0, b1) = (&self.below[r0..r0 + nxu], &self.below[r1..r1 + nxu]);
                let (a0, a1) = (&self.above[r0..r0 + nxu], &self.above[r1..r1 + nxu]);
                for i in 0..nxu - 1 {
                    let d = [b0[i], b0[i + 1], b1[i], b1[i + 1], a0[i], a0[i + 1], a1[i], a1[i + 1]];
                    let case = case_of(&d);
                    stats.cells += 1;
                    match case {
                        0 => stats.cells_outside += 1,
                        255 => stats.cells_inside += 1,
                        _ => {}
                    }
                    if (case != 0 && case != 255) || uniform_too {
                        let mut cell = SlabCell {
                            ijk: [i as u32, j, k],
                            d,
                            case,
                            nx: nxu,
                            dims: [nx, ny, nz],
                            vol,
                            iso,
                            normals,
                            x_ids: &mut self.x_ids,
                            y_ids: &mut self.y_ids,
                            z_ids: &mut self.z_ids,
                            segs: &mut self.segs,
                            memo: [f32::NAN; 7],
                            out,
                        };
                        x.process(&mut cell);
                    }
                }
            }
            // PASS 3: the top slab becomes the bottom one.
            std::mem::swap(&mut self.below, &mut self.above);
            self.x_ids.swap(0, 1);
            self.y_ids.swap(0, 1);
            self.segs.advance();
            if let Some(p) = self.progress {
                p.advance(k as u64 + 1, nz as u64 - 1);
            }
        }
        Ok(stats)
    }
}

struct SlabCell<'a, V> {
    ijk: [u32; 3],
    d: [f32; 8],
    case: u8,
    nx: usize,
    dims: [u32; 3],
    vol: &'a V,
    iso: Iso,
    normals: bool,
    x_ids: &'a mut [Vec<VertexId>; 2],
    y_ids: &'a mut [Vec<VertexId>; 2],
    z_ids: &'a mut Vec<VertexId>,
    segs: &'a mut SegmentCache,
    memo: [f32; 7],
    out: &'a mut MeshBuilder,
}

impl<V: Volume> Cell for SlabCell<'_, V> {
    #[inline]
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    #[inline]
    fn values(&self) -> &[f32; 8] {
        &self.d
    }
    #[inline]
    fn case(&self) -> u8 {
        self.case
    }

    #[inline]
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let [i, j, _] = self.ijk;
        let (i, j) = (i as usize, j as usize);
        // r = e % 4 gives the edge's offsets on the two other axes (see extract/cube.rs).
        let (lo, hi) = ((e.0 & 1) as usize, ((e.0 >> 1) & 1) as usize);
        let slot = match e.axis() {
            Axis::X => &mut self.x_ids[hi][(j + lo) * self.nx + i],
            Axis::Y => &mut self.y_ids[hi][j * self.nx + i + lo],
            Axis::Z => &mut self.z_ids[(j + hi) * self.nx + i + lo],
        };
        if *slot != VertexId::NONE {
            return *slot;
        }
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let h = hermite(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso, self.normals);
        let id = self.out.push_vertex(h.point, h.normal);
        *slot = id;
        id
    }

    #[inline]
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.out.push_triangle(t);
    }

    #[inline]
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.dims, self.ijk, face)
    }

    #[inline]
    fn point_value(&mut self, p: CellPoint) -> f32 {
        segment::point_value(self.vol, self.iso, self.ijk, &self.d, &mut self.memo, p)
    }

    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        if let Some(e) = CellPoint::axis_edge(a, b) {
            return self.edge_vertex(e);
        }
        let (vol, iso) = (self.vol, self.iso);
        let (key, d0, d1) = segment::cell_segment(vol, iso, self.ijk, &self.d, &mut self.memo, (a, b));
        if let Some(id) = self.segs.get(&key) {
            return id;
        }
        let h = segment::segment_hermite(vol, key, d0, d1, iso, self.normals);
        let id = self.out.push_vertex(h.point, h.normal);
        self.segs.insert(key, id);
        id
    }

    fn interior_vertex(&mut self, local: [f32; 3]) -> VertexId {
        let p = segment::cell_point(self.ijk, local);
        let h = segment::point_hermite(self.vol, p, self.iso, self.normals, || [0.0; 3]);
        self.out.push_vertex(h.point, h.normal)
    }
}
