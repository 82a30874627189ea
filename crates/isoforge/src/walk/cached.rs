//! The caches of a walker that advances one cell layer at a time, and the [`Cell`] they back.
//!
//! ```text
//!   plane k+1:  x[(k+1) % 2], y[(k+1) % 2], faces normal to z   z: edges (i, j, k) → (i, j, k+1)
//!   plane k:    x[k % 2],     y[k % 2],     faces normal to z   faces normal to x and y, cells of
//!                                                               layer k (and k − 1: centres)
//! ```
//! Slots are dense arrays indexed by a point's (i, j) relative to the cached box, whose first
//! point is `origin`, and *stamped* with the plane or layer they belong to: a slot holds a vertex
//! only when its stamp is the plane or layer asked for, so nothing is cleared between layers.
//! Segments off the lattice edges get the same treatment: a face's split diagonals and the
//! segment between the centres on both sides of it have slots per face, a centre's segments to
//! its cell's corners per cell (for this layer and the one below), a cell's body diagonals per
//! cell; anything else falls back to a small hash map ([`SegmentCache`]). Every vertex is created
//! once, by the first cell that asks.

use super::segment::{self, SegmentCache};
use super::{cell_crossing, edge_hermite, local_on_edge, push_edge_vertex, Cell, Hermite};
use crate::cube::{Axis, CellPoint, CubeEdge, EdgeKey, SegmentKey};
use crate::extract::Placed;
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// Vertices placed by one layer of cells: for each cell its entries.
#[derive(Debug, Default)]
struct PlacedLayer {
    start: Vec<u32>,
    count: Vec<u8>,
    entries: Vec<Placed>,
}

impl PlacedLayer {
    fn reset(&mut self, n: usize) {
        self.start.clear();
        self.start.resize(n, 0);
        self.count.clear();
        self.count.resize(n, 0);
        self.entries.clear();
    }

    fn of(&self, cell: usize) -> &[Placed] {
        let (s, c) = (self.start[cell] as usize, self.count[cell] as usize);
        &self.entries[s..s + c]
    }
}

/// A dense table of values stamped with the plane or layer they belong to, and with the walk
/// that wrote them: every reset starts a new generation, so a table of the same size is reused
/// by the next walk (the next layer group) without clearing or reallocating it.
#[derive(Debug, Clone)]
struct Stamped<T> {
    /// `(generation, stamp, value)`; generation 0 is never current.
    slots: Vec<(u32, u32, T)>,
    generation: u32,
}

impl<T> Default for Stamped<T> {
    fn default() -> Self {
        Stamped { slots: Vec::new(), generation: 0 }
    }
}

impl<T: Copy> Stamped<T> {
    fn reset(&mut self, n: usize, empty: T) {
        if self.slots.len() == n && self.generation < u32::MAX {
            self.generation += 1;
            return;
        }
        self.slots.clear();
        self.slots.resize(n, (0, u32::MAX, empty));
        self.generation = 1;
    }

    #[inline(always)]
    fn get(&self, at: usize, stamp: u32) -> Option<T> {
        let (g, s, v) = self.slots[at];
        (g == self.generation && s == stamp).then_some(v)
    }

    #[inline(always)]
    fn set(&mut self, at: usize, stamp: u32, v: T) {
        self.slots[at] = (self.generation, stamp, v);
    }
}

/// Where a segment's vertex is kept: a table and an index in it, with the stamp to match.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SegmentSlot {
    /// Face slots: the face's normal axis and its kind (0: low–high diagonal, 1: the other
    /// diagonal, 2: the segment between the centres on both sides), at plane or layer `stamp`.
    Face { normal: usize, kind: usize, stamp: u32, at: usize },
    /// A centre's segment to its cell's corner `corner`, for the cell at layer `stamp`.
    CentreCorner { corner: usize, stamp: u32, at: usize },
    /// A body diagonal of a cell of layer `stamp`, named by its end with z = 0 (corner 0–3).
    Body { which: usize, stamp: u32, at: usize },
}

/// The vertex ids of one cell's (or face's) segments, stamped as a group with the layer (plane)
/// and the generation they belong to: a cell's segments are named together, so they share a
/// cache line.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Group<const N: usize> {
    generation: u32,
    stamp: u32,
    ids: [VertexId; N],
}

/// Segments per cell group: centre to corner 0–7, then x-faces by kind (8–10), y-faces (11–13).
const CELL_GROUP: usize = 14;
/// Segments per z-face group: by kind.
const PLANE_GROUP: usize = 3;

impl<const N: usize> Group<N> {
    const EMPTY: Self = Group { generation: 0, stamp: u32::MAX, ids: [VertexId::NONE; N] };

    #[inline(always)]
    fn get(&self, generation: u32, stamp: u32, i: usize) -> Option<VertexId> {
        let id = self.ids[i];
        (self.generation == generation && self.stamp == stamp && id != VertexId::NONE).then_some(id)
    }

    #[inline(always)]
    fn set(&mut self, generation: u32, stamp: u32, i: usize, id: VertexId) {
        if self.generation != generation || self.stamp != stamp {
            *self = Group { generation, stamp, ids: [VertexId::NONE; N] };
        }
        self.ids[i] = id;
    }
}

/// The segment tables (allocated on the first segment a walk names), reused across walks of
/// the same box size like [`Stamped`].
#[derive(Debug, Default)]
struct SegmentTables {
    generation: u32,
    /// Per cell, by layer parity: its centre-to-corner segments and the x- and y-faces at its
    /// low side (whose stamp is always the current layer).
    cells: [Vec<Group<CELL_GROUP>>; 2],
    /// Faces normal to z, by plane parity.
    planes: [Vec<Group<PLANE_GROUP>>; 2],
    body: [Stamped<VertexId>; 4],
}

impl SegmentTables {
    fn new(n: usize) -> Self {
        let mut t = SegmentTables::default();
        t.reset(n);
        t
    }

    fn reset(&mut self, n: usize) {
        if self.cells[0].len() == n && self.generation < u32::MAX {
            self.generation += 1;
        } else {
            for c in &mut self.cells {
                c.clear();
                c.resize(n, Group::EMPTY);
            }
            for p in &mut self.planes {
                p.clear();
                p.resize(n, Group::EMPTY);
            }
            self.generation = 1;
        }
        for b in &mut self.body {
            b.reset(n, VertexId::NONE);
        }
    }

    /// The vertex in `slot`, if one was made.
    #[inline(always)]
    fn get(&self, slot: SegmentSlot) -> Option<VertexId> {
        let g = self.generation;
        match slot {
            SegmentSlot::Face { normal: 2, kind, stamp, at } => self.planes[stamp as usize % 2][at].get(g, stamp, kind),
            SegmentSlot::Face { normal, kind, stamp, at } => {
                self.cells[stamp as usize % 2][at].get(g, stamp, 8 + 3 * normal + kind)
            }
            SegmentSlot::CentreCorner { corner, stamp, at } => self.cells[stamp as usize % 2][at].get(g, stamp, corner),
            SegmentSlot::Body { which, stamp, at } => self.body[which].get(at, stamp),
        }
    }

    /// Keeps `id` in `slot`.
    #[inline(always)]
    fn set(&mut self, slot: SegmentSlot, id: VertexId) {
        let g = self.generation;
        match slot {
            SegmentSlot::Face { normal: 2, kind, stamp, at } => {
                self.planes[stamp as usize % 2][at].set(g, stamp, kind, id)
            }
            SegmentSlot::Face { normal, kind, stamp, at } => {
                self.cells[stamp as usize % 2][at].set(g, stamp, 8 + 3 * normal + kind, id)
            }
            SegmentSlot::CentreCorner { corner, stamp, at } => {
                self.cells[stamp as usize % 2][at].set(g, stamp, corner, id)
            }
            SegmentSlot::Body { which, stamp, at } => self.body[which].set(at, stamp, id),
        }
    }
}

/// Per-layer caches over a box of `w × h` points starting at global `(origin[0], origin[1])`,
/// for the cell layer `k` being walked.
#[derive(Debug, Default)]
pub(crate) struct LayerCaches {
    origin: [u32; 2],
    w: usize,
    h: usize,
    k: u32,
    x: [Stamped<VertexId>; 2],
    y: [Stamped<VertexId>; 2],
    z: Stamped<VertexId>,
    segments: Option<Box<SegmentTables>>,
    /// Segments the tables do not cover.
    other: SegmentCache,
    /// Only used by extractors that place vertices (sized on first use).
    placed: [PlacedLayer; 2],
    /// Hermite data per edge slot, like the ids (allocated on the first request).
    hermite: Option<Box<[HermiteTable; 5]>>,
    /// Crossing parameters per edge slot, like the ids (allocated on the first request).
    crossings: Option<Box<[Stamped<f32>; 5]>>,
    /// Cell-centre values (offset by iso) of the current layer and the one below, by layer
    /// parity, each computed once through `Volume::value_at` (allocated on the first request).
    centres: Option<Box<[Stamped<f32>; 2]>>,
}

/// Hermite data of one edge table: a slot per edge holding an index into a list of the data of
/// the crossed edges of the table's current plane (52 bytes each), so that the dense table stays
/// small (12 bytes a slot: a plane of 256² edges fits in the cache, where slots holding the data
/// itself made reading them a quarter of dual contouring's time). The list is emptied when the
/// table moves on to another plane or walk; an index is only read back while its list is current.
#[derive(Debug, Clone, Default)]
struct HermiteTable {
    slots: Stamped<u32>,
    data: Vec<Hermite>,
    /// `(generation, stamp)` of the slots `data` holds.
    current: (u32, u32),
}

impl HermiteTable {
    fn reset(&mut self, n: usize) {
        self.slots.reset(n, u32::MAX);
        self.data.clear();
        self.current = (self.slots.generation, u32::MAX);
    }

    #[inline(always)]
    fn get(&self, at: usize, stamp: u32) -> Option<Hermite> {
        if self.current != (self.slots.generation, stamp) {
            return None;
        }
        self.slots.get(at, stamp).and_then(|i| self.data.get(i as usize).copied())
    }

    #[inline(always)]
    fn set(&mut self, at: usize, stamp: u32, h: Hermite) {
        if self.current != (self.slots.generation, stamp) {
            self.data.clear();
            self.current = (self.slots.generation, stamp);
        }
        self.slots.set(at, stamp, self.data.len() as u32);
        self.data.push(h);
    }
}

impl LayerCaches {
    /// Empty caches for the box of `w × h` points from `origin`, starting at cell layer `k`.
    pub(crate) fn reset(&mut self, origin: [u32; 2], w: usize, h: usize, k: u32, places: bool) {
        let n = w * h;
        (self.origin, self.w, self.h, self.k) = (origin, w, h, k);
        for ids in self.x.iter_mut().chain(self.y.iter_mut()).chain(std::iter::once(&mut self.z)) {
            ids.reset(n, VertexId::NONE);
        }
        // Tables a previous walk allocated are kept (a new generation), the others made on demand.
        if let Some(t) = &mut self.segments {
            t.reset(n);
        }
        self.other.clear();
        if places {
            self.placed[0].reset(n);
            self.placed[1].reset(n);
        }
        for s in self.hermite.iter_mut().flat_map(|t| t.iter_mut()) {
            s.reset(n);
        }
        for s in self.crossings.iter_mut().flat_map(|t| t.iter_mut()) {
            s.reset(n, f32::NAN);
        }
        for s in self.centres.iter_mut().flat_map(|t| t.iter_mut()) {
            s.reset(n, f32::NAN);
        }
    }

    /// After a layer of cells: the next one (stamps make older slots stale, nothing is cleared).
    pub(crate) fn advance(&mut self, places: bool) {
        self.k += 1;
        self.other.advance();
        if places {
            self.placed.swap(0, 1);
            self.placed[1].reset(self.w * self.h);
        }
    }

    /// The table, stamp and index of edge `e` of cell `ijk` (of the current layer).
    #[inline]
    fn edge_slot(&self, ijk: [u32; 3], e: CubeEdge) -> (usize, u32, usize) {
        let (i, j) = ((ijk[0] - self.origin[0]) as usize, (ijk[1] - self.origin[1]) as usize);
        // r = e % 4 gives the edge's offsets on the two other axes (see cube/mod.rs).
        let (lo, hi) = ((e.0 & 1) as usize, ((e.0 >> 1) & 1) as usize);
        let k = ijk[2];
        match e.axis() {
            Axis::X => (0, k + hi as u32, (j + lo) * self.w + i),
            Axis::Y => (1, k + hi as u32, j * self.w + i + lo),
            Axis::Z => (2, k, (j + hi) * self.w + i + lo),
        }
    }

    #[inline(always)]
    fn edge_table(&mut self, table: usize, stamp: u32) -> &mut Stamped<VertexId> {
        match table {
            0 => &mut self.x[stamp as usize % 2],
            1 => &mut self.y[stamp as usize % 2],
            _ => &mut self.z,
        }
    }

    #[inline]
    fn cell_index(&self, ijk: [u32; 3]) -> usize {
        (ijk[1] - self.origin[1]) as usize * self.w + (ijk[0] - self.origin[0]) as usize
    }

    /// The segment tables, allocated on the first request.
    #[inline]
    fn segment_tables(&mut self) -> &mut SegmentTables {
        let n = self.w * self.h;
        self.segments.get_or_insert_with(|| Box::new(SegmentTables::new(n)))
    }

    /// Index of box cell or face `(i, j)` (global), if it lies in the box.
    #[inline(always)]
    fn box_index(&self, i: u32, j: u32) -> Option<usize> {
        let (i, j) = (i.wrapping_sub(self.origin[0]) as usize, j.wrapping_sub(self.origin[1]) as usize);
        (i < self.w && j < self.h).then(|| j * self.w + i)
    }

    /// The centre table, stamp and index of cell `c`'s centre, if the table covers it (a cell of
    /// the current layer or the one below, inside the box).
    #[inline(always)]
    fn centre_slot(&self, c: [u32; 3]) -> Option<(usize, u32, usize)> {
        if c[2] != self.k && c[2].wrapping_add(1) != self.k {
            return None;
        }
        Some((c[2] as usize % 2, c[2], self.box_index(c[0], c[1])?))
    }

    /// The centre table, allocated on the first request.
    #[inline]
    fn centre_tables(&mut self) -> &mut [Stamped<f32>; 2] {
        let n = self.w * self.h;
        self.centres.get_or_insert_with(|| {
            let mut t: [Stamped<f32>; 2] = Default::default();
            for s in &mut t {
                s.reset(n, f32::NAN);
            }
            Box::new(t)
        })
    }

    /// Keeps the centre value of cell `c` (global index, of the current layer or the one below)
    /// computed by `value` unless the table has it or does not cover the cell. `value` must give
    /// the bits [`Volume::value_at`] gives at the centre (offset by the walk's iso): a walker that
    /// reads the samples computes it without the generic path ([`SampleSlabs::centres_from_samples`]).
    ///
    /// [`SampleSlabs::centres_from_samples`]: crate::volume::SampleSlabs::centres_from_samples
    #[inline]
    pub(crate) fn keep_centre(&mut self, c: [u32; 3], value: impl FnOnce() -> f32) {
        let Some((parity, stamp, at)) = self.centre_slot(c) else { return };
        let table = &mut self.centre_tables()[parity];
        if table.get(at, stamp).is_none() {
            table.set(at, stamp, value());
        }
    }

    /// Where segment `a`–`b` of cell `ijk` (of the current layer) is kept, found from the names of
    /// its ends alone, for the segments of body-centred splits: a centre to a corner of its cell,
    /// a centre to the centre across a face. `None` for any other segment or one the tables do
    /// not cover: the key then decides ([`segment_slot`](Self::segment_slot)), which gives the same
    /// slot for every segment found here (a test checks it).
    #[inline]
    fn named_slot(&self, ijk: [u32; 3], a: CellPoint, b: CellPoint) -> Option<SegmentSlot> {
        use CellPoint::{Beyond, Centre, Corner};
        // The neighbour across face f (its index, if representable).
        let across = |f: u8| -> Option<[u32; 3]> {
            let mut n = ijk;
            let x = (f / 2) as usize;
            n[x] = if f.is_multiple_of(2) { n[x].checked_sub(1)? } else { n[x].checked_add(1)? };
            Some(n)
        };
        let centre_corner = |cell: [u32; 3], corner: u8| -> Option<SegmentSlot> {
            if cell[2] != self.k && cell[2].wrapping_add(1) != self.k {
                return None;
            }
            let at = self.box_index(cell[0], cell[1])?;
            Some(SegmentSlot::CentreCorner { corner: corner as usize, stamp: cell[2], at })
        };
        match (a, b) {
            (Centre, Corner(c)) | (Corner(c), Centre) => centre_corner(ijk, c),
            (Beyond(f), Corner(c)) | (Corner(c), Beyond(f)) => {
                // A corner on the shared face is the neighbour's corner with the face's axis bit flipped.
                let bit = 1u8 << (f / 2);
                let on_face = (c & bit != 0) == (f % 2 == 1);
                if !on_face {
                    return None;
                }
                centre_corner(across(f)?, c ^ bit)
            }
            (Centre, Beyond(f)) | (Beyond(f), Centre) => {
                let normal = (f / 2) as usize;
                let mut o = ijk;
                if f % 2 == 1 {
                    o[normal] = o[normal].checked_add(1)?;
                } else {
                    across(f)?;
                }
                if !(o[2] == self.k || normal == 2 && o[2] == self.k.wrapping_add(1)) {
                    return None;
                }
                Some(SegmentSlot::Face { normal, kind: 2, stamp: o[2], at: self.box_index(o[0], o[1])? })
            }
            _ => None,
        }
    }

    /// Where segment `key` (named by a cell of the current layer) is kept, if the tables cover it.
    fn segment_slot(&self, key: &SegmentKey) -> Option<SegmentSlot> {
        let (a, b) = (key.a.map(i64::from), key.b.map(i64::from));
        let d = [0, 1, 2].map(|x| (b[x] - a[x]).abs());
        let lo = [0, 1, 2].map(|x| a[x].min(b[x]));
        let even = |p: &[i64; 3]| p.iter().all(|c| c % 2 == 0);
        let odd = |p: &[i64; 3]| p.iter().all(|c| c % 2 == 1);
        let index = |i: i64, j: i64| -> Option<usize> {
            let (i, j) = (i - self.origin[0] as i64, j - self.origin[1] as i64);
            (i >= 0 && j >= 0 && (i as usize) < self.w && (j as usize) < self.h)
                .then(|| j as usize * self.w + i as usize)
        };
        let k = self.k as i64;
        let moved = d.iter().filter(|&&x| x != 0).count();
        if even(&a) && even(&b) && moved == 2 && d.iter().all(|&x| x == 0 || x == 2) {
            // A face diagonal: the face's normal is the axis that does not move.
            let normal = (0..3).find(|x| d[*x] == 0)?;
            let low_high = (0..3).all(|x| a[x] <= b[x]);
            let o = lo.map(|c| c / 2);
            let stamp = o[2];
            if !(stamp == k || normal == 2 && stamp == k + 1) {
                return None;
            }
            let at = index(o[0], o[1])?;
            return Some(SegmentSlot::Face { normal, kind: usize::from(!low_high), stamp: stamp as u32, at });
        }
        if even(&a) && even(&b) && moved == 3 && d.iter().all(|&x| x == 2) {
            let cell = lo.map(|c| c / 2);
            let bottom = if a[2] < b[2] { a } else { b };
            let which = (((bottom[0] / 2 - cell[0]) as usize) | (((bottom[1] / 2 - cell[1]) as usize) << 1)) & 3;
            if cell[2] != k {
                return None;
            }
            return Some(SegmentSlot::Body { which, stamp: k as u32, at: index(cell[0], cell[1])? });
        }
        if odd(&a) && odd(&b) && moved == 1 && d.contains(&2) {
            // Between two centres: the face they share.
            let normal = (0..3).find(|&x| d[x] != 0)?;
            let mut o = lo.map(|c| (c - 1) / 2);
            o[normal] += 1;
            if !(o[2] == k || normal == 2 && o[2] == k + 1) {
                return None;
            }
            return Some(SegmentSlot::Face { normal, kind: 2, stamp: o[2] as u32, at: index(o[0], o[1])? });
        }
        let (centre, corner) = if odd(&a) && even(&b) {
            (a, b)
        } else if odd(&b) && even(&a) {
            (b, a)
        } else {
            return None;
        };
        let cell = centre.map(|c| (c - 1) / 2);
        let rel = [0, 1, 2].map(|x| corner[x] / 2 - cell[x]);
        if rel.iter().any(|&r| !(0..=1).contains(&r)) || !(cell[2] == k || cell[2] == k - 1) {
            return None;
        }
        let c = (rel[0] | (rel[1] << 1) | (rel[2] << 2)) as usize;
        Some(SegmentSlot::CentreCorner { corner: c, stamp: cell[2] as u32, at: index(cell[0], cell[1])? })
    }
}

/// A cell of a layer walk: its values, and the caches that make every vertex unique.
pub(crate) struct CachedCell<'a, V: ?Sized> {
    pub(crate) ijk: [u32; 3],
    pub(crate) d: [f32; 8],
    pub(crate) case: u8,
    pub(crate) dims: [u32; 3],
    pub(crate) vol: &'a V,
    pub(crate) iso: Iso,
    pub(crate) caches: &'a mut LayerCaches,
    pub(crate) out: &'a mut MeshBuilder,
    /// Centre values computed so far (NaN = not yet).
    pub(crate) memo: [f32; 7],
    /// Vertices this cell placed so far.
    pub(crate) placed: u8,
}

impl<'a, V: Volume + ?Sized> CachedCell<'a, V> {
    /// A cell of the current layer.
    #[inline]
    pub(crate) fn new(
        ijk: [u32; 3],
        d: [f32; 8],
        case: u8,
        vol: &'a V,
        iso: Iso,
        caches: &'a mut LayerCaches,
        out: &'a mut MeshBuilder,
    ) -> Self {
        CachedCell { ijk, d, case, dims: vol.lattice().dims(), vol, iso, caches, out, memo: [f32::NAN; 7], placed: 0 }
    }
}

impl<V: Volume + ?Sized> Cell for CachedCell<'_, V> {
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

    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        let (table, stamp, at) = self.caches.edge_slot(self.ijk, e);
        let n = self.caches.w * self.caches.h;
        let slots = self.caches.hermite.get_or_insert_with(|| {
            let mut t: [HermiteTable; 5] = Default::default();
            for s in &mut t {
                s.reset(n);
            }
            Box::new(t)
        });
        // Tables 0–1: x by plane parity, 2–3: y, 4: z.
        let slot = match table {
            0 => &mut slots[stamp as usize % 2],
            1 => &mut slots[2 + stamp as usize % 2],
            _ => &mut slots[4],
        };
        if let Some(h) = slot.get(at, stamp) {
            return h.on_edge(e);
        }
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let h = edge_hermite(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso);
        slot.set(at, stamp, h);
        h.on_edge(e)
    }

    fn crossing(&mut self, e: CubeEdge) -> [f32; 3] {
        let (table, stamp, at) = self.caches.edge_slot(self.ijk, e);
        let n = self.caches.w * self.caches.h;
        let slots = self.caches.crossings.get_or_insert_with(|| {
            let mut t: [Stamped<f32>; 5] = Default::default();
            for s in &mut t {
                s.reset(n, f32::NAN);
            }
            Box::new(t)
        });
        let slot = match table {
            0 => &mut slots[stamp as usize % 2],
            1 => &mut slots[2 + stamp as usize % 2],
            _ => &mut slots[4],
        };
        if let Some(t) = slot.get(at, stamp) {
            return local_on_edge(e, t);
        }
        let p = cell_crossing(self.vol, self.ijk, e, &self.d, self.iso);
        slot.set(at, stamp, p[e.axis().index()]);
        p
    }

    #[inline]
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let (table, stamp, at) = self.caches.edge_slot(self.ijk, e);
        if let Some(id) = self.caches.edge_table(table, stamp).get(at, stamp) {
            return id;
        }
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let id = push_edge_vertex(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso, self.out);
        self.caches.edge_table(table, stamp).set(at, stamp, id);
        id
    }

    #[inline]
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.dims, self.ijk, face)
    }

    #[inline]
    fn point_value(&mut self, p: CellPoint) -> f32 {
        let mut c = self.ijk;
        match p {
            CellPoint::Corner(corner) => return self.d[corner as usize],
            CellPoint::Centre => {}
            CellPoint::Beyond(f) => {
                let x = (f / 2) as usize;
                c[x] = if f % 2 == 0 { c[x].wrapping_sub(1) } else { c[x].wrapping_add(1) };
            }
        }
        let Some((parity, stamp, at)) = self.caches.centre_slot(c) else {
            return segment::point_value(self.vol, self.iso, self.ijk, &self.d, &mut self.memo, p);
        };
        let table = &mut self.caches.centre_tables()[parity];
        if let Some(v) = table.get(at, stamp) {
            return v;
        }
        // The same point as `segment::point_value` names (ijk + local), so the same bits.
        let v = self.vol.value_at(c.map(|x| x as f64 + 0.5), self.iso);
        table.set(at, stamp, v);
        v
    }

    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        if let Some(e) = CellPoint::axis_edge(a, b) {
            return self.edge_vertex(e);
        }
        let (vol, iso) = (self.vol, self.iso);
        if let Some(slot) = self.caches.named_slot(self.ijk, a, b) {
            // Centre segments: found without a key; the key and the end values only for a new vertex.
            if let Some(id) = self.caches.segment_tables().get(slot) {
                return id;
            }
            let ijk = self.ijk;
            let (key, d0, d1) = segment::segment_ends(ijk, a, b, |p| self.point_value(p));
            let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
            self.caches.segment_tables().set(slot, id);
            return id;
        }
        let ijk = self.ijk;
        let (key, d0, d1) = segment::segment_ends(ijk, a, b, |p| self.point_value(p));
        let caches = &mut *self.caches;
        match caches.segment_slot(&key) {
            Some(slot) => {
                let tables = caches.segment_tables();
                if let Some(id) = tables.get(slot) {
                    return id;
                }
                let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
                tables.set(slot, id);
                id
            }
            None => {
                if let Some(id) = caches.other.get(&key) {
                    return id;
                }
                let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
                caches.other.insert(key, id);
                id
            }
        }
    }

    fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId {
        let n = self.placed;
        self.placed += 1;
        let (id, w) = segment::push_cell_vertex(self.vol, self.iso, self.ijk, n, local, self.out);
        let c = self.caches.cell_index(self.ijk);
        let layer = &mut self.caches.placed[1];
        if !layer.start.is_empty() {
            if layer.count[c] == 0 {
                layer.start[c] = layer.entries.len() as u32;
            }
            layer.count[c] += 1;
            layer.entries.push(Placed { vertex: id, point: w, edges });
        }
        id
    }

    fn placed(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<Placed> {
        let key = EdgeKey::of_cell(self.ijk, e);
        let cell = segment::neighbour(self.ijk, offset)?;
        let ne = key.in_cell(cell)?;
        let (ox, oy) = (self.caches.origin[0], self.caches.origin[1]);
        if cell[0] < ox || cell[1] < oy || offset[2] < -1 || offset[2] > 0 {
            return None;
        }
        let layer = &self.caches.placed[(offset[2] + 1) as usize];
        if layer.start.is_empty() {
            return None;
        }
        let c = self.caches.cell_index(cell);
        layer.of(c).iter().find(|p| p.edges & (1 << ne.0) != 0).copied()
    }

    #[inline]
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.out.push_triangle(t);
    }

    #[inline]
    fn push_quad(&mut self, q: [VertexId; 4]) {
        self.out.push_quad(q);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cube::CellPoint::{Beyond, Centre, Corner};
    use crate::grid::{DenseGrid, Lattice};
    use crate::mesh::Normals;
    use crate::volume::GridVolume;

    fn points() -> Vec<CellPoint> {
        (0..8).map(Corner).chain([Centre]).chain((0..6).map(Beyond)).collect()
    }

    #[test]
    fn named_slots_are_the_slots_of_their_keys() {
        let mut c = LayerCaches::default();
        // Box points i 1..=5, j 2..=5; layer 3. Cells around and outside the box too.
        let k = 3;
        c.reset([1, 2], 5, 4, k, false);
        let mut named = 0;
        for i in 0..8 {
            for j in 0..8 {
                let ijk = [i, j, k];
                for a in points() {
                    for b in points() {
                        let Some((key, _)) = SegmentKey::of_cell(ijk, a, b) else { continue };
                        if a == b {
                            continue;
                        }
                        if let Some(slot) = c.named_slot(ijk, a, b) {
                            assert_eq!(Some(slot), c.segment_slot(&key), "cell {ijk:?}, {a:?}–{b:?}");
                            named += 1;
                        }
                    }
                }
            }
        }
        // Inside the box every centre-to-corner and centre-to-centre segment is found by name.
        let inner = [2, 3, k];
        for p in points().into_iter().filter(|p| *p != Centre) {
            assert!(c.named_slot(inner, Centre, p).is_some(), "{p:?}");
        }
        assert!(named > 0);
    }

    #[test]
    fn centre_table_gives_the_values_of_value_at() {
        let dims = [6, 5, 7];
        let mut h = 0x2545_f491_u32;
        let g = DenseGrid::from_fn(Lattice::new(dims).unwrap(), |_| {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            (h % 1000) as f32 / 7.0
        });
        let vol = GridVolume::new(&g);
        let iso = Iso::below(60.0);
        let mut out = MeshBuilder::new(Normals::None);
        let mut caches = LayerCaches::default();
        // Twice: the second walk reuses the tables (a new generation).
        for _ in 0..2 {
            caches.reset([0, 0], dims[0] as usize, dims[1] as usize, 0, false);
            for k in 0..dims[2] - 1 {
                for j in 0..dims[1] - 1 {
                    for i in 0..dims[0] - 1 {
                        let ijk = [i, j, k];
                        let mut cell = CachedCell::new(ijk, [1.0; 8], 0, &vol, iso, &mut caches, &mut out);
                        let faces: Vec<u8> = (0..6).filter(|&f| cell.has_neighbour(f)).collect();
                        for f in faces {
                            let mut n = ijk.map(f64::from);
                            n[(f / 2) as usize] += if f % 2 == 0 { -1.0 } else { 1.0 };
                            let want = vol.value_at(n.map(|x| x + 0.5), iso);
                            for _ in 0..2 {
                                assert_eq!(cell.point_value(Beyond(f)).to_bits(), want.to_bits(), "{ijk:?} face {f}");
                            }
                        }
                        let want = vol.value_at(ijk.map(|x| x as f64 + 0.5), iso);
                        assert_eq!(cell.point_value(Centre).to_bits(), want.to_bits(), "{ijk:?}");
                    }
                }
                caches.advance(false);
            }
        }
    }
}
