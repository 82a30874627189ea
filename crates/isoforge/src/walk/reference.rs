use std::collections::HashMap;

use super::segment::{self, CellPoint, SegmentKey};
use super::{hermite, Cell, WalkStats, Walker};
use crate::error::{Error, Result};
use crate::extract::cube::{case_of, CubeEdge, EdgeKey, CORNER_OFFSETS};
use crate::extract::Extractor;
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// The test oracle walker: no caches. For every cell it refills the two slabs it needs and
/// recomputes each crossing; vertices are joined by [`EdgeKey`] in a map, and a recomputed
/// crossing that differs from the first one (by a single bit) is reported as an internal error.
///
/// Slow by design (O(cells · nx · ny)); use it on small lattices only.
#[derive(Debug, Default)]
pub struct ReferenceWalker;

impl Walker for ReferenceWalker {
    fn walk<V: Volume, X: Extractor>(
        &mut self,
        vol: &V,
        iso: Iso,
        x: &mut X,
        out: &mut MeshBuilder,
    ) -> Result<WalkStats> {
        let lattice = vol.lattice().clone();
        let mut stats = WalkStats::default();
        if !lattice.has_cells() {
            return Ok(stats);
        }
        out.set_reverse_winding(lattice.is_mirrored());
        let [nx, ny, nz] = lattice.dims();
        let mut ids: HashMap<EdgeKey, (VertexId, [f32; 3])> = HashMap::new();
        let mut seg_ids: HashMap<SegmentKey, (VertexId, [f32; 3])> = HashMap::new();
        let mut mismatch = None;
        let uniform_too = x.visits_uniform_cells();
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let (mut s0, mut s1) = (vec![0.0; lattice.slab_len()], vec![0.0; lattice.slab_len()]);
                    vol.fill_slab(k, iso, &mut s0);
                    vol.fill_slab(k + 1, iso, &mut s1);
                    let d = CORNER_OFFSETS.map(|o| {
                        let s = if o[2] == 0 { &s0 } else { &s1 };
                        s[(j + o[1]) as usize * nx as usize + (i + o[0]) as usize]
                    });
                    let case = case_of(&d);
                    stats.cells += 1;
                    match case {
                        0 => stats.cells_outside += 1,
                        255 => stats.cells_inside += 1,
                        _ => {}
                    }
                    if (case != 0 && case != 255) || uniform_too {
                        let mut cell = RefCell {
                            ijk: [i, j, k],
                            dims: [nx, ny, nz],
                            d,
                            case,
                            vol,
                            iso,
                            ids: &mut ids,
                            seg_ids: &mut seg_ids,
                            memo: [f32::NAN; 7],
                            out,
                            mismatch: &mut mismatch,
                        };
                        x.process(&mut cell);
                    }
                }
            }
        }
        match mismatch {
            Some(key) => Err(Error::Internal(format!("crossing on {key} is not reproducible"))),
            None => Ok(stats),
        }
    }
}

struct RefCell<'a, V> {
    ijk: [u32; 3],
    dims: [u32; 3],
    d: [f32; 8],
    case: u8,
    vol: &'a V,
    iso: Iso,
    ids: &'a mut HashMap<EdgeKey, (VertexId, [f32; 3])>,
    seg_ids: &'a mut HashMap<SegmentKey, (VertexId, [f32; 3])>,
    memo: [f32; 7],
    out: &'a mut MeshBuilder,
    mismatch: &'a mut Option<String>,
}

impl<V: Volume> Cell for RefCell<'_, V> {
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    fn values(&self) -> &[f32; 8] {
        &self.d
    }
    fn case(&self) -> u8 {
        self.case
    }
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let h = hermite(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso, self.out.wants_normals());
        if let Some(&(id, p)) = self.ids.get(&key) {
            if p.map(f32::to_bits) != h.point.map(f32::to_bits) {
                *self.mismatch = Some(format!("{key:?}"));
            }
            return id;
        }
        let id = self.out.push_vertex(h.point, h.normal);
        self.ids.insert(key, (id, h.point));
        id
    }
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.out.push_triangle(t);
    }
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.dims, self.ijk, face)
    }
    fn point_value(&mut self, p: CellPoint) -> f32 {
        segment::point_value(self.vol, self.iso, self.ijk, &self.d, &mut self.memo, p)
    }
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        if let Some(e) = CellPoint::axis_edge(a, b) {
            return self.edge_vertex(e);
        }
        let (vol, iso) = (self.vol, self.iso);
        let (key, d0, d1) = segment::cell_segment(vol, iso, self.ijk, &self.d, &mut self.memo, (a, b));
        let h = segment::segment_hermite(vol, key, d0, d1, iso, self.out.wants_normals());
        if let Some(&(id, p)) = self.seg_ids.get(&key) {
            if p.map(f32::to_bits) != h.point.map(f32::to_bits) {
                *self.mismatch = Some(format!("{key:?}"));
            }
            return id;
        }
        let id = self.out.push_vertex(h.point, h.normal);
        self.seg_ids.insert(key, (id, h.point));
        id
    }
    fn interior_vertex(&mut self, local: [f32; 3]) -> VertexId {
        let p = segment::cell_point(self.ijk, local);
        let h = segment::point_hermite(self.vol, p, self.iso, self.out.wants_normals(), || [0.0; 3]);
        self.out.push_vertex(h.point, h.normal)
    }
}
