use std::collections::HashMap;

use super::segment;
use super::{edge_crossing, edge_hermite, push_edge_vertex, wants_cell, Cell, Hermite, WalkStats, Walker};
use crate::cube::{case_of, CellPoint, CubeEdge, EdgeKey, SegmentKey, CORNER_OFFSETS};
use crate::error::{Error, Result};
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

impl<V: Volume> Walker<V> for ReferenceWalker {
    fn walk<X: Extractor + Sync>(&mut self, vol: &V, iso: Iso, x: &X, out: &mut MeshBuilder) -> Result<WalkStats> {
        let lattice = vol.lattice().clone();
        let mut stats = WalkStats::default();
        if !lattice.has_cells() {
            return Ok(stats);
        }
        out.set_reverse_winding(lattice.is_mirrored());
        let [nx, ny, nz] = lattice.dims();
        let mut ids: HashMap<EdgeKey, (VertexId, [f32; 3])> = HashMap::new();
        let mut seg_ids: HashMap<SegmentKey, (VertexId, [f32; 3])> = HashMap::new();
        let mut placed: HashMap<[u32; 3], Vec<(VertexId, u16)>> = HashMap::new();
        let mut mismatch = None;
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
                    if wants_cell(x, case) {
                        let mut cell = RefCell {
                            ijk: [i, j, k],
                            dims: [nx, ny, nz],
                            d,
                            case,
                            vol,
                            iso,
                            ids: &mut ids,
                            seg_ids: &mut seg_ids,
                            placed: &mut placed,
                            n_placed: 0,
                            memo: [f32::NAN; 7],
                            out,
                            mismatch: &mut mismatch,
                        };
                        x.place(&mut cell);
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
    placed: &'a mut HashMap<[u32; 3], Vec<(VertexId, u16)>>,
    n_placed: u8,
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
    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        let [c0, c1] = e.corners();
        edge_hermite(self.vol, EdgeKey::of_cell(self.ijk, e), self.d[c0 as usize], self.d[c1 as usize], self.iso)
    }
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let (d0, d1) = (self.d[c0 as usize], self.d[c1 as usize]);
        let (p, _) = edge_crossing(self.vol, key, d0, d1, self.iso);
        if let Some(&(id, first)) = self.ids.get(&key) {
            if p.map(f32::to_bits) != first.map(f32::to_bits) {
                *self.mismatch = Some(format!("{key:?}"));
            }
            return id;
        }
        let id = push_edge_vertex(self.vol, key, d0, d1, self.iso, self.out);
        self.ids.insert(key, (id, p));
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
        let p = segment::segment_hermite(vol, key, d0, d1, iso).point;
        if let Some(&(id, first)) = self.seg_ids.get(&key) {
            if p.map(f32::to_bits) != first.map(f32::to_bits) {
                *self.mismatch = Some(format!("{key:?}"));
            }
            return id;
        }
        let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
        self.seg_ids.insert(key, (id, p));
        id
    }
    fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId {
        let n = self.n_placed;
        self.n_placed += 1;
        let id = segment::push_cell_vertex(self.vol, self.iso, self.ijk, n, local, self.out);
        self.placed.entry(self.ijk).or_default().push((id, edges));
        id
    }
    fn placed_vertex(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<VertexId> {
        let key = EdgeKey::of_cell(self.ijk, e);
        let cell = segment::neighbour(self.ijk, offset)?;
        let ne = key.in_cell(cell)?;
        let entries = self.placed.get(&cell)?;
        entries.iter().find(|(_, m)| m & (1 << ne.0) != 0).map(|&(v, _)| v)
    }
    fn push_quad(&mut self, q: [VertexId; 4]) {
        self.out.push_quad(q);
    }
}
