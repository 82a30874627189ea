//! Marching cubes 33 [Chernyaev95; Lewiner03; Custodio13]: the topology of the trilinear
//! interpolant in every cell, decided from the values instead of read from a 33-case table.
//!
//! Per active cell:
//! 1. **Faces.** On each face the crossings pair up into segments; a face with four crossings is
//!    ambiguous and its bilinear saddle decides (asymptotic decider \[Nielson91\]): the two inside
//!    corners are joined iff the saddle value is below iso, computed as the sign of
//!    `a·c − b·d` with exact f64 products so both cells sharing the face decide the same way.
//! 2. **Loops.** Segments chain into closed loops on the cube's surface (each crossed edge lies on
//!    two faces), oriented with the inside on the right seen from outside the cell.
//! 3. **Interior.** The loops split the cube's surface into patches. Two patches of one class
//!    (inside or outside) that are joined through the cell's interior form a tunnel. Connectivity
//!    through the interior is decided exactly by sweeping horizontal slices: the slice at height t
//!    is bilinear, its topology changes only where a vertical edge crosses or where its saddle
//!    crosses iso (roots of a quadratic), and slice components are followed from one sample to
//!    the next through the vertical edges; the samples are the events themselves and the middle
//!    of every interval between them. This covers Chernyaev's interior test for cases 4, 6, 7,
//!    10, 12 and 13 including the configurations that Custodio et al. found mis-tabulated.
//! 4. **Triangles.** Each loop not in a tunnel spans a disk: a fan from its first vertex, or from
//!    a cell-private centroid vertex when the loop crosses one face twice (a fan there could
//!    create a chord also used by the neighbour). A tunnel's two loops are joined by a band; a
//!    band chord whose ends lie on one face (both loops cross a face whose saddle separates them)
//!    is split at a cell-private vertex, because the neighbour's tunnel through that face could
//!    pick the same chord.
//! 5. **No folds.** A thin tunnel squeezed against a face can make its band cross itself. A
//!    tunnel cell's triangles are first sketched in cell coordinates and tested pairwise with the
//!    exact predicates of `check --self-intersections`; the band is laid (zipper start, depth of
//!    its chord vertices: `Lay`) the first way that does not fold. The lay depends on the values
//!    alone, so the count before the fill agrees with the fill.
//!
//! Steps 1–2 and the candidate loops of step 3 depend only on the case and the face deciders, so
//! they are tabulated once per case and face decisions (`Skeleton`); per cell only the deciders and,
//! for a class with several patches, the slice sweep run — unless a cheap exact pre-test
//! (`interior_cannot_join`: no slice inside the cell has that class joined across its diagonal)
//! shows the sweep would join nothing, as for most such classes on scans. A walker that counts before it fills gets
//! the decided topology from [`counts`](Extractor::counts) and hands it back to
//! [`process_decided`](Extractor::process_decided).
//!
//! Ties follow the project rule (a value equal to iso is outside; a saddle exactly at iso is
//! outside), identically in both cells of a face, so no crack or non-manifold edge can appear.
//! Inside the cell the same rule makes the outside closed: where a slice saddle only touches iso
//! (a double root) or two vertical edges reach iso at one height, the outside regions meeting
//! there are joined. Integer scans produce all of these (issue 10; `isoforge-io/tests/real_data.rs`).

use super::{CellCounts, Counting, Decision, Extractor, ProbeCell};
use crate::cube::{CubeEdge, CORNER_OFFSETS, EDGE_CORNERS, EDGE_FACES, FACE_CORNERS, FACE_EDGES};
use crate::extract::Cell;
use crate::math::UnionFind;
use crate::mesh::VertexId;

/// Marching cubes 33: the isosurface of the trilinear interpolant, cell by cell.
///
/// **Guarantees**: for a surface that stays inside the lattice, the mesh is closed, edge- and
/// vertex-manifold, consistently oriented (normals from inside to outside), and has the
/// components and genus of the trilinear interpolant's isosurface (ties at iso counted outside).
/// Vertices lie on lattice edges (shared), plus private ones inside the cell: a centroid for each
/// loop that crosses a face twice, and one on the interpolant for each tunnel chord on a face.
/// A tunnel's triangles do not cross each other (checked exactly on a sketch of the cell; on
/// the real scans and random lattices no two triangles cross, `tests/topology.rs`).
///
/// **Limits**: geometry inside a cell is a fan or a band, not the interpolant's exact shape.
#[derive(Debug, Clone, Copy, Default)]
pub struct MarchingCubes33;

impl Extractor for MarchingCubes33 {
    const COUNTING: Counting = Counting::Known;

    #[inline]
    fn case_triangles(&self, case: u8, _odd: bool) -> Option<&[[u8; 3]]> {
        easy_cases()[case as usize].as_deref()
    }

    fn counts(&self, case: u8, ijk: [u32; 3], values: impl FnOnce() -> [f32; 8]) -> (CellCounts, Decision) {
        let _ = ijk;
        if let Some(t) = self.case_triangles(case, false) {
            return (CellCounts { triangles: t.len() as u16, ..Default::default() }, Decision::default());
        }
        // The values decide: what `general` makes, without making it.
        let d = values();
        let topo = CellTopology::of_case(case, &d);
        if topo.n_tubes == 0 {
            // Every loop a disk: the skeleton's counts (most value-decided cells).
            return (topo.skeleton.disks, topo.decision());
        }
        let counts = Sketch::of(&topo, 0, &d, Lay::unfolded(&topo, 0, &d)).counts();
        (counts, topo.decision())
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        match self.case_triangles(cell.case(), false) {
            Some(t) => {
                for &[a, b, c] in t {
                    let v = [a, b, c].map(|e| cell.edge_vertex(CubeEdge(e)));
                    cell.push_triangle(v);
                }
            }
            None => self.general(cell),
        }
    }

    /// A cell whose loops are all plain fans (no tunnel, no centroid): its skeleton's fans, what
    /// `triangulate` makes for it.
    #[inline]
    fn decided_triangles(&self, Decision(code): Decision) -> Option<&[[u8; 3]]> {
        if code >> SKELETON_BITS != 0 {
            return None; // tunnels
        }
        let s = skeletons().table.get(code as usize)?;
        (s.twice == 0).then(|| &s.fans[..s.disks.triangles as usize])
    }

    fn process_decided<C: Cell>(&self, cell: &mut C, decision: Decision) {
        match self.case_triangles(cell.case(), false) {
            Some(_) => self.process(cell),
            None => self.triangulate(cell, &CellTopology::of_decision(decision)),
        }
    }
}

impl MarchingCubes33 {
    /// Decides and triangulates a cell from its values (every case; `process` uses the table
    /// where the case decides).
    fn general<C: Cell>(&self, cell: &mut C) {
        let d = *cell.values();
        self.triangulate(cell, &CellTopology::of(&d));
    }

    /// Triangulates a cell of topology `topo`: a band per tunnel, a disk per other loop.
    fn triangulate<C: Cell>(&self, cell: &mut C, topo: &CellTopology) {
        triangulate(cell, topo, 0);
    }
}

/// Triangulates a cell of topology `topo` but the loops in the bit mask `skip` (none in a
/// tunnel; another method fans them): a band per tunnel, a disk per other loop. The values are
/// read only where the geometry needs them (bands, centroids); a cell of disks without a
/// centroid is a fan per loop, as in the case table.
pub(crate) fn triangulate<C: Cell>(cell: &mut C, topo: &CellTopology, skip: u8) {
    let needs_values = topo.n_tubes > 0 || topo.skeleton.twice & !skip != 0;
    let d = if needs_values { *cell.values() } else { [0.0; 8] };
    let lay = if topo.n_tubes > 0 { Lay::unfolded(topo, skip, &d) } else { Lay::default() };
    let mut emit = Emit { cell, d: &d, rule: lay.rule, ids: [VertexId::NONE; 12], split: [[VertexId::NONE; 12]; 12] };
    build(&mut emit, topo, skip, &d, lay.start);
}

/// Where a cell's triangles go: the mesh ([`Emit`]) or a sketch of local positions
/// ([`Sketch`], to test a placement for folds). [`build`] calls them in one order for both, so
/// the mesh's vertices are created in the order the sketch saw them.
trait Out {
    type V: Copy;
    /// The crossing on cube edge `e`.
    fn edge(&mut self, e: u8) -> Self::V;
    /// The private vertex splitting the face chord `x`–`y` on face `f` (one per chord).
    fn chord(&mut self, x: u8, y: u8, f: u8) -> Self::V;
    /// A private vertex at the centroid of a loop's crossings.
    fn centroid(&mut self, edges: &[u8]) -> Self::V;
    fn triangle(&mut self, t: [Self::V; 3]);
}

/// The cell's triangles, bands first (one per tunnel), then a disk per other loop but those in
/// `skip`: a fan from its first vertex, or from its centroid when the loop crosses one face
/// twice (a fan there could make a chord the neighbour also uses).
fn build<O: Out>(out: &mut O, topo: &CellTopology, skip: u8, d: &[f32; 8], start: usize) {
    let tubes = topo.tube_loops();
    debug_assert_eq!(tubes & skip, 0, "a loop in a tunnel is not a disk");
    for &(a, b) in &topo.tubes[..topo.n_tubes] {
        band(out, d, topo.loop_edges(a), topo.loop_edges(b), start);
    }
    for l in 0..topo.n_loops() {
        if (tubes | skip) >> l & 1 == 1 {
            continue;
        }
        let edges = topo.loop_edges(l);
        if topo.visits_a_face_twice(l) {
            let centre = out.centroid(edges);
            for i in 0..edges.len() {
                let (p, q) = (out.edge(edges[i]), out.edge(edges[(i + 1) % edges.len()]));
                out.triangle([centre, q, p]);
            }
        } else {
            let v0 = out.edge(edges[0]);
            for i in 1..edges.len() - 1 {
                let (p, q) = (out.edge(edges[i]), out.edge(edges[i + 1]));
                out.triangle([v0, q, p]);
            }
        }
    }
}

/// [`Out`] into the cell: vertices created on first use, chords split at [`off_face_point`]
/// with placement `rule`.
struct Emit<'a, C> {
    cell: &'a mut C,
    d: &'a [f32; 8],
    rule: u8,
    ids: [VertexId; 12],
    split: [[VertexId; 12]; 12],
}

impl<C: Cell> Out for Emit<'_, C> {
    type V = VertexId;

    fn edge(&mut self, e: u8) -> VertexId {
        if self.ids[e as usize] == VertexId::NONE {
            self.ids[e as usize] = self.cell.edge_vertex(CubeEdge(e));
        }
        self.ids[e as usize]
    }

    fn chord(&mut self, x: u8, y: u8, f: u8) -> VertexId {
        let (lo, hi) = (x.min(y) as usize, x.max(y) as usize);
        if self.split[lo][hi] == VertexId::NONE {
            self.split[lo][hi] = self.cell.place_vertex(off_face_point(self.d, x, y, f, self.rule), 0);
        }
        self.split[lo][hi]
    }

    fn centroid(&mut self, edges: &[u8]) -> VertexId {
        self.cell.place_vertex(centroid(self.d, edges), 0)
    }

    fn triangle(&mut self, t: [VertexId; 3]) {
        self.cell.push_triangle(t);
    }
}

/// Most triangles a cell makes: two bands of at most 12 + 12 triangles, each chord split into
/// two (at most 48 in all), and disks on the remaining crossings.
const SKETCH_TRIANGLES: usize = 64;
/// Slots: 12 cube edges, then private vertices (chords and centroids) in order of first use.
const SKETCH_SLOTS: usize = 64;

/// [`Out`] into local positions (cell coordinates from the values' linear crossings, f64)
/// numbered by slot: the cell's triangles under chord placement `rule`, to count them and to test
/// them for folds without a cell.
struct Sketch<'a> {
    d: &'a [f32; 8],
    rule: u8,
    pos: [[f64; 3]; SKETCH_SLOTS],
    slots: usize,
    split: [[u8; 12]; 12],
    tris: [[u8; 3]; SKETCH_TRIANGLES],
    n: usize,
}

impl<'a> Sketch<'a> {
    /// The triangles and private vertices that values `d` of topology `topo` make laid as `lay`.
    fn of(topo: &CellTopology, skip: u8, d: &'a [f32; 8], lay: Lay) -> Self {
        let mut sketch = Sketch {
            d,
            rule: lay.rule,
            pos: [[0.0; 3]; SKETCH_SLOTS],
            slots: 12,
            split: [[u8::MAX; 12]; 12],
            tris: [[0; 3]; SKETCH_TRIANGLES],
            n: 0,
        };
        for (e, p) in sketch.pos[..12].iter_mut().enumerate() {
            *p = edge_point(d, e as u8).map(f64::from);
        }
        build(&mut sketch, topo, skip, d, lay.start);
        sketch
    }

    fn counts(&self) -> CellCounts {
        CellCounts { triangles: self.n as u16, placed: (self.slots - 12) as u16, ..Default::default() }
    }

    fn private(&mut self, p: [f32; 3]) -> u8 {
        debug_assert!(self.slots < SKETCH_SLOTS, "more private vertices than a cell can make");
        let s = self.slots.min(SKETCH_SLOTS - 1);
        self.pos[s] = p.map(f64::from);
        self.slots += 1;
        s as u8
    }

    /// Pairs of the triangles that meet other than adjacent triangles may (the exact test of
    /// `check --self-intersections`).
    fn folds(&self) -> usize {
        let mut geo = [([0u32; 3], [[0.0f64; 3]; 3], 0usize); SKETCH_TRIANGLES];
        let mut n = 0;
        for t in &self.tris[..self.n.min(SKETCH_TRIANGLES)] {
            let p = t.map(|s| self.pos[s as usize]);
            if let Some(k) = crate::topo::keep_axis(&p) {
                geo[n] = (t.map(u32::from), p, k);
                n += 1;
            }
        }
        let geo = &geo[..n];
        let mut folds = 0;
        for (i, (ta, a, ka)) in geo.iter().enumerate() {
            for (tb, b, kb) in &geo[i + 1..] {
                folds += crate::topo::improper(*ta, a, *ka, *tb, b, *kb) as usize;
            }
        }
        folds
    }
}

impl Out for Sketch<'_> {
    type V = u8;

    fn edge(&mut self, e: u8) -> u8 {
        e
    }

    fn chord(&mut self, x: u8, y: u8, f: u8) -> u8 {
        let (lo, hi) = (x.min(y) as usize, x.max(y) as usize);
        if self.split[lo][hi] == u8::MAX {
            self.split[lo][hi] = self.private(off_face_point(self.d, x, y, f, self.rule));
        }
        self.split[lo][hi]
    }

    fn centroid(&mut self, edges: &[u8]) -> u8 {
        self.private(centroid(self.d, edges))
    }

    fn triangle(&mut self, t: [u8; 3]) {
        debug_assert!(self.n < SKETCH_TRIANGLES, "more triangles than a cell can make");
        if self.n < SKETCH_TRIANGLES {
            self.tris[self.n] = t;
        }
        self.n += 1;
    }
}

/// How a tunnel cell's bands are laid: where each band's zipper starts ([`band_triangles`]) and
/// how deep its chord vertices go ([`CHORD_RULES`]). A function of the values alone, so the count
/// before the fill and the fill agree.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord)]
struct Lay {
    start: usize,
    rule: u8,
}

impl Lay {
    /// The first lay (starts in order, each with every chord rule) under which the cell's
    /// triangles do not fold onto each other, or the one with the fewest folds. The default lay
    /// (the closest pair of crossings first, chord vertices on the interpolant) serves almost
    /// every cell; a thin tunnel squeezed against a face can fold under it.
    fn unfolded(topo: &CellTopology, skip: u8, d: &[f32; 8]) -> Lay {
        let starts = topo.tubes[..topo.n_tubes]
            .iter()
            .map(|&(a, b)| topo.loop_edges(a).len() * topo.loop_edges(b).len())
            .max()
            .unwrap_or(1);
        let mut best = (usize::MAX, Lay::default());
        for start in 0..starts {
            for rule in 0..CHORD_RULES.len() as u8 {
                let lay = Lay { start, rule };
                let folds = Sketch::of(topo, skip, d, lay).folds();
                if folds == 0 {
                    return lay;
                }
                best = best.min((folds, lay));
            }
        }
        best.1
    }
}

/// The cases whose triangles the case alone decides: no ambiguous face (no face with its two
/// inside corners on a diagonal) and one connected patch of each class on the cell's surface, so
/// one loop and no possible tunnel. Their triangles (the loop's fan, exactly what the general
/// path makes) are tabulated once; the other cases are decided from the values.
fn easy_cases() -> &'static [Option<Vec<[u8; 3]>>; 256] {
    static TABLE: std::sync::OnceLock<[Option<Vec<[u8; 3]>>; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|case| {
            let d: [f32; 8] = std::array::from_fn(|c| if case >> c & 1 == 1 { -1.0 } else { 1.0 });
            let ambiguous = FACE_CORNERS.iter().any(|f| {
                let [p, q, r, s] = f.map(|c| inside(d[c as usize]));
                p == r && q == s && p != q
            });
            let mut patches = UnionFind::<[u32; 8]>::fixed();
            for [a, b] in EDGE_CORNERS {
                if inside(d[a as usize]) == inside(d[b as usize]) {
                    patches.union(a as usize, b as usize);
                }
            }
            let mut roots = |class: bool| {
                let mut r: Vec<usize> = (0..8).filter(|&c| inside(d[c]) == class).map(|c| patches.find(c)).collect();
                r.sort();
                r.dedup();
                r.len()
            };
            if case == 0 || case == 255 || ambiguous || roots(true) > 1 || roots(false) > 1 {
                return None;
            }
            let mut probe = ProbeCell::new([0; 3], d);
            MarchingCubes33.general(&mut probe);
            (!probe.other_vertices && probe.counts.placed == 0).then_some(probe.triangles)
        })
    })
}

/// At most 4 loops: 12 edges, at least 3 per loop.
const MAX_LOOPS: usize = 4;
const NO_EDGE: u8 = u8::MAX;

#[inline]
fn inside(v: f32) -> bool {
    v < 0.0
}

/// Whether the saddle of face `f`'s bilinear interpolant is inside; meaningful for ambiguous faces
/// (opposite corners of one class). Exact: products of f32 in f64 do not round, and their
/// difference rounds to the right sign.
#[inline]
pub(crate) fn face_centre_inside(d: &[f32; 8], f: usize) -> bool {
    let [p, q, r, s] = FACE_CORNERS[f].map(|c| d[c as usize] as f64);
    saddle_inside(p, q, r, s)
}

/// For a square with values p, q, r, s counter-clockwise and an ambiguous sign pattern (p, r on
/// one side, q, s on the other): is the bilinear saddle value `(pr − qs) / (p + r − q − s)` < 0?
#[inline]
pub(crate) fn saddle_inside(p: f64, q: f64, r: f64, s: f64) -> bool {
    let num = p * r - q * s;
    // The denominator is < 0 when p, r are inside and > 0 when q, s are.
    if p < 0.0 {
        num > 0.0
    } else {
        num < 0.0
    }
}

/// The loops of one cell and which pairs of them a tunnel joins.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CellTopology {
    /// What the signs and face decisions fix (tabulated), and its index in the table.
    skeleton: &'static Skeleton,
    index: u32,
    pub(crate) tubes: [(usize, usize); 2],
    pub(crate) n_tubes: usize,
}

impl CellTopology {
    pub(crate) fn loop_edges(&self, l: usize) -> &'static [u8] {
        self.skeleton.loop_edges(l)
    }

    pub(crate) fn n_loops(&self) -> usize {
        self.skeleton.n_loops as usize
    }

    /// The loops in a tunnel, as a bit mask (bit l: loop l is one end of a band).
    pub(crate) fn tube_loops(&self) -> u8 {
        self.tubes[..self.n_tubes].iter().fold(0, |m, &(a, b)| m | 1 << a | 1 << b)
    }

    pub(crate) fn visits_a_face_twice(&self, l: usize) -> bool {
        self.skeleton.twice >> l & 1 == 1
    }

    /// The topology of the cell with offset values `d`: its skeleton from the signs and the face
    /// deciders (a table lookup), then the tunnels its interior makes (the slice sweep, only for
    /// a class with several patches on the cell's surface).
    pub(crate) fn of(d: &[f32; 8]) -> Self {
        Self::of_case(crate::cube::case_of(d), d)
    }

    /// [`of`](CellTopology::of) for a cell of known `case`.
    #[inline]
    pub(crate) fn of_case(case: u8, d: &[f32; 8]) -> Self {
        Self::of_case_with(case, d, true)
    }

    /// [`of_case`](CellTopology::of_case), sweeping every class with several patches unless
    /// `pretest` may rule the sweep out first ([`interior_cannot_join`]; the same topology).
    fn of_case_with(case: u8, d: &[f32; 8], pretest: bool) -> Self {
        let faces = &skeletons().faces[case as usize];
        // PASS 1: the deciders of the case's ambiguous faces select the skeleton.
        let mut bits = 0usize;
        for (i, &f) in faces.ambiguous[..faces.n_ambiguous as usize].iter().enumerate() {
            bits |= (face_centre_inside(d, f as usize) as usize) << i;
        }
        let index = faces.first + bits as u32;
        let skeleton = &skeletons().table[index as usize];
        // PASS 2: tunnels, two patches of one class joined through the interior.
        let mut t = CellTopology { skeleton, index, tubes: [(0, 0); 2], n_tubes: 0 };
        for (class, patches) in skeleton.classes.iter().enumerate() {
            let n = patches.n as usize;
            if n < 2 || !patches.may_tube {
                // One patch, or no pair of loops a tunnel could join: the interior adds nothing.
                continue;
            }
            if pretest && interior_cannot_join(d, class == 0) {
                // No slice inside the cell joins two corners of the class across its diagonal:
                // the sweep would find the patches of the surface, apart.
                continue;
            }
            let mut interior = interior_components(d, class == 0);
            let mut joined = UnionFind::<[u32; 4]>::fixed();
            for i in 0..n {
                for j in i + 1..n {
                    let (p, q) = (patches.roots[i] as usize, patches.roots[j] as usize);
                    if !interior.joined(p, q) || joined.find(i) == joined.find(j) {
                        continue;
                    }
                    let [l0, l1] = patches.tube_loops[i][j];
                    if l0 != NO_LOOP {
                        if t.n_tubes < t.tubes.len() {
                            t.tubes[t.n_tubes] = (l0 as usize, l1 as usize);
                            t.n_tubes += 1;
                        }
                        joined.union(i, j);
                    }
                }
            }
        }
        t
    }

    /// The topology as a [`Decision`]: the skeleton's index (bits 0–13), the number of tunnels
    /// (bits 14–15), then the two loops of each tunnel (2 bits each).
    fn decision(&self) -> Decision {
        let mut code = self.index | (self.n_tubes as u32) << SKELETON_BITS;
        for (i, &(a, b)) in self.tubes[..self.n_tubes].iter().enumerate() {
            code |= ((a | b << 2) as u32) << (SKELETON_BITS + 2 + 4 * i as u32);
        }
        Decision(code)
    }

    /// The topology a [`decision`](CellTopology::decision) encodes.
    fn of_decision(Decision(code): Decision) -> Self {
        let index = code & ((1 << SKELETON_BITS) - 1);
        let mut t = CellTopology {
            skeleton: &skeletons().table[index as usize],
            index,
            tubes: [(0, 0); 2],
            n_tubes: (code >> SKELETON_BITS & 3) as usize,
        };
        for i in 0..t.n_tubes {
            let tube = code >> (SKELETON_BITS + 2 + 4 * i as u32);
            t.tubes[i] = ((tube & 3) as usize, (tube >> 2 & 3) as usize);
        }
        t
    }
}

/// Bits of a skeleton's index in a [`Decision`] (the table holds fewer skeletons).
const SKELETON_BITS: u32 = 14;

const NO_LOOP: u8 = u8::MAX;

/// The loops of a cell and its patches, which the case and the decisions of its ambiguous faces
/// fix; the interior, decided from the values, only adds tunnels between patches.
#[derive(Debug, Clone)]
struct Skeleton {
    /// Loop vertices (crossed edges) in order, loop after loop.
    edges: [u8; 12],
    /// Start of each loop in `edges` (loop l spans `start[l]..start[l + 1]`).
    start: [u8; MAX_LOOPS + 1],
    n_loops: u8,
    /// Bit l: loop l crosses one face twice.
    twice: u8,
    /// What the loops make when each spans a disk (no tunnel): a fan, or a centroid fan.
    disks: CellCounts,
    /// When no loop crosses a face twice, those disks' triangles as edge triples (`disks`
    /// counts them): each loop's fan from its first vertex, loop after loop.
    fans: [[u8; 3]; 10],
    /// The patches of the inside class, then of the outside class, when a tunnel can join two.
    classes: [ClassPatches; 2],
}

/// The patches of one class on a cell's surface, and the loops a tunnel between two would join.
#[derive(Debug, Clone, Copy, Default)]
struct ClassPatches {
    /// Patches (0 when fewer than two loops: no tunnel possible).
    n: u8,
    /// Each patch's smallest corner, in corner order.
    roots: [u8; 4],
    /// For patches i < j: the loops bounding them that a tunnel joins (`NO_LOOP`: none).
    tube_loops: [[[u8; 2]; 4]; 4],
    /// Whether some pair has such loops (else the interior need not be swept).
    may_tube: bool,
}

impl Skeleton {
    fn loop_edges(&self, l: usize) -> &[u8] {
        &self.edges[self.start[l] as usize..self.start[l + 1] as usize]
    }

    /// What loop `l` makes as a disk: a fan from its first vertex, or around a centroid when it
    /// crosses a face twice.
    fn disk_counts(&self, l: usize) -> CellCounts {
        let n = self.loop_edges(l).len() as u16;
        if self.twice >> l & 1 == 1 {
            CellCounts { triangles: n, placed: 1, ..Default::default() }
        } else {
            CellCounts { triangles: n - 2, ..Default::default() }
        }
    }

    /// The skeleton of `case` when the saddle of each ambiguous face `f` is inside iff bit `f` of
    /// `centre_in` is set.
    fn new(case: u8, centre_in: u8) -> Self {
        let inside = |c: u8| case >> c & 1 == 1;
        // 1. Face segments: next[exit edge] = entry edge; patches of corners joined on the faces.
        let mut next = [NO_EDGE; 12];
        let mut patches = UnionFind::<[u32; 8]>::fixed();
        for [a, b] in EDGE_CORNERS {
            if inside(a) == inside(b) {
                patches.union(a as usize, b as usize);
            }
        }
        for f in 0..6 {
            let cs = FACE_CORNERS[f];
            let mut xs = [(0u8, false); 4];
            let mut n = 0;
            for i in 0..4 {
                let (p, q) = (cs[i], cs[(i + 1) % 4]);
                if inside(p) != inside(q) {
                    xs[n] = (FACE_EDGES[f][i], inside(p));
                    n += 1;
                }
            }
            match n {
                2 => {
                    let (exit, entry) = if xs[0].1 { (xs[0].0, xs[1].0) } else { (xs[1].0, xs[0].0) };
                    next[exit as usize] = entry;
                }
                4 => {
                    let centre_in = centre_in >> f & 1 == 1;
                    for i in 0..4 {
                        if xs[i].1 {
                            let j = if centre_in { (i + 1) % 4 } else { (i + 3) % 4 };
                            next[xs[i].0 as usize] = xs[j].0;
                        }
                    }
                    // The diagonal of the centre's class is joined across the face.
                    let [p, q, r, s] = cs;
                    if inside(p) == centre_in {
                        patches.union(p as usize, r as usize);
                    } else {
                        patches.union(q as usize, s as usize);
                    }
                }
                _ => {}
            }
        }
        // 2. Loops.
        let mut t = Skeleton {
            edges: [0; 12],
            start: [0; MAX_LOOPS + 1],
            n_loops: 0,
            twice: 0,
            disks: CellCounts::default(),
            fans: [[0; 3]; 10],
            classes: [ClassPatches::default(); 2],
        };
        let mut seen = [false; 12];
        let mut n = 0;
        for e0 in 0..12u8 {
            if next[e0 as usize] == NO_EDGE || seen[e0 as usize] {
                continue;
            }
            let l = t.n_loops as usize;
            t.start[l] = n;
            let mut faces = 0u8;
            let mut e = e0;
            while !seen[e as usize] {
                seen[e as usize] = true;
                t.edges[n as usize] = e;
                n += 1;
                let nx = next[e as usize];
                if nx == NO_EDGE {
                    break; // unreachable for consistent faces: every crossed edge exits one face
                }
                let f = common_face(e, nx);
                if faces & (1 << f) != 0 {
                    t.twice |= 1 << l;
                }
                faces |= 1 << f;
                e = nx;
            }
            t.n_loops += 1;
            t.start[t.n_loops as usize] = n;
        }
        for l in 0..t.n_loops as usize {
            let c = t.disk_counts(l);
            t.disks.triangles += c.triangles;
            t.disks.placed += c.placed;
        }
        if t.twice == 0 {
            // 12 edges make at most 10 fan triangles (one loop of 12).
            let (edges, start, mut n) = (t.edges, t.start, 0);
            for l in 0..t.n_loops as usize {
                let e = &edges[start[l] as usize..start[l + 1] as usize];
                for i in 1..e.len() - 1 {
                    t.fans[n] = [e[0], e[i + 1], e[i]];
                    n += 1;
                }
            }
        }
        if t.n_loops < 2 {
            return t;
        }
        // 3. Where tunnels may run: each class's patches, and for each pair the loops bounding
        // them; prefer two that also bound one patch of the other class (the tube runs through it).
        let side_corner = |l: usize, class_inside: bool| -> usize {
            let [a, b] = EDGE_CORNERS[t.edges[t.start[l] as usize] as usize];
            (if inside(a) == class_inside { a } else { b }) as usize
        };
        for (class, class_inside) in [true, false].into_iter().enumerate() {
            let mut cp = ClassPatches { tube_loops: [[[NO_LOOP; 2]; 4]; 4], ..Default::default() };
            for c in 0..8u8 {
                let r = patches.find(c as usize) as u8;
                if inside(c) == class_inside && !cp.roots[..cp.n as usize].contains(&r) {
                    cp.roots[cp.n as usize] = r;
                    cp.n += 1;
                }
            }
            for i in 0..cp.n as usize {
                for j in i + 1..cp.n as usize {
                    let (p, q) = (cp.roots[i] as usize, cp.roots[j] as usize);
                    let mut best: Option<(usize, usize, bool)> = None;
                    for l0 in 0..t.n_loops as usize {
                        for l1 in 0..t.n_loops as usize {
                            if patches.find(side_corner(l0, class_inside)) != p
                                || patches.find(side_corner(l1, class_inside)) != q
                            {
                                continue;
                            }
                            let shared = patches.find(side_corner(l0, !class_inside))
                                == patches.find(side_corner(l1, !class_inside));
                            if best.is_none_or(|b| shared && !b.2) {
                                best = Some((l0, l1, shared));
                            }
                        }
                    }
                    if let Some((l0, l1, _)) = best {
                        cp.tube_loops[i][j] = [l0 as u8, l1 as u8];
                        cp.may_tube = true;
                    }
                }
            }
            t.classes[class] = cp;
        }
        t
    }
}

/// The ambiguous faces of one case, and where its skeletons start in [`Skeletons::table`].
#[derive(Debug, Clone, Copy, Default)]
struct CaseFaces {
    first: u32,
    ambiguous: [u8; 6],
    n_ambiguous: u8,
}

/// Every skeleton: per case, one for each combination of its ambiguous faces' decisions (bit i
/// of the index: the saddle of its i-th ambiguous face is inside).
struct Skeletons {
    faces: [CaseFaces; 256],
    table: Vec<Skeleton>,
}

fn skeletons() -> &'static Skeletons {
    static SKELETONS: std::sync::OnceLock<Skeletons> = std::sync::OnceLock::new();
    SKELETONS.get_or_init(|| {
        let mut faces = [CaseFaces::default(); 256];
        let mut table = Vec::new();
        for case in 0..=255u8 {
            let cf = &mut faces[case as usize];
            cf.first = table.len() as u32;
            for (f, cs) in FACE_CORNERS.iter().enumerate() {
                let [p, q, r, s] = cs.map(|c| case >> c & 1 == 1);
                if p == r && q == s && p != q {
                    cf.ambiguous[cf.n_ambiguous as usize] = f as u8;
                    cf.n_ambiguous += 1;
                }
            }
            for bits in 0..1u32 << cf.n_ambiguous {
                let centre_in = (0..cf.n_ambiguous as usize)
                    .filter(|&i| bits >> i & 1 == 1)
                    .fold(0u8, |m, i| m | 1 << cf.ambiguous[i]);
                table.push(Skeleton::new(case, centre_in));
            }
        }
        assert!(table.len() <= 1 << SKELETON_BITS, "{} skeletons", table.len());
        Skeletons { faces, table }
    })
}

/// The face shared by two edges that follow each other on a loop.
#[inline]
pub(crate) fn common_face(a: u8, b: u8) -> u8 {
    let [f0, f1] = EDGE_FACES[a as usize];
    if EDGE_FACES[b as usize].contains(&f0) {
        f0
    } else {
        f1
    }
}

/// A height where a horizontal slice's topology can change: vertical edges crossing iso (`zero`:
/// the slice corners exactly at iso there) or the slice's saddle passing through iso.
#[derive(Debug, Clone, Copy)]
struct Event {
    t: f64,
    zero: u8,
    saddle_at_iso: bool,
}

/// A computed root of the slice saddle this close to a vertical crossing where the saddle is
/// exactly at iso is that crossing (the crossing is exact, the root rounded).
const ROOT_MERGE: f64 = 1e-9;

/// Which corners of one class are connected inside the closed cell (through faces or interior),
/// by a sweep over horizontal slices (see the module documentation).
///
/// The sweep samples the middle of every interval between events *and the events themselves*:
/// with ties outside, the outside class is closed, and two outside regions touching at one point
/// (a slice saddle reaching iso without crossing it, a double root) are joined there only, as a
/// face saddle exactly at iso joins the outside corners. Integer data makes these ties (issue 10).
// Out of line: a few percent of the value-decided cells need the sweep even on noise, and inlined
// into `of_case_with` its set-up was paid on every call (9 % of mc33's instructions on white noise).
#[inline(never)]
fn interior_components(d: &[f32; 8], class_inside: bool) -> Interior {
    let member = |v: f64| (v < 0.0) == class_inside;
    let b: [f64; 4] = [0, 1, 2, 3].map(|c| d[c] as f64);
    let top: [f64; 4] = [4, 5, 6, 7].map(|c| d[c] as f64);
    let delta: [f64; 4] = [0, 1, 2, 3].map(|c| top[c] - b[c]);
    let mut crossing: [Option<f64>; 4] = [0, 1, 2, 3].map(|c| {
        let t = b[c] / (b[c] - top[c]);
        ((b[c] < 0.0) != (top[c] < 0.0) && t > 0.0 && t < 1.0).then_some(t)
    });
    let always_zero = (0..4).filter(|&c| b[c] == 0.0 && top[c] == 0.0).fold(0u8, |m, c| m | 1 << c);
    // PASS 1: vertical crossings, grouped when simultaneous. Equal heights are found exactly:
    // b_a / (b_a − top_a) = b_c / (b_c − top_c) ⇔ b_a·top_c = b_c·top_a, products of f32 exact in f64.
    let mut events = [Event { t: 0.0, zero: 0, saddle_at_iso: false }; 6];
    let mut ne = 0;
    for c in 0..4 {
        let Some(t) = crossing[c] else { continue };
        let same = events[..ne].iter().position(|e| {
            let a = e.zero.trailing_zeros() as usize;
            b[a] * top[c] == b[c] * top[a]
        });
        match same {
            Some(i) => {
                events[i].zero |= 1 << c;
                crossing[c] = Some(events[i].t); // one height for the group, whatever rounding
            }
            None => {
                events[ne] = Event { t, zero: 1 << c, saddle_at_iso: false };
                ne += 1;
            }
        }
    }
    // The slice saddle numerator g(t) = e0·e3 − e1·e2 is exactly 0 at a crossing where both
    // diagonals have a corner at iso.
    for e in &mut events[..ne] {
        let z = e.zero | always_zero;
        e.saddle_at_iso = z & 0b1001 != 0 && z & 0b0110 != 0;
    }
    // PASS 2: the roots of g in (0, 1), unless they are such a crossing.
    let qa = delta[0] * delta[3] - delta[1] * delta[2];
    let qb = b[0] * delta[3] + delta[0] * b[3] - b[1] * delta[2] - delta[1] * b[2];
    let qc = b[0] * b[3] - b[1] * b[2];
    let g_vanishes = qa == 0.0 && qb == 0.0 && qc == 0.0;
    let mut roots = [f64::NAN; 2];
    if qa == 0.0 {
        if qb != 0.0 {
            roots[0] = -qc / qb;
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc == 0.0 {
            roots[0] = -qb / (2.0 * qa);
        } else if disc > 0.0 {
            // Stable roots: q = −(b + sign(b)·√disc)/2, roots q/a and c/q.
            let sq = disc.sqrt();
            let q = -0.5 * (qb + if qb >= 0.0 { sq } else { -sq });
            roots[0] = q / qa;
            if q != 0.0 {
                roots[1] = qc / q;
            }
        }
    }
    for r in roots {
        let at_crossing = events[..ne].iter().any(|e| e.saddle_at_iso && (e.t - r).abs() <= ROOT_MERGE);
        if r > 0.0 && r < 1.0 && !at_crossing {
            events[ne] = Event { t: r, zero: 0, saddle_at_iso: true };
            ne += 1;
        }
    }
    let ev = &mut events[..ne];
    ev.sort_by(|x, y| x.t.total_cmp(&y.t));
    // PASS 3: samples t = 0, the middle of every interval, every event, t = 1.
    let mut samples = [(0.0f64, 0u8, false); 2 * 6 + 3];
    let mut ns = 1;
    let mut prev = 0.0;
    for e in ev.iter() {
        if e.t > prev {
            samples[ns] = (0.5 * (prev + e.t), 0, g_vanishes);
            ns += 1;
            prev = e.t;
        }
        samples[ns] = (e.t, e.zero, e.saddle_at_iso || g_vanishes);
        ns += 1;
    }
    samples[ns] = (0.5 * (prev + 1.0), 0, g_vanishes);
    samples[ns + 1] = (1.0, 0, false);
    ns += 2;
    // The slice corner values at height t: a corner at iso exactly at its own crossing, else on
    // the side of iso its crossing (or its edge, when it does not cross) says, whatever rounding.
    let slice = |t: f64, zero: u8| -> [f64; 4] {
        std::array::from_fn(|c| {
            if t == 0.0 {
                return b[c];
            }
            if t == 1.0 {
                return top[c];
            }
            let v = b[c] + t * delta[c];
            let below = match crossing[c] {
                _ if zero >> c & 1 == 1 => return 0.0,
                Some(tc) if t == tc => return 0.0,
                Some(tc) => (if t < tc { b[c] } else { top[c] }) < 0.0,
                // No crossing inside (0, 1): one class throughout, the one at both ends, or
                // the non-zero end's when the other end is exactly at iso.
                None => (if b[c] == 0.0 { top[c] } else { b[c] }) < 0.0,
            };
            if below {
                v.min(-f64::MIN_POSITIVE)
            } else {
                v.max(0.0)
            }
        })
    };
    let mut uf = UnionFind::<[u32; 4 * (2 * 6 + 3)]>::fixed();
    let mut last = [0.0f64; 4];
    for (s, &(t, zero, saddle_at_iso)) in samples[..ns].iter().enumerate() {
        let e = slice(t, zero);
        let node = |c: usize| 4 * s + c;
        for (p, q) in [(0, 1), (0, 2), (1, 3), (2, 3)] {
            if member(e[p]) && member(e[q]) {
                uf.union(node(p), node(q));
            }
        }
        // Diagonal pattern: (0, 3) against (1, 2); slice corners counter-clockwise are 0, 1, 3, 2.
        let diag_a = member(e[0]) && member(e[3]) && !member(e[1]) && !member(e[2]);
        let diag_b = member(e[1]) && member(e[2]) && !member(e[0]) && !member(e[3]);
        if diag_a || diag_b {
            let centre_in = !saddle_at_iso && saddle_inside(e[0], e[1], e[3], e[2]);
            if centre_in == class_inside {
                if diag_a {
                    uf.union(node(0), node(3));
                } else {
                    uf.union(node(1), node(2));
                }
            }
        }
        if s > 0 {
            for c in 0..4 {
                if member(last[c]) && member(e[c]) {
                    uf.union(node(c) - 4, node(c));
                }
            }
        }
        last = e;
    }
    Interior { uf, top: 4 * (ns - 1) }
}

/// Heights (fractions of the cell) within which [`interior_cannot_join`] leaves the decision to the
/// sweep: far above the rounding of the crossing heights it compares (a few ulps of 1).
const PRETEST_MARGIN: f64 = 1e-9;

/// A cheap proof that the slice sweep of `class_inside` joins no two patches of the cell's surface
/// (false: no proof, sweep). The sweep joins corners through the interior only across the diagonal
/// of a slice strictly inside the cell, where the slice's two corners of the class lie on one
/// diagonal and its saddle is of the class (elsewhere it follows the cell's faces and edges, which
/// the skeleton's patches already join). Each vertical edge crosses iso at most once, so the
/// heights where its slice corner may be of the class form one closed range, as do those where it
/// may not: a diagonal pattern can only occur where four such ranges meet, and there its saddle is
/// of the class only where the slice saddle numerator `g(t) = e0·e3 − e1·e2` has one sign (≥ 0 for
/// corners 0 and 3 of the class, ≤ 0 for 1 and 2; `saddle_inside`). The proof holds when the
/// ranges miss each other or `g` keeps the other sign on their meeting, both by a margin far above
/// rounding; ties at iso (a corner at iso, equal crossing heights on a face, `g` at 0) fall back.
///
/// It also asks the sweep's side faces to agree with the face deciders: a face with its class on a
/// diagonal is joined by the sweep where its two vertical crossings overlap, so they must be apart.
// Out of line too: inlined into `of_case_with`'s loop over classes it ran about 50 % more
// instructions (callgrind, white noise).
#[inline(never)]
fn interior_cannot_join(d: &[f32; 8], class_inside: bool) -> bool {
    const NEVER: (f64, f64) = (2.0, -1.0);
    let b: [f64; 4] = [0, 1, 2, 3].map(|c| d[c] as f64);
    let top: [f64; 4] = [4, 5, 6, 7].map(|c| d[c] as f64);
    let (mut member, mut other) = ([(0.0f64, 1.0f64); 4], [(0.0f64, 1.0f64); 4]);
    let mut crossing = [f64::NAN; 4];
    for c in 0..4 {
        let changes = (b[c] < 0.0) != (top[c] < 0.0);
        let t = b[c] / (b[c] - top[c]); // the sweep's crossing height, rounded alike
        if changes && t > 0.0 && t < 1.0 {
            crossing[c] = t;
            let (before, after) = ((0.0, t), (t, 1.0));
            (member[c], other[c]) = if (b[c] < 0.0) == class_inside { (before, after) } else { (after, before) };
        } else if changes {
            return false; // an end at iso: the class changes at the cell's face (ties)
        } else if ((if b[c] == 0.0 { top[c] } else { b[c] }) < 0.0) == class_inside {
            other[c] = NEVER;
        } else {
            member[c] = NEVER;
        }
    }
    for (p, q) in [(0, 1), (1, 3), (3, 2), (2, 0)] {
        if (b[p] < 0.0) != (b[q] < 0.0) && (crossing[p] - crossing[q]).abs() <= PRETEST_MARGIN {
            return false;
        }
    }
    let scale = d.iter().fold(0.0f64, |m, &v| m.max((v as f64).abs()));
    let tol = PRETEST_MARGIN * scale * scale;
    let g = |t: f64| {
        let e: [f64; 4] = std::array::from_fn(|c| b[c] + t * (top[c] - b[c]));
        e[0] * e[3] - e[1] * e[2]
    };
    let delta: [f64; 4] = std::array::from_fn(|c| top[c] - b[c]);
    let qa = delta[0] * delta[3] - delta[1] * delta[2];
    let qb = b[0] * delta[3] + delta[0] * b[3] - b[1] * delta[2] - delta[1] * b[2];
    // The class on diagonal (0, 3): joined where g ≥ 0; on (1, 2): where g ≤ 0.
    for ([p, q], [r, s], sign) in [([0, 3], [1, 2], -1.0), ([1, 2], [0, 3], 1.0)] {
        let ranges = [member[p], member[q], other[r], other[s]];
        let lo = ranges.iter().fold(0.0f64, |m, x| m.max(x.0));
        let hi = ranges.iter().fold(1.0f64, |m, x| m.min(x.1));
        if lo > hi + PRETEST_MARGIN {
            continue; // no slice with that pattern
        }
        let (lo, hi) = ((lo.min(hi) - PRETEST_MARGIN).max(0.0), (lo.max(hi) + PRETEST_MARGIN).min(1.0));
        let vertex = if qa != 0.0 { -qb / (2.0 * qa) } else { f64::NAN };
        let least = if vertex > lo && vertex < hi { (sign * g(vertex)).min(sign * g(lo)) } else { sign * g(lo) };
        if !(least.min(sign * g(hi)) > tol) {
            return false;
        }
    }
    true
}

/// The connectivity [`interior_components`] found: slice corners over the samples.
struct Interior {
    uf: UnionFind<[u32; 4 * (2 * 6 + 3)]>,
    /// Node of the top slice's corner 0.
    top: usize,
}

impl Interior {
    /// Whether cell corners `a` and `b`, both of the swept class, are connected in the cell.
    fn joined(&mut self, a: usize, b: usize) -> bool {
        let node = |c: usize| if c < 4 { c } else { self.top + c - 4 };
        let (na, nb) = (node(a), node(b));
        self.uf.find(na) == self.uf.find(nb)
    }
}

/// Cell coordinates of the crossing on edge `e` (linear in the corner values).
#[inline]
fn edge_point(d: &[f32; 8], e: u8) -> [f32; 3] {
    let [a, b] = EDGE_CORNERS[e as usize];
    let (da, db) = (d[a as usize], d[b as usize]);
    let t = if da == db { 0.5 } else { (da / (da - db)).clamp(0.0, 1.0) };
    let mut p = CORNER_OFFSETS[a as usize].map(|x| x as f32);
    p[(e / 4) as usize] += t;
    p
}

fn centroid(d: &[f32; 8], edges: &[u8]) -> [f32; 3] {
    let mut c = [0.0f32; 3];
    for &e in edges {
        let p = edge_point(d, e);
        for a in 0..3 {
            c[a] += p[a];
        }
    }
    c.map(|x| x / edges.len() as f32)
}

fn dist2(p: [f32; 3], q: [f32; 3]) -> f32 {
    (0..3).map(|a| (p[a] - q[a]) * (p[a] - q[a])).sum()
}

/// Joins loops `la` and `lb` (each oriented with the inside on the right, seen from outside the
/// cell) by a band of triangles: an annulus whose boundary is the two loops.
///
/// A chord of the band whose two ends lie on one face of the cell (both loops cross an ambiguous
/// face the saddle separates) is split at a private vertex inside the cell: the neighbour across
/// that face may hold a tunnel through the same face and pick the same chord, and a chord on a
/// face would then carry four triangles (issue 10, seen on CT scans where such cells pair up).
fn band<O: Out>(out: &mut O, d: &[f32; 8], la: &[u8], lb: &[u8], start: usize) {
    band_triangles(d, la, lb, start, |p, q, r| {
        let chord = |out: &mut O, x: u8, y: u8| common_face_of(x, y).map(|f| out.chord(x, y, f));
        let (mqr, mrp) = (chord(out, q, r), chord(out, r, p));
        let (vp, vq, vr) = (out.edge(p), out.edge(q), out.edge(r));
        match (mqr, mrp) {
            (None, None) => out.triangle([vp, vq, vr]),
            (Some(m1), None) => {
                out.triangle([vp, vq, m1]);
                out.triangle([vp, m1, vr]);
            }
            (None, Some(m2)) => {
                out.triangle([vp, vq, m2]);
                out.triangle([vq, vr, m2]);
            }
            (Some(m1), Some(m2)) => {
                out.triangle([m1, vr, m2]);
                out.triangle([vp, vq, m1]);
                out.triangle([vp, m1, m2]);
            }
        }
    });
}

/// The band's triangles before its face chords are split, in order: `(p, q, r)` for loop edge
/// p → q and apex r (its chords are q → r and r → p), crossed cube edges all three; the zipper
/// starts where [`Lay`]'s `start` says.
fn band_triangles(d: &[f32; 8], la: &[u8], lb: &[u8], start: usize, mut triangle: impl FnMut(u8, u8, u8)) {
    // Walk A = reverse(la) forward and B = reverse(lb) backward (see the module docs for the
    // orientation argument): triangles (a_i, a_i+1, b_j) and (b_j−1, b_j, a_i).
    let (m, n) = (la.len(), lb.len());
    let (mut a, mut b) = ([0u8; 12], [0u8; 12]);
    let (mut pa, mut pb) = ([[0.0f32; 3]; 12], [[0.0f32; 3]; 12]);
    for (i, &e) in la.iter().rev().enumerate() {
        a[i] = e;
        pa[i] = edge_point(d, e);
    }
    for (i, &e) in lb.iter().rev().enumerate() {
        b[i] = e;
        pb[i] = edge_point(d, e);
    }
    // Start `start`: A's vertex start mod m, paired with B's vertex closest to it shifted by
    // start / m (start 0: A's first vertex and its closest partner).
    let i0 = start % m;
    let closest = (0..n).min_by(|&x, &y| dist2(pa[i0], pb[x]).total_cmp(&dist2(pa[i0], pb[y]))).unwrap_or(0);
    let j0 = (closest + start / m) % n;
    let (mut i, mut j) = (i0, j0 + n); // j counts down; indices mod n
    let (mut da, mut db) = (0, 0);
    // Steps taken around the current b (by A) and around the current a (by B): a full turn of
    // one loop around a single vertex of the other would repeat a chord (a non-manifold edge).
    let (mut run_a, mut run_b) = (0, 0);
    while da < m || db < n {
        let (ai, ai1) = (i % m, (i + 1) % m);
        let (bj, bj1) = (j % n, (j + n - 1) % n);
        let can_a = da < m && run_a + 1 < m;
        let can_b = db < n && run_b + 1 < n;
        let advance_a = match (can_a, can_b) {
            (true, true) => dist2(pa[ai1], pb[bj]) <= dist2(pa[ai], pb[bj1]),
            (a, _) => a,
        };
        if advance_a {
            triangle(a[ai], a[ai1], b[bj]);
            i += 1;
            da += 1;
            run_a += 1;
            run_b = 0;
        } else {
            triangle(b[bj1], b[bj], a[ai]);
            j -= 1;
            db += 1;
            run_b += 1;
            run_a = 0;
        }
    }
}

/// The face holding both crossed edges `x` and `y`, if any.
#[inline]
fn common_face_of(x: u8, y: u8) -> Option<u8> {
    let [f0, f1] = EDGE_FACES[x as usize];
    let other = EDGE_FACES[y as usize];
    [f0, f1].into_iter().find(|f| other.contains(f))
}

/// How close to the face its chord lies on a private band vertex may come, as a fraction of the
/// cell: strictly inside, so it never meets the neighbour's vertex or lies in the shared face.
const OFF_FACE_MIN_DEPTH: f32 = 1.0 / 16.0;

/// How far from its chord's midpoint towards the cell's centre a chord vertex goes, by rule: on
/// the interpolant (`None`: where the class first changes), else a fixed fraction of the way.
const CHORD_RULES: [Option<f32>; 5] = [None, Some(0.25), Some(0.125), Some(0.0), Some(0.5)];

/// Steps and bisections locating a private band vertex on the interpolant.
const OFF_FACE_STEPS: usize = 8;
const OFF_FACE_BISECTIONS: usize = 24;

/// The private vertex for the chord `x`–`y` on face `f`: on the way from the chord's midpoint to
/// the cell's centre, where the trilinear interpolant first changes class (the tube's wall behind
/// the chord), or half way when it does not; never closer to the face than `OFF_FACE_MIN_DEPTH`.
fn off_face_point(d: &[f32; 8], x: u8, y: u8, f: u8, rule: u8) -> [f32; 3] {
    let (px, py) = (edge_point(d, x), edge_point(d, y));
    let mid: [f32; 3] = std::array::from_fn(|a| 0.5 * (px[a] + py[a]));
    let at = |s: f32| -> [f32; 3] { std::array::from_fn(|a| mid[a] + s * (0.5 - mid[a])) };
    let class = |s: f32| trilinear(d, at(s)) < 0.0;
    let start = class(0.0);
    let mut s = 0.5;
    if let Some(fixed) = CHORD_RULES[rule as usize] {
        s = fixed;
    } else if let Some(k) = (1..=OFF_FACE_STEPS).find(|&k| class(k as f32 / OFF_FACE_STEPS as f32) != start) {
        let (mut lo, mut hi) = ((k - 1) as f32 / OFF_FACE_STEPS as f32, k as f32 / OFF_FACE_STEPS as f32);
        for _ in 0..OFF_FACE_BISECTIONS {
            let m = 0.5 * (lo + hi);
            if class(m) == start {
                lo = m;
            } else {
                hi = m;
            }
        }
        s = 0.5 * (lo + hi);
    }
    let mut p = at(s);
    let (axis, side) = ((f / 2) as usize, (f % 2) as f32);
    if (p[axis] - side).abs() < OFF_FACE_MIN_DEPTH {
        p[axis] = (side - OFF_FACE_MIN_DEPTH).abs();
    }
    p
}

/// The trilinear interpolant of the corner values at cell coordinates `p` ∈ [0, 1]³.
fn trilinear(d: &[f32; 8], p: [f32; 3]) -> f32 {
    (0..8)
        .map(|c| {
            let w: f32 = (0..3).map(|a| if (c >> a) & 1 == 1 { p[a] } else { 1.0 - p[a] }).product();
            w * d[c]
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use crate::extract::ProbeCell;

    /// Issue 11: the table the walker applies for the easy cases is exactly what the values would
    /// give, and `counts` is exactly what `process` makes, on random values of every case.
    #[test]
    fn issue_11_the_case_table_and_the_counts_agree_with_processing() {
        let mut seed = 0x33_c0de_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let (mut easy, mut fans) = (0, 0);
        for case in 0..=255u8 {
            for _ in 0..200 {
                let d: [f32; 8] = std::array::from_fn(|c| {
                    let m = 0.01 + (next() % 1000) as f32 / 100.0;
                    if case >> c & 1 == 1 {
                        -m
                    } else {
                        m
                    }
                });
                let mut general = ProbeCell::new([3, 4, 5], d);
                MarchingCubes33.general(&mut general);
                let mut processed = ProbeCell::new([3, 4, 5], d);
                MarchingCubes33.process(&mut processed);
                assert_eq!(processed.counts, general.counts, "case {case} {d:?}");
                let (counts, decision) = MarchingCubes33.counts(case, [3, 4, 5], || d);
                assert_eq!(counts, general.counts, "case {case}");
                let mut decided = ProbeCell::new([3, 4, 5], d);
                MarchingCubes33.process_decided(&mut decided, decision);
                assert_eq!((decided.counts, &decided.triangles), (general.counts, &general.triangles), "case {case}");
                match MarchingCubes33.case_triangles(case, false) {
                    Some(t) => {
                        assert_eq!(t, &general.triangles[..], "case {case} {d:?}");
                        assert_eq!(general.counts.placed, 0);
                    }
                    None => fans += decided_table_agrees(decision, &general),
                }
            }
            easy += usize::from(MarchingCubes33.case_triangles(case, false).is_some());
        }
        // 0 and 255 have nothing to tabulate; the ambiguous and two-patch cases go by values.
        assert_eq!(easy, 126, "easy cases");
        assert!(fans > 10_000, "{fans} value-decided cells applied from their skeleton's fans");
    }

    /// Issue 11: the triangles `decided_triangles` gives for `decision` (the walker applies them
    /// itself) are those `process_decided` made (`made`), and it gives them exactly when that
    /// cell has no tunnel and places no vertex. Returns 1 when it gave them.
    fn decided_table_agrees(decision: Decision, made: &ProbeCell) -> usize {
        let plain = CellTopology::of_decision(decision).n_tubes == 0 && made.counts.placed == 0;
        let table = MarchingCubes33.decided_triangles(decision);
        assert_eq!(table.is_some(), plain, "{decision:?}");
        if let Some(t) = table {
            assert_eq!(t, &made.triangles[..], "{decision:?}");
        }
        usize::from(plain)
    }

    use super::*;

    /// Issue 11: on integer cells (ties at iso, plateaus, simultaneous vertical crossings: what
    /// scans make), the count pass's counts and decision give exactly what `process` makes.
    #[test]
    fn issue_11_decided_cells_equal_processed_cells_on_integer_values() {
        let vals = [-3.0f32, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0];
        let (mut decided_cells, mut tubes, mut fans) = (0, 0, 0);
        // Every 11th code of 7⁸ (a stride prime to 7 gives every corner every value).
        for code in (0..7usize.pow(8)).step_by(11) {
            let mut c = code;
            let d: [f32; 8] = std::array::from_fn(|_| {
                let v = vals[c % 7];
                c /= 7;
                v
            });
            let case = crate::cube::case_of(&d);
            if MarchingCubes33.case_triangles(case, false).is_some() || case == 0 || case == 255 {
                continue;
            }
            let mut processed = ProbeCell::new([1, 2, 3], d);
            MarchingCubes33.process(&mut processed);
            let (counts, decision) = MarchingCubes33.counts(case, [1, 2, 3], || d);
            let mut decided = ProbeCell::new([1, 2, 3], d);
            MarchingCubes33.process_decided(&mut decided, decision);
            assert_eq!(counts, processed.counts, "{d:?}");
            assert_eq!((decided.counts, &decided.triangles), (processed.counts, &processed.triangles), "{d:?}");
            fans += decided_table_agrees(decision, &processed);
            let t = CellTopology::of(&d);
            let back = CellTopology::of_decision(decision);
            assert_eq!((back.index, back.tubes, back.n_tubes), (t.index, t.tubes, t.n_tubes), "{d:?}");
            decided_cells += 1;
            tubes += usize::from(t.n_tubes > 0);
        }
        assert!(decided_cells > 10_000 && tubes > 100, "{decided_cells} cells, {tubes} with a tube");
        assert!(fans > 1_000, "{fans} cells applied from their skeleton's fans");
    }

    /// Issue 11: where [`interior_cannot_join`] skips the slice sweep, the sweep joins no two
    /// patches of that class either, so the topology is the same; `(skipped, swept)` counted.
    fn pretest_agrees(d: [f32; 8], stats: &mut [usize; 3]) {
        let case = crate::cube::case_of(&d);
        let fast = CellTopology::of_case_with(case, &d, true);
        let swept = CellTopology::of_case_with(case, &d, false);
        assert_eq!((fast.index, fast.n_tubes, fast.tubes), (swept.index, swept.n_tubes, swept.tubes), "{d:?}");
        for (class, patches) in fast.skeleton.classes.iter().enumerate() {
            let n = patches.n as usize;
            if n < 2 || !patches.may_tube {
                continue;
            }
            if !interior_cannot_join(&d, class == 0) {
                stats[1] += 1;
                continue;
            }
            stats[0] += 1;
            let mut interior = interior_components(&d, class == 0);
            for i in 0..n {
                for j in i + 1..n {
                    let (p, q) = (patches.roots[i] as usize, patches.roots[j] as usize);
                    assert!(!interior.joined(p, q), "{d:?}: class {class}, patches {p} and {q} are joined inside");
                }
            }
        }
        stats[2] += usize::from(swept.n_tubes > 0);
    }

    #[test]
    fn issue_11_the_sweep_pretest_agrees_with_the_sweep_on_random_cells() {
        let mut seed = 0x5eed_0011_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut stats = [0; 3];
        for i in 0..400_000 {
            let d: [f32; 8] = std::array::from_fn(|_| {
                let u = (next() % 1_000_001) as f32 / 500_000.0 - 1.0;
                // Every other cell: a wide range of magnitudes, as CT values around iso.
                if i % 2 == 0 {
                    u
                } else {
                    u * u * u * 300.0
                }
            });
            pretest_agrees(d, &mut stats);
        }
        let [skipped, swept, tubes] = stats;
        assert!(skipped > 5 * swept && swept > 1000 && tubes > 1000, "{skipped} skipped, {swept} swept, {tubes} tubes");
    }

    #[test]
    fn issue_11_the_sweep_pretest_agrees_with_the_sweep_on_integer_cells() {
        // Ties at iso, equal crossing heights, slice and face saddles at iso (issue 10): every cell
        // with values in −2..=2, every 7th with −3..=3, and every 5th of integers 0..=6 less a
        // fractional iso (scans at a non-integer iso: no ties at iso, many equal crossing heights).
        let mut stats = [0; 3];
        let sets: [(&[f32], usize); 3] = [
            (&[-2.0, -1.0, 0.0, 1.0, 2.0], 1),
            (&[-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0], 7),
            (&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0].map(|v: f32| (v as f64 - 2.3184) as f32), 5),
        ];
        for (vals, stride) in sets {
            let k = vals.len();
            for code in (0..k.pow(8)).step_by(stride) {
                let mut c = code;
                let d: [f32; 8] = std::array::from_fn(|_| {
                    let v = vals[c % k];
                    c /= k;
                    v
                });
                pretest_agrees(d, &mut stats);
            }
        }
        // The issue-10 cells: slice saddles touching iso, a corner at iso, a CT head tunnel.
        for d in [
            [-1., -1., -1., 3., 2., -1., -1., 0.],
            [-1., 2., 0., -1., 0., -1., 1., 0.],
            [0., -1., -0.5, -2., -1., 0.25, 1., -2.],
            [56.0f32, 55.0, 43.0, 48.0, 52.0, 49.0, 54.0, 58.0].map(|v| (v as f64 - 52.2949) as f32),
        ] {
            pretest_agrees(d, &mut stats);
        }
        let [skipped, swept, tubes] = stats;
        assert!(skipped > 100_000 && swept > 10_000 && tubes > 1000, "{skipped} skipped, {swept} swept, {tubes} tubes");
    }

    #[test]
    fn the_face_decider_agrees_from_both_sides_and_every_start() {
        // The two cells of a face list its corners in opposite orders; any start corner.
        for vals in [[-1.0, 2.0, -3.0, 0.5], [1.0, -2.0, 3.0, -0.5], [-1.0, 1.0, -1.0, 1.0], [-2.0, 1.0, -0.5, 1.0]] {
            let [p, q, r, s] = vals.map(|x: f64| x);
            let want = saddle_inside(p, q, r, s);
            assert_eq!(saddle_inside(q, r, s, p), want);
            assert_eq!(saddle_inside(p, s, r, q), want, "reversed order");
            assert_eq!(saddle_inside(s, r, q, p), want, "reversed, other start");
        }
        // A saddle exactly at iso is outside (ties outside).
        assert!(!saddle_inside(-1.0, 1.0, -1.0, 1.0));
        assert!(saddle_inside(-2.0, 1.0, -1.0, 1.0));
    }

    #[test]
    fn issue_10_face_chords_of_a_tunnel_get_a_private_vertex_on_the_interpolant() {
        // https://isoforge/issues/10 — a 10.1.2 cell of the CT head (iso 52.2949): both loops of
        // the tube cross the faces x = 0 and x = 1, whose saddles separate them.
        let d = [56.0f32, 55.0, 43.0, 48.0, 52.0, 49.0, 54.0, 58.0].map(|v| (v as f64 - 52.2949) as f32);
        let t = CellTopology::of(&d);
        assert_eq!((t.n_loops(), t.n_tubes), (2, 1));
        let (a, b) = (t.loop_edges(t.tubes[0].0), t.loop_edges(t.tubes[0].1));
        let mut on_faces = 0;
        for &x in a {
            for &y in b {
                let Some(f) = common_face_of(x, y) else { continue };
                on_faces += 1;
                let p = off_face_point(&d, x, y, f, 0);
                let depth = (p[(f / 2) as usize] - (f % 2) as f32).abs();
                assert!((OFF_FACE_MIN_DEPTH..=0.5).contains(&depth), "chord {x}–{y}: {p:?} on face {f}");
                assert!(trilinear(&d, p).abs() < 1e-4, "chord {x}–{y}: {p:?} is off the interpolant");
            }
        }
        assert_eq!(on_faces, 8, "two faces, 2 × 2 chords each");
    }

    #[test]
    fn issue_10_small_integer_cells_have_at_most_one_tube() {
        // https://isoforge/issues/10 — every cell with values in −3..=3 (ties at iso included)
        // and in the tie set of `tests/topology.rs`: a loop in two tubes would get two bands
        // (four triangles on its edges). Three patches of one class joined through the interior
        // would need that; the interpolant never does it, and the tie rules must not either.
        for vals in [[-3.0f32, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0], [-2.0, -1.0, -0.5, 0.0, 0.25, 1.0, 2.0]] {
            for code in 0..7usize.pow(8) {
                let mut c = code;
                let d: [f32; 8] = std::array::from_fn(|_| {
                    let v = vals[c % 7];
                    c /= 7;
                    v
                });
                let t = CellTopology::of(&d);
                assert!(t.n_tubes <= 1, "{d:?}: {} tubes", t.n_tubes);
            }
        }
    }

    #[test]
    fn a_body_diagonal_pair_is_joined_only_through_the_interior() {
        // Case 4: corners 0 and 7 inside. Deep enough, they meet in the middle (4.1.2).
        let tube = [-1.0, 0.2, 0.2, 0.2, 0.2, 0.2, 0.2, -1.0];
        let caps = [-0.1, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -0.1];
        assert_eq!(CellTopology::of(&tube).n_tubes, 1);
        assert_eq!(CellTopology::of(&caps).n_tubes, 0);
        assert_eq!(CellTopology::of(&tube).n_loops(), 2);
    }

    /// Issue 49: the bunny CT's two tunnel cells whose bands crossed themselves (14 pairs of
    /// triangles, BENCHMARKS §17.2): the default lay folds, the lay chosen does not.
    #[test]
    fn issue_49_the_bunny_tunnel_cells_are_laid_without_folds() {
        let iso = 988.37f32;
        for (values, folded) in [
            ([1026.0f32, 1085.0, 957.0, 803.0, 978.0, 1091.0, 998.0, 895.0], 11),
            ([978.0, 1091.0, 998.0, 895.0, 830.0, 997.0, 1051.0, 1014.0], 3),
        ] {
            let d = values.map(|v| v - iso);
            let topo = CellTopology::of(&d);
            assert_eq!(topo.n_tubes, 1, "{values:?}: a tunnel cell");
            assert_eq!(Sketch::of(&topo, 0, &d, Lay::default()).folds(), folded, "{values:?}: the default lay");
            let lay = Lay::unfolded(&topo, 0, &d);
            assert_ne!(lay, Lay::default());
            assert_eq!(Sketch::of(&topo, 0, &d, lay).folds(), 0, "{values:?}: laid as {lay:?}");
            // What the cell emits is what the sketch counted.
            let mut probe = ProbeCell::new([0; 3], d);
            MarchingCubes33.general(&mut probe);
            assert_eq!(probe.counts, Sketch::of(&topo, 0, &d, lay).counts());
            let (counts, _) = MarchingCubes33.counts(crate::cube::case_of(&d), [0; 3], || d);
            assert_eq!(counts, probe.counts);
        }
    }
}
