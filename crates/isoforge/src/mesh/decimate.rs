//! Decimation: edge collapses ordered by the quadric error metric \[Garland97\], each one refused
//! unless it keeps the mesh's guarantees.
//!
//! **Guarantees** (each collapse is checked; a refused one is retried only after a collapse
//! next to it changes its neighbourhood):
//! - connectivity: no collapse violates the link condition \[Dey99\] (the common neighbours of the
//!   edge's ends are exactly the two vertices opposite it), so a manifold stays manifold and keeps
//!   its genus; no closed component drops below 4 vertices (a tetrahedron), so none vanishes;
//!   vertices on boundary or non-manifold edges, and those whose triangles form several fans,
//!   never move (boundary edges, such as those on the volume's faces, are kept exactly);
//! - geometry: no triangle next to a collapse turns its normal by more than
//!   [`max_normal_turn_deg`](DecimateOptions::max_normal_turn_deg) (no fold-over), none gets zero
//!   area, none gets a shape below [`min_shape`](DecimateOptions::min_shape) unless the triangles it
//!   replaces were already worse;
//! - error: with [`max_error`](DecimateOptions::max_error), every vertex of the input lies within
//!   that distance of the output surface (each input vertex is assigned to a triangle within the
//!   bound, and a collapse is refused unless every vertex assigned to the triangles it changes is
//!   within the bound of one of the new ones), and every vertex of the output within that distance
//!   of the input surface (a moved vertex must be near the input triangles around the vertices
//!   assigned to its triangles). Points inside output triangles are not bounded: across a groove
//!   narrower than the bound a triangle may span it.
//!
//! Quads are split into triangles first (the output is triangles); normals, when the input has
//! them, are recomputed from the faces.

use std::cmp::Ordering;

use super::Mesh;
use crate::error::{Error, Result};
use crate::math::UnionFind;

/// How far to decimate (see [`decimate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DecimateOptions {
    /// Fraction of the triangles to remove, in [0, 1] (0.9 keeps a tenth); `None`: as many as
    /// the error bound and the guards allow.
    pub reduction: Option<f64>,
    /// Every input vertex stays within this distance (world units) of the output surface;
    /// `None`: no bound (only the guards).
    pub max_error: Option<f64>,
    /// No collapse turns a neighbouring triangle's normal by more than this many degrees, in
    /// (0, 90] (90: only fold-overs are refused). Default 60.
    pub max_normal_turn_deg: f64,
    /// Smallest triangle shape `4√3 · area / (sum of squared sides)` (1 equilateral, 0
    /// degenerate) a collapse may create, unless the triangles it replaces were worse. Default 0.05.
    pub min_shape: f64,
}

impl Default for DecimateOptions {
    fn default() -> Self {
        DecimateOptions { reduction: None, max_error: None, max_normal_turn_deg: 60.0, min_shape: 0.05 }
    }
}

impl DecimateOptions {
    /// Remove the fraction `r` of the triangles.
    pub fn reduction(r: f64) -> Self {
        DecimateOptions { reduction: Some(r), ..Self::default() }
    }

    /// As many collapses as keep every input vertex within `e` of the output surface.
    pub fn max_error(e: f64) -> Self {
        DecimateOptions { max_error: Some(e), ..Self::default() }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the first value out of its range, or when neither a
    /// reduction nor an error bound is given.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| Err(Error::InvalidInput(what));
        if let Some(r) = self.reduction {
            if !(0.0..=1.0).contains(&r) {
                return bad(format!(
                    "decimation: reduction {r} must lie in [0, 1] (the fraction of triangles removed)"
                ));
            }
        }
        if let Some(e) = self.max_error {
            if !(e.is_finite() && e >= 0.0) {
                return bad(format!("decimation: error bound {e} must be a finite number ≥ 0"));
            }
        }
        if self.reduction.is_none() && self.max_error.is_none() {
            return bad("decimation: give a reduction, an error bound or both".into());
        }
        if !(self.max_normal_turn_deg > 0.0 && self.max_normal_turn_deg <= 90.0) {
            return bad(format!("decimation: normal turn {}° must lie in (0, 90]", self.max_normal_turn_deg));
        }
        if !(0.0..=1.0).contains(&self.min_shape) {
            return bad(format!("decimation: shape bound {} must lie in [0, 1]", self.min_shape));
        }
        Ok(())
    }
}

/// Why collapses were refused, by guard.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Refusals {
    /// The link condition (or an edge without exactly two triangles).
    pub link: usize,
    /// A component would drop below 4 vertices.
    pub component: usize,
    /// A neighbouring triangle would turn too far.
    pub fold_over: usize,
    /// A triangle would get zero area or too poor a shape.
    pub shape: usize,
    /// An input vertex would end farther than the error bound from the surface.
    pub error: usize,
}

/// What [`decimate`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DecimateStats {
    /// Triangles before (quads counted as two).
    pub triangles_before: usize,
    /// Triangles after.
    pub triangles_after: usize,
    /// Vertices before.
    pub vertices_before: usize,
    /// Vertices after.
    pub vertices_after: usize,
    /// Edges collapsed.
    pub collapses: usize,
    /// Vertices that could not move (boundary, non-manifold).
    pub locked: usize,
    /// Collapses refused, by guard.
    pub refused: Refusals,
    /// With an error bound: the largest distance from an input vertex to the triangle it is
    /// assigned to (an upper bound of the one-sided Hausdorff distance, vertices to surface).
    pub error: Option<f64>,
}

/// Decimates `mesh` in place (see the module doc for what is kept).
///
/// # Errors
/// [`Error::InvalidInput`] for options out of range or a mesh with indices out of range.
pub fn decimate(mesh: &mut Mesh, opts: &DecimateOptions) -> Result<DecimateStats> {
    opts.validate()?;
    mesh.validate()?;
    mesh.triangulate();
    let triangles_before = mesh.triangles.len();
    let vertices_before = mesh.positions.len();
    let target = match opts.reduction {
        Some(r) => ((1.0 - r) * triangles_before as f64).round() as usize,
        None => 0,
    };
    // Decimated in a spatial order of the vertices (Morton): a collapse's neighbourhood and the
    // input vertices it checks lie close in memory; written back in the input's order.
    let order = spatial_order(&mesh.positions);
    let mut local_of = vec![0u32; order.len()];
    for (local, &v) in order.iter().enumerate() {
        local_of[v as usize] = local as u32;
    }
    let local = Mesh {
        positions: order.iter().map(|&v| mesh.positions[v as usize]).collect(),
        triangles: mesh.triangles.iter().map(|t| t.map(|v| local_of[v as usize])).collect(),
        ..Mesh::default()
    };
    let mut d = Decimator::new(&local, opts);
    drop(local);
    d.run(target);
    let stats = DecimateStats {
        triangles_before,
        triangles_after: d.live_triangles,
        vertices_before,
        vertices_after: 0,
        collapses: d.collapses,
        locked: d.locked.iter().filter(|&&l| l).count(),
        refused: d.refused,
        error: d.track.as_ref().map(|t| t.worst(&d)),
    };
    let had_normals = !mesh.normals.is_empty();
    d.write(mesh, &local_of);
    if had_normals {
        mesh.normals = super::smooth::vertex_normals(mesh);
    }
    Ok(DecimateStats { vertices_after: mesh.positions.len(), ..stats })
}

/// The vertices in Morton order of their positions (quantised to 2²¹ steps over the bounding
/// box; ties by index): `order[k]` is the `k`-th vertex.
fn spatial_order(positions: &[[f32; 3]]) -> Vec<u32> {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let scale = [0, 1, 2].map(|a| if hi[a] > lo[a] { ((1u32 << 21) - 1) as f64 / (hi[a] - lo[a]) as f64 } else { 0.0 });
    let mut keyed: Vec<(u64, u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = [0, 1, 2].map(|a| ((p[a] - lo[a]) as f64 * scale[a]) as u32);
            (crate::grid::octree::morton(q, 21), i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// A symmetric 4×4 quadric `xᵀ A x + 2 bᵀ x + c`: A as (xx, xy, xz, yy, yz, zz).
#[derive(Debug, Clone, Copy, Default)]
struct Quadric {
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
}

impl Quadric {
    /// `w` times the squared distance to the plane through `p` with unit normal `n`.
    fn plane(n: [f64; 3], p: [f64; 3], w: f64) -> Self {
        let d = -dot(n, p);
        Quadric {
            a: [n[0] * n[0], n[0] * n[1], n[0] * n[2], n[1] * n[1], n[1] * n[2], n[2] * n[2]].map(|x| x * w),
            b: n.map(|x| x * d * w),
            c: d * d * w,
        }
    }

    fn add(&self, o: &Quadric) -> Quadric {
        Quadric {
            a: [0, 1, 2, 3, 4, 5].map(|i| self.a[i] + o.a[i]),
            b: [0, 1, 2].map(|i| self.b[i] + o.b[i]),
            c: self.c + o.c,
        }
    }

    fn eval(&self, x: [f64; 3]) -> f64 {
        let a = &self.a;
        let ax = [
            a[0] * x[0] + a[1] * x[1] + a[2] * x[2],
            a[1] * x[0] + a[3] * x[1] + a[4] * x[2],
            a[2] * x[0] + a[4] * x[1] + a[5] * x[2],
        ];
        (dot(ax, x) + 2.0 * dot(self.b, x) + self.c).max(0.0)
    }

    /// The minimiser `A x = −b`, when A is well conditioned.
    fn minimiser(&self) -> Option<[f64; 3]> {
        let a = &self.a;
        let m = [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]];
        let cof = [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
        ];
        let det = m[0][0] * cof[0] + m[0][1] * cof[1] + m[0][2] * cof[2];
        let scale = a[0] + a[3] + a[5];
        if !(det.abs() > SINGULAR * scale * scale * scale) {
            return None;
        }
        let r = self.b.map(|x| -x);
        // Cramer's rule.
        let solve = |col: usize| {
            let mut mm = m;
            for row in 0..3 {
                mm[row][col] = r[row];
            }
            let d = mm[0][0] * (mm[1][1] * mm[2][2] - mm[1][2] * mm[2][1])
                - mm[0][1] * (mm[1][0] * mm[2][2] - mm[1][2] * mm[2][0])
                + mm[0][2] * (mm[1][0] * mm[2][1] - mm[1][1] * mm[2][0]);
            d / det
        };
        Some([solve(0), solve(1), solve(2)])
    }
}

/// A quadric whose determinant is below this fraction of its trace cubed is treated as singular
/// (flat or creased neighbourhoods), and the collapse goes to the best of the ends and midpoint.
const SINGULAR: f64 = 1e-9;

/// A candidate collapse in the queue, 16 bytes: its cost (an `f32` ≥ 0, whose bits order as
/// the numbers do), its ends, and the sum of their stamps when it was queued. Stamps only grow,
/// so the sum is unchanged exactly when neither end changed: the candidate is still valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Candidate {
    cost: u32,
    a: u32,
    b: u32,
    stamps: u32,
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    /// Reversed, so that the queue (greatest first) pops the cheapest; ties by vertex ids
    /// (deterministic).
    fn cmp(&self, o: &Self) -> Ordering {
        (o.cost, o.a, o.b, o.stamps).cmp(&(self.cost, self.a, self.b, self.stamps))
    }
}

/// A 4-ary heap, greatest first: half the depth of a binary heap, a node's four children side
/// by side (64 bytes); the heap of the bucket [`Buckets`] is popping.
#[derive(Debug, Default)]
struct Queue {
    items: Vec<Candidate>,
}

impl Queue {
    fn push(&mut self, c: Candidate) {
        let mut i = self.items.len();
        self.items.push(c);
        while i > 0 {
            let parent = (i - 1) / 4;
            if self.items[parent] >= c {
                break;
            }
            self.items[i] = self.items[parent];
            i = parent;
        }
        self.items[i] = c;
    }

    fn pop(&mut self) -> Option<Candidate> {
        let last = self.items.pop()?;
        if self.items.is_empty() {
            return Some(last);
        }
        let top = self.items[0];
        self.sift_down(0, last);
        Some(top)
    }

    /// A heap of `items` (bottom-up, in linear time).
    fn from_vec(items: Vec<Candidate>) -> Self {
        let mut q = Queue { items };
        for i in (0..q.items.len().div_ceil(4)).rev() {
            q.sift_down(i, q.items[i]);
        }
        q
    }

    /// Puts `c` at slot `i` (whose subtrees are heaps), moving it down past greater children.
    fn sift_down(&mut self, mut i: usize, c: Candidate) {
        let n = self.items.len();
        loop {
            let first = 4 * i + 1;
            if first >= n {
                break;
            }
            let mut best = first;
            for j in first + 1..(first + 4).min(n) {
                if self.items[j] > self.items[best] {
                    best = j;
                }
            }
            if self.items[best] <= c {
                break;
            }
            self.items[i] = self.items[best];
            i = best;
        }
        self.items[i] = c;
    }
}

/// The collapse queue: candidates in 2¹⁶ buckets by the top bits of their cost (sign, exponent
/// and 7 bits of mantissa: costs within 1/128 of each other share one), each a plain list until
/// the pops reach it, then a heap. Everything below the bucket being popped goes into its heap,
/// so the cheapest candidate is always there: the pops come in the order one heap of everything
/// would give, but the heap is small and warm (one heap of millions of candidates spent a
/// quarter of the decimation's time in cache misses; bunny CT, 3.7 M triangles).
struct Buckets {
    lists: Vec<Vec<Candidate>>,
    /// The bucket whose candidates are in `current` (and every one below it is empty).
    at: usize,
    current: Queue,
}

impl Default for Buckets {
    fn default() -> Self {
        Buckets { lists: vec![Vec::new(); 1 << 16], at: 0, current: Queue::default() }
    }
}

impl Buckets {
    fn push(&mut self, c: Candidate) {
        let b = (c.cost >> 16) as usize;
        if b <= self.at {
            self.current.push(c);
        } else {
            self.lists[b].push(c);
        }
    }

    fn pop(&mut self) -> Option<Candidate> {
        loop {
            if let Some(c) = self.current.pop() {
                return Some(c);
            }
            let next = (self.at + 1..self.lists.len()).find(|&b| !self.lists[b].is_empty())?;
            self.at = next;
            self.current = Queue::from_vec(std::mem::take(&mut self.lists[next]));
        }
    }
}

/// An input vertex in the tracker: where it is, and the next of its triangle's list.
#[derive(Debug, Clone, Copy)]
struct Node {
    point: [f64; 3],
    next: u32,
}

/// Marks "no point" / "no triangle" in the tracker's lists.
const NONE: u32 = u32::MAX;

/// Which input vertex is assigned to which live triangle: a singly linked list per triangle;
/// and the input surface around each input vertex (its triangles, in compressed rows), where a
/// moved vertex must stay within the bound.
struct Tracker {
    bound: f64,
    /// Each input vertex's position and the next vertex of its triangle's list, side by side
    /// (walking a list touches one line per vertex, not two: the lists are the decimation's
    /// main cache misses).
    nodes: Vec<Node>,
    head: Vec<u32>,
    owner: Vec<u32>,
    input_triangles: Vec<[u32; 3]>,
    star_offsets: Vec<u32>,
    star: Vec<u32>,
}

impl Tracker {
    /// Whether `x` lies within the bound of the input surface near the input vertices `near`
    /// (their own positions, then their triangles): a part of the input surface, so `true` is
    /// exact, `false` conservative.
    fn near_input(&self, x: [f64; 3], near: &[(u32, u32)]) -> bool {
        let bound2 = self.bound * self.bound;
        if near
            .iter()
            .any(|&(p, _)| dot(sub(x, self.nodes[p as usize].point), sub(x, self.nodes[p as usize].point)) <= bound2)
        {
            return true;
        }
        near.iter().any(|&(p, _)| {
            let (lo, hi) = (self.star_offsets[p as usize] as usize, self.star_offsets[p as usize + 1] as usize);
            self.star[lo..hi].iter().any(|&t| {
                let [a, b, c] = self.input_triangles[t as usize].map(|v| self.nodes[v as usize].point);
                point_triangle_distance2(x, a, b, c) <= bound2
            })
        })
    }
}

impl Tracker {
    /// The largest distance from an input vertex to the triangle it is assigned to.
    fn worst(&self, d: &Decimator) -> f64 {
        let mut worst: f64 = 0.0;
        for (i, node) in self.nodes.iter().enumerate() {
            let (p, t) = (&node.point, self.owner[i]);
            if t != NONE {
                let [a, b, c] = d.tris[t as usize].map(|v| d.pos[v as usize]);
                worst = worst.max(point_triangle_distance2(*p, a, b, c).sqrt());
            }
        }
        worst
    }
}

struct Decimator {
    centre: [f64; 3],
    pos: Vec<[f64; 3]>,
    quadric: Vec<Quadric>,
    tris: Vec<[u32; 3]>,
    tri_alive: Vec<bool>,
    /// Live triangles around each vertex.
    star: Vec<Vec<u32>>,
    vertex_alive: Vec<bool>,
    /// The vertex's position changed (the others are written back bit for bit).
    moved: Vec<bool>,
    locked: Vec<bool>,
    /// Raised when a vertex's neighbourhood changes: queue entries with an older stamp are stale.
    stamp: Vec<u32>,
    /// The other ends of the vertex's edges whose collapse was refused: queued again (with their
    /// unchanged stamps, so nothing else of the vertex goes stale) when its neighbourhood changes.
    parked: Vec<Vec<u32>>,
    /// Scratch lists reused by every collapse (no allocation per candidate).
    scratch: Scratch,
    component: Vec<u32>,
    component_size: Vec<u32>,
    /// Triangles with a repeated vertex: kept as they are, outside every star.
    kept: Vec<[u32; 3]>,
    heap: Buckets,
    live_triangles: usize,
    collapses: usize,
    refused: Refusals,
    track: Option<Tracker>,
    cos_turn: f64,
    min_shape: f64,
}

impl Decimator {
    fn new(mesh: &Mesh, opts: &DecimateOptions) -> Self {
        let nv = mesh.positions.len();
        let centre = super::smooth::centre_of(&mesh.positions);
        let pos: Vec<[f64; 3]> = mesh.positions.iter().map(|p| [0, 1, 2].map(|a| p[a] as f64 - centre[a])).collect();
        let mut tris = Vec::with_capacity(mesh.triangles.len());
        let mut kept = Vec::new();
        let mut locked = vec![false; nv];
        for &t in &mesh.triangles {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                kept.push(t);
                t.iter().for_each(|&v| locked[v as usize] = true);
            } else {
                tris.push(t);
            }
        }
        let mut star: Vec<Vec<u32>> = vec![Vec::new(); nv];
        for (i, t) in tris.iter().enumerate() {
            for &v in t {
                star[v as usize].push(i as u32);
            }
        }
        // Edges used by other than two triangles lock their ends.
        let mut keys: Vec<u64> =
            tris.iter().flat_map(|t| (0..3).map(move |s| crate::topo::edge_key(t[s], t[(s + 1) % 3]))).collect();
        super::smooth::sort_keys(&mut keys);
        for g in keys.chunk_by(|a, b| a == b) {
            if g.len() != 2 {
                locked[(g[0] >> 32) as usize] = true;
                locked[g[0] as u32 as usize] = true;
            }
        }
        let mut quadric = vec![Quadric::default(); nv];
        let mut uf = UnionFind::new(nv);
        for t in &tris {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            let n = cross(sub(b, a), sub(c, a));
            let len = dot(n, n).sqrt();
            if len > 0.0 {
                let q = Quadric::plane(n.map(|x| x / len), a, 0.5 * len);
                for &v in t {
                    quadric[v as usize] = quadric[v as usize].add(&q);
                }
            }
            uf.union(t[0], t[1]);
            uf.union(t[1], t[2]);
        }
        let mut component = vec![0u32; nv];
        let mut component_size = vec![0u32; nv];
        for v in 0..nv {
            let r = uf.find(v as u32);
            component[v] = r;
            component_size[r as usize] += 1;
        }
        let live_triangles = tris.len() + kept.len();
        let mut d = Decimator {
            centre,
            pos,
            quadric,
            tri_alive: vec![true; tris.len()],
            tris,
            star,
            vertex_alive: vec![true; nv],
            moved: vec![false; nv],
            locked,
            stamp: vec![0; nv],
            parked: vec![Vec::new(); nv],
            scratch: Scratch::default(),
            component,
            component_size,
            kept,
            heap: Buckets::default(),
            live_triangles,
            collapses: 0,
            refused: Refusals::default(),
            track: None,
            cos_turn: opts.max_normal_turn_deg.to_radians().cos(),
            min_shape: opts.min_shape,
        };
        for v in 0..nv {
            if !d.star[v].is_empty() && !d.one_fan(v as u32) {
                d.locked[v] = true;
            }
        }
        if let Some(bound) = opts.max_error {
            let mut star_offsets = vec![0u32; nv + 1];
            for v in 0..nv {
                star_offsets[v + 1] = star_offsets[v] + d.star[v].len() as u32;
            }
            let mut t = Tracker {
                bound,
                nodes: d.pos.iter().map(|&point| Node { point, next: NONE }).collect(),
                head: vec![NONE; d.tris.len()],
                owner: vec![NONE; nv],
                input_triangles: d.tris.clone(),
                star: d.star.iter().flatten().copied().collect(),
                star_offsets,
            };
            for v in 0..nv {
                if let Some(&tri) = d.star[v].first() {
                    t.nodes[v].next = t.head[tri as usize];
                    t.head[tri as usize] = v as u32;
                    t.owner[v] = tri;
                }
            }
            d.track = Some(t);
        }
        // Every edge once, from its smaller end.
        for v in 0..nv as u32 {
            for n in d.neighbours(v) {
                if v < n {
                    d.push(v, n);
                }
            }
        }
        d
    }

    /// Whether the triangles around `v` form one fan (turning about `v` across shared edges
    /// reaches them all).
    fn one_fan(&self, v: u32) -> bool {
        let star = &self.star[v as usize];
        let mut seen = vec![false; star.len()];
        let mut stack = vec![0usize];
        seen[0] = true;
        while let Some(i) = stack.pop() {
            for &w in &self.tris[star[i] as usize] {
                if w == v {
                    continue;
                }
                for (j, &t) in star.iter().enumerate() {
                    if !seen[j] && self.tris[t as usize].contains(&w) {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        seen.iter().all(|&s| s)
    }

    /// The vertices sharing a live triangle with `v`, ascending.
    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut n = Vec::new();
        self.neighbours_into(v, &mut n);
        n
    }

    /// [`Decimator::neighbours`] into `n` (cleared first).
    fn neighbours_into(&self, v: u32, n: &mut Vec<u32>) {
        n.clear();
        n.extend(self.star[v as usize].iter().flat_map(|&t| self.tris[t as usize]).filter(|&w| w != v));
        n.sort_unstable();
        n.dedup();
    }

    /// Where collapsing `keep`–`gone` would put the vertex, and its quadric cost; `None` when
    /// both ends are locked. A locked end stays; otherwise the quadric's minimiser when it lies
    /// within an edge length of the midpoint, else the best of the ends and the midpoint.
    /// The position is rounded to what the output stores (`f32` about the original frame).
    fn plan(&self, a: u32, b: u32) -> Option<(f64, [f64; 3])> {
        let (la, lb) = (self.locked[a as usize], self.locked[b as usize]);
        if la && lb {
            return None;
        }
        let q = self.quadric[a as usize].add(&self.quadric[b as usize]);
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let x = if la {
            pa
        } else if lb {
            pb
        } else {
            let mid = [0, 1, 2].map(|i| 0.5 * (pa[i] + pb[i]));
            let reach = dot(sub(pa, pb), sub(pa, pb));
            match q.minimiser().filter(|x| dot(sub(*x, mid), sub(*x, mid)) <= reach) {
                Some(x) => self.rounded(x),
                None => {
                    let mid = self.rounded(mid);
                    [mid, pa, pb].into_iter().min_by(|x, y| q.eval(*x).total_cmp(&q.eval(*y))).unwrap_or(mid)
                }
            }
        };
        Some((q.eval(x), x))
    }

    /// `x` as the output will store it.
    fn rounded(&self, x: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| ((x[i] + self.centre[i]) as f32) as f64 - self.centre[i])
    }

    fn push(&mut self, a: u32, b: u32) {
        if let Some((cost, _)) = self.plan(a, b) {
            let stamps = self.stamp[a as usize].wrapping_add(self.stamp[b as usize]);
            // Costs are ≥ 0 (or NaN from overflowing coordinates: queued last).
            let cost = if cost.is_nan() { u32::MAX } else { (cost as f32).to_bits() };
            self.heap.push(Candidate { cost, a, b, stamps });
        }
    }

    /// Collapses the cheapest edges until `target` triangles remain or the queue is empty.
    fn run(&mut self, target: usize) {
        while self.live_triangles > target {
            let Some(c) = self.heap.pop() else { break };
            let (a, b) = (c.a as usize, c.b as usize);
            if !self.vertex_alive[a] || !self.vertex_alive[b] || self.stamp[a].wrapping_add(self.stamp[b]) != c.stamps {
                continue;
            }
            if let Err(refusal) = self.try_collapse(c.a, c.b) {
                match refusal {
                    Refusal::Link => self.refused.link += 1,
                    Refusal::Component => self.refused.component += 1,
                    Refusal::FoldOver => self.refused.fold_over += 1,
                    Refusal::Shape => self.refused.shape += 1,
                    Refusal::Error => self.refused.error += 1,
                }
                if !self.parked[a].contains(&c.b) {
                    self.parked[a].push(c.b);
                }
                if !self.parked[b].contains(&c.a) {
                    self.parked[b].push(c.a);
                }
            }
        }
    }

    fn try_collapse(&mut self, a: u32, b: u32) -> std::result::Result<(), Refusal> {
        let mut scratch = std::mem::take(&mut self.scratch);
        let verdict = self.check_collapse(a, b, &mut scratch);
        let result = verdict.map(|(keep, gone, x)| self.apply_collapse(keep, gone, x, &mut scratch));
        self.scratch = scratch;
        result
    }

    /// Whether collapsing `a`–`b` keeps every guarantee: the vertex kept, the one gone and the
    /// position, with `s.changed`, `s.shared` and `s.reassigned` filled for the apply; else the
    /// first guard that refuses. The cheap and most often failing guards come first (on the
    /// engine CT: 330 k fold-overs and 680 k shapes to 4 k link refusals).
    fn check_collapse(&self, a: u32, b: u32, s: &mut Scratch) -> std::result::Result<(u32, u32, [f64; 3]), Refusal> {
        let Some((_, x)) = self.plan(a, b) else { return Err(Refusal::Link) };
        // The locked end (if any) is kept.
        let (keep, gone) = if self.locked[b as usize] { (b, a) } else { (a, b) };
        let (ks, gs) = (keep as usize, gone as usize);

        // 1. Exactly two triangles on the edge.
        s.shared.clear();
        s.shared.extend(self.star[ks].iter().copied().filter(|&t| self.tris[t as usize].contains(&gone)));
        if s.shared.len() != 2 {
            return Err(Refusal::Link);
        }
        let shared = [s.shared[0], s.shared[1]];
        // 2. Components keep at least a tetrahedron's 4 vertices.
        if self.component_size[self.component[ks] as usize] <= 4 {
            return Err(Refusal::Component);
        }
        // 3. Geometry of the triangles that stay: no turn beyond the bound, no degenerate shape.
        s.changed.clear();
        s.changed.extend(self.star[ks].iter().copied().filter(|t| !shared.contains(t)));
        s.changed.extend(self.star[gs].iter().copied().filter(|t| !shared.contains(t)));
        let moved = |p: u32| if p == keep || p == gone { x } else { self.pos[p as usize] };
        let (mut old_shape, mut new_shape) = (f64::INFINITY, f64::INFINITY);
        for &t in s.changed.iter().chain(&shared) {
            old_shape = old_shape.min(shape(self.tris[t as usize].map(|v| self.pos[v as usize])));
        }
        for &t in &s.changed {
            let tri = self.tris[t as usize];
            let before = tri.map(|v| self.pos[v as usize]);
            let after = tri.map(moved);
            let (n0, n1) = (normal(before), normal(after));
            let (l0, l1) = (dot(n0, n0).sqrt(), dot(n1, n1).sqrt());
            if l1 == 0.0 {
                return Err(Refusal::Shape);
            }
            if dot(n0, n1) <= self.cos_turn * l0 * l1 {
                return Err(Refusal::FoldOver);
            }
            new_shape = new_shape.min(shape(after));
        }
        if new_shape < self.min_shape && new_shape < old_shape {
            return Err(Refusal::Shape);
        }
        // 4. Link condition: the ends' common neighbours are exactly the edge's two third vertices.
        let mut opposite =
            shared.map(|t| self.tris[t as usize].into_iter().find(|&w| w != keep && w != gone).unwrap_or(NONE));
        opposite.sort_unstable();
        self.neighbours_into(keep, &mut s.nk);
        self.neighbours_into(gone, &mut s.ng);
        let mut common = s.nk.iter().copied().filter(|w| s.ng.binary_search(w).is_ok());
        if common.next() != Some(opposite[0]) || common.next() != Some(opposite[1]) || common.next().is_some() {
            return Err(Refusal::Link);
        }
        // 5. Error bound: every input vertex assigned to a triangle that changes or goes must be
        // within the bound of a triangle that stays.
        s.reassigned.clear();
        if let Some(track) = &self.track {
            let bound2 = track.bound * track.bound;
            for &t in s.changed.iter().chain(&shared) {
                let mut p = track.head[t as usize];
                while p != NONE {
                    let q = track.nodes[p as usize].point;
                    // Most vertices stay within the bound of their own triangle as it moves:
                    // only the others look for the nearest new triangle.
                    if t != shared[0] && t != shared[1] {
                        let [u, v, w] = self.tris[t as usize].map(moved);
                        if point_triangle_distance2(q, u, v, w) <= bound2 {
                            s.reassigned.push((p, t));
                            p = track.nodes[p as usize].next;
                            continue;
                        }
                    }
                    let mut best = (f64::INFINITY, NONE);
                    for &c in &s.changed {
                        let [u, v, w] = self.tris[c as usize].map(moved);
                        let d2 = point_triangle_distance2(q, u, v, w);
                        if d2 < best.0 {
                            best = (d2, c);
                            if d2 == 0.0 {
                                break;
                            }
                        }
                    }
                    if !(best.0 <= bound2) {
                        return Err(Refusal::Error);
                    }
                    s.reassigned.push((p, best.1));
                    p = track.nodes[p as usize].next;
                }
            }
            // The other direction at the moved vertex: it stays within the bound of the input
            // surface (unless it is an input vertex that did not move).
            let unmoved = !self.moved[ks] && x == self.pos[ks];
            if !unmoved && !track.near_input(x, &s.reassigned) {
                return Err(Refusal::Error);
            }
        }
        Ok((keep, gone, x))
    }

    /// Collapses `gone` into `keep` at `x` (checked by [`Decimator::check_collapse`], whose lists
    /// `s` holds).
    fn apply_collapse(&mut self, keep: u32, gone: u32, x: [f64; 3], s: &mut Scratch) {
        let (ks, gs) = (keep as usize, gone as usize);
        let shared = [s.shared[0], s.shared[1]];
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            for &v in &self.tris[t as usize] {
                self.star[v as usize].retain(|&s| s != t);
            }
            self.live_triangles -= 1;
        }
        let gone_star = std::mem::take(&mut self.star[gs]);
        for t in gone_star {
            for v in &mut self.tris[t as usize] {
                if *v == gone {
                    *v = keep;
                }
            }
            self.star[ks].push(t);
        }
        if self.pos[ks] != x {
            self.pos[ks] = x;
            self.moved[ks] = true;
        }
        self.quadric[ks] = self.quadric[ks].add(&self.quadric[gs]);
        self.vertex_alive[gs] = false;
        self.component_size[self.component[ks] as usize] -= 1;
        if let Some(track) = &mut self.track {
            for &t in s.changed.iter().chain(&shared) {
                track.head[t as usize] = NONE;
            }
            for &(p, t) in &s.reassigned {
                track.nodes[p as usize].next = track.head[t as usize];
                track.head[t as usize] = p;
                track.owner[p as usize] = t;
            }
        }
        self.collapses += 1;
        // Queue the kept vertex's edges anew (its cost and stamp changed), and the refused
        // collapses parked at its neighbours (their stars changed: they may pass now).
        self.stamp[ks] += 1;
        let mut ring = std::mem::take(&mut s.ring);
        self.neighbours_into(keep, &mut ring);
        for &n in &ring {
            self.push(keep, n);
        }
        // Each parked edge once, though both its ends may be in the ring.
        let mut again = std::mem::take(&mut s.again);
        again.clear();
        for &n in &ring {
            for m in self.parked[n as usize].drain(..) {
                if m != keep && m != gone {
                    again.push((n.min(m), n.max(m)));
                }
            }
        }
        again.sort_unstable();
        again.dedup();
        for &(n, m) in &again {
            if self.vertex_alive[m as usize] && self.vertex_alive[n as usize] {
                self.push(n, m);
            }
        }
        s.again = again;
        s.ring = ring;
        // Every edge of the kept vertex was queued anew; the gone vertex has none.
        self.parked[ks].clear();
        self.parked[gs] = Vec::new();
    }

    /// The live vertices (in their input order: vertex `v` of `mesh` is `local_of[v]` here)
    /// and triangles into `mesh`.
    fn write(&self, mesh: &mut Mesh, local_of: &[u32]) {
        let mut id = vec![NONE; self.pos.len()];
        let mut positions = Vec::new();
        for (v, &l) in local_of.iter().enumerate() {
            let l = l as usize;
            if self.vertex_alive[l] {
                id[l] = positions.len() as u32;
                // Vertices that never moved (the locked ones among them) keep their input
                // coordinates.
                let p = self.pos[l];
                positions.push(if self.moved[l] {
                    [0, 1, 2].map(|i| (p[i] + self.centre[i]) as f32)
                } else {
                    mesh.positions[v]
                });
            }
        }
        let mut triangles: Vec<[u32; 3]> = self
            .tris
            .iter()
            .zip(&self.tri_alive)
            .filter(|(_, &alive)| alive)
            .map(|(t, _)| t.map(|v| id[v as usize]))
            .collect();
        triangles.extend(self.kept.iter().map(|t| t.map(|v| id[v as usize])));
        *mesh = Mesh { positions, normals: Vec::new(), triangles, quads: Vec::new() };
    }
}

/// The lists a collapse's check fills and its apply reads, kept between collapses.
#[derive(Debug, Default)]
struct Scratch {
    shared: Vec<u32>,
    changed: Vec<u32>,
    reassigned: Vec<(u32, u32)>,
    nk: Vec<u32>,
    ng: Vec<u32>,
    ring: Vec<u32>,
    again: Vec<(u32, u32)>,
}

/// Which guard refused a collapse.
#[derive(Debug, Clone, Copy)]
enum Refusal {
    Link,
    Component,
    FoldOver,
    Shape,
    Error,
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// `(b − a) × (c − a)`.
#[inline]
fn normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    cross(sub(b, a), sub(c, a))
}

/// `4√3 · area / (sum of squared sides)`: 1 for an equilateral triangle, 0 for a degenerate one.
fn shape(p: [[f64; 3]; 3]) -> f64 {
    let n = normal(p);
    let sides = dot(sub(p[1], p[0]), sub(p[1], p[0]))
        + dot(sub(p[2], p[1]), sub(p[2], p[1]))
        + dot(sub(p[0], p[2]), sub(p[0], p[2]));
    if sides == 0.0 {
        return 0.0;
    }
    2.0 * 3f64.sqrt() * dot(n, n).sqrt() / sides
}

/// Squared distance from `p` to triangle `abc`: to its plane when the foot lies inside,
/// otherwise to the nearest side.
pub(crate) fn point_triangle_distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let n = cross(ab, ac);
    let nn = dot(n, n);
    if nn > 0.0 {
        // Barycentric coordinates of the foot (the offset along n drops out of both).
        let s = dot(cross(ap, ac), n) / nn;
        let t = dot(cross(ab, ap), n) / nn;
        if s >= 0.0 && t >= 0.0 && s + t <= 1.0 {
            let h = dot(ap, n);
            return h * h / nn;
        }
    }
    segment_distance2(p, a, b).min(segment_distance2(p, b, c)).min(segment_distance2(p, c, a))
}

fn segment_distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let (ab, ap) = (sub(b, a), sub(p, a));
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 { (dot(ap, ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let d = sub(ap, ab.map(|x| x * t));
    dot(d, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{self, Distance};
    use crate::topo::{self, MeshReport};

    /// The report's topology: closed, manifold, oriented, genus, components, Euler characteristic.
    fn topology(r: &MeshReport) -> (bool, bool, bool, Option<i64>, usize, i64) {
        (r.is_closed(), r.is_manifold(), r.is_oriented(), r.genus(), r.components.len(), r.euler)
    }

    /// Squared distance from `p` to triangle `abc` by the Voronoi regions of its corners, sides
    /// and face (a different route from the library's foot-or-sides test).
    fn distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
        let closest = || -> [f64; 3] {
            let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
            let (d1, d2) = (dot(ab, ap), dot(ac, ap));
            if d1 <= 0.0 && d2 <= 0.0 {
                return a;
            }
            let bp = sub(p, b);
            let (d3, d4) = (dot(ab, bp), dot(ac, bp));
            if d3 >= 0.0 && d4 <= d3 {
                return b;
            }
            let vc = d1 * d4 - d3 * d2;
            if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
                let v = d1 / (d1 - d3);
                return [0, 1, 2].map(|i| a[i] + v * ab[i]);
            }
            let cp = sub(p, c);
            let (d5, d6) = (dot(ab, cp), dot(ac, cp));
            if d6 >= 0.0 && d5 <= d6 {
                return c;
            }
            let vb = d5 * d2 - d1 * d6;
            if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
                let w = d2 / (d2 - d6);
                return [0, 1, 2].map(|i| a[i] + w * ac[i]);
            }
            let va = d3 * d6 - d5 * d4;
            if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
                let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
                return [0, 1, 2].map(|i| b[i] + w * (c[i] - b[i]));
            }
            let denom = 1.0 / (va + vb + vc);
            let (v, w) = (vb * denom, vc * denom);
            [0, 1, 2].map(|i| a[i] + ab[i] * v + ac[i] * w)
        };
        let q = sub(p, closest());
        dot(q, q)
    }

    /// The largest distance from a vertex of `from` to the surface of `to` (brute force).
    fn vertices_to_surface(from: &Mesh, to: &Mesh) -> f64 {
        let p = |m: &Mesh, v: u32| m.positions[v as usize].map(f64::from);
        let mut worst: f64 = 0.0;
        for v in 0..from.positions.len() as u32 {
            let q = p(from, v);
            let d = to
                .triangles
                .iter()
                .map(|t| distance2(q, p(to, t[0]), p(to, t[1]), p(to, t[2])))
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(d.sqrt());
        }
        worst
    }

    /// Triangles whose normal turned over or that lost their area.
    fn degenerate(m: &Mesh) -> usize {
        m.triangles.iter().filter(|t| shape(t.map(|v| m.positions[v as usize].map(f64::from))) == 0.0).count()
    }

    const SHAPES: [(&str, [u32; 3], Distance); 3] = [
        ("sphere", [32; 3], shapes::sphere),
        ("torus", [32; 3], shapes::torus),
        ("double torus", [48, 32, 32], shapes::double_torus),
    ];

    /// Decimation to a tenth keeps closedness, manifoldness, orientation, genus and components,
    /// and reaches the ratio.
    #[test]
    fn reduction_keeps_the_topology_and_reaches_the_ratio() {
        for (name, dims, shape) in SHAPES {
            let mut mesh = shapes::binary(dims, shape);
            let before = topo::check(&mesh);
            assert!(before.is_watertight(), "{name}");
            let stats = decimate(&mut mesh, &DecimateOptions::reduction(0.9)).unwrap();
            let after = topo::check(&mesh);
            println!("{name}: {stats:?}");
            assert_eq!(topology(&after), topology(&before), "{name}: {stats:?}");
            assert_eq!(stats.triangles_after, mesh.triangles.len());
            assert!(mesh.triangles.len() as f64 <= 0.1 * before.triangles as f64 + 1.0, "{name}: {stats:?}");
            assert_eq!(after.isolated_vertices.count, 0, "{name}");
            assert_eq!(degenerate(&mesh), 0, "{name}");
            assert_eq!(mesh.positions.len(), stats.vertices_after);
        }
    }

    /// With an error bound, every input vertex lies within it of the output surface (checked by
    /// brute force), and the topology is kept.
    #[test]
    fn error_bound_holds_for_every_input_vertex() {
        for (name, dims, shape) in SHAPES {
            for bound in [0.25, 0.5, 1.0] {
                let original = shapes::binary(dims, shape);
                let mut mesh = original.clone();
                let stats = decimate(&mut mesh, &DecimateOptions::max_error(bound)).unwrap();
                let worst = vertices_to_surface(&original, &mesh);
                println!(
                    "{name} bound {bound}: {} → {} triangles, vertices to surface {worst:.3} (tracked {:.3}), back {:.3}",
                    stats.triangles_before,
                    stats.triangles_after,
                    stats.error.unwrap_or(-1.0),
                    vertices_to_surface(&mesh, &original)
                );
                assert!(worst <= bound * (1.0 + 1e-9), "{name} bound {bound}: {worst}");
                let back = vertices_to_surface(&mesh, &original);
                assert!(back <= bound * (1.0 + 1e-6), "{name} bound {bound}: output vertices {back} from the input");
                assert!(stats.error.is_some_and(|e| e <= bound && worst <= e + 1e-9), "{stats:?}");
                assert!(stats.triangles_after < stats.triangles_before / 2, "{name} bound {bound}: {stats:?}");
                assert_eq!(topology(&topo::check(&mesh)), topology(&topo::check(&original)), "{name}");
            }
        }
    }

    /// Boundary edges (a sphere cut open) come out exactly, vertices and all.
    #[test]
    fn boundary_edges_are_kept() {
        let mut mesh = shapes::binary([32; 3], shapes::sphere);
        mesh.triangles.retain(|t| t.iter().all(|&v| mesh.positions[v as usize][2] < 20.0));
        let boundary = |m: &Mesh| {
            let mut keys: Vec<u64> = m
                .triangles
                .iter()
                .flat_map(|t| (0..3).map(move |s| crate::topo::edge_key(t[s], t[(s + 1) % 3])))
                .collect();
            keys.sort_unstable();
            let mut edges: Vec<[[u32; 3]; 2]> = keys
                .chunk_by(|a, b| a == b)
                .filter(|g| g.len() == 1)
                .map(|g| {
                    let e = [(g[0] >> 32) as usize, g[0] as u32 as usize].map(|v| m.positions[v].map(f32::to_bits));
                    if e[0] < e[1] {
                        e
                    } else {
                        [e[1], e[0]]
                    }
                })
                .collect();
            edges.sort_unstable();
            edges
        };
        let before = boundary(&mesh);
        let r0 = topo::check(&mesh);
        let stats = decimate(&mut mesh, &DecimateOptions::reduction(0.95)).unwrap();
        assert!(stats.locked >= before.len());
        assert_eq!(boundary(&mesh), before);
        let r1 = topo::check(&mesh);
        assert_eq!(topology(&r1), topology(&r0));
        assert!(stats.triangles_after < stats.triangles_before / 4, "{stats:?}");
    }

    /// A tetrahedron beside a sphere survives any reduction: components never vanish.
    #[test]
    fn small_components_do_not_vanish() {
        let mut mesh = shapes::binary([32; 3], shapes::sphere);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        mesh.triangles.extend([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].map(|t| t.map(|v| v + base)));
        let before = topo::check(&mesh);
        decimate(&mut mesh, &DecimateOptions::reduction(1.0)).unwrap();
        let after = topo::check(&mesh);
        assert_eq!(topology(&after), topology(&before));
        assert!(after.components.iter().all(|c| c.vertices >= 4));
    }

    #[test]
    fn options_are_checked() {
        let mut m = shapes::binary([8; 3], shapes::sphere);
        assert!(decimate(&mut m, &DecimateOptions::default()).is_err());
        assert!(decimate(&mut m, &DecimateOptions::reduction(1.5)).is_err());
        assert!(decimate(&mut m, &DecimateOptions::max_error(-1.0)).is_err());
        assert!(decimate(&mut m, &DecimateOptions::max_error(f64::NAN)).is_err());
    }

    /// The queue pops in order.
    #[test]
    fn queue_pops_the_cheapest_first() {
        let mut q = Queue::default();
        let mut seed = 7u64;
        let mut costs = Vec::new();
        for i in 0..5000u32 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let cost = (seed >> 40) as u32;
            costs.push((cost, i));
            q.push(Candidate { cost, a: i, b: 0, stamps: 0 });
            if i % 3 == 0 {
                let c = q.pop().unwrap();
                let k = costs.iter().position(|&x| x == *costs.iter().min().unwrap()).unwrap();
                assert_eq!((c.cost, c.a), costs.swap_remove(k));
            }
        }
        costs.sort_unstable();
        for want in costs {
            let c = q.pop().unwrap();
            assert_eq!((c.cost, c.a), want);
        }
        assert!(q.pop().is_none());
    }

    #[test]
    fn buckets_pop_as_one_heap_does() {
        let (mut buckets, mut heap) = (Buckets::default(), Queue::default());
        let mut seed = 11u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            seed
        };
        for i in 0..20_000u32 {
            // Costs over the whole range, many equal, some below what was popped already.
            let r = next();
            let cost = match r % 4 {
                0 => (r >> 32) as u32,
                1 => (r >> 48) as u32,
                2 => 0x3f80_0000 + (r >> 58) as u32,
                _ => (r >> 40) as u32 & 0xffff_0000,
            };
            let c = Candidate { cost, a: i, b: (r >> 20) as u32 % 7, stamps: 0 };
            buckets.push(c);
            heap.push(c);
            if next() % 3 == 0 {
                assert_eq!(buckets.pop(), heap.pop());
            }
        }
        while let Some(c) = heap.pop() {
            assert_eq!(buckets.pop(), Some(c));
        }
        assert!(buckets.pop().is_none());
        // A heap built at once pops as one built by pushes.
        let items: Vec<Candidate> =
            (0..1000u32).map(|i| Candidate { cost: i * 7919 % 1000, a: i, b: 0, stamps: 0 }).collect();
        let (mut built, mut pushed) = (Queue::from_vec(items.clone()), Queue::default());
        items.into_iter().for_each(|c| pushed.push(c));
        while let Some(c) = pushed.pop() {
            assert_eq!(built.pop(), Some(c));
        }
    }

    /// The library's distance agrees with the test's.
    #[test]
    fn point_triangle_distances_agree() {
        let mut seed = 12345u64;
        let mut r = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
        };
        for _ in 0..20000 {
            let [p, a, b, c] = [(); 4].map(|_| [r(), r(), r()]);
            let (x, y) = (point_triangle_distance2(p, a, b, c), distance2(p, a, b, c));
            assert!((x - y).abs() <= 1e-9 * (1.0 + y), "{x} vs {y}");
        }
    }
}
