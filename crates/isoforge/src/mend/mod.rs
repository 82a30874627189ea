//! Topology repair of solids (TopoMender \[Zhou07\]): small handles cut and small tunnels filled,
//! found on skeletons.
//!
//! In: a grid and an iso (a SOG's sign grid, a voxelized mesh's distances, a scan or a label
//! mask) naming a solid. Out: the grid with few points flipped so that every handle whose
//! smallest cutting membrane is below `thin` is cut there and every tunnel whose smallest
//! spanning membrane is below `grow` is filled there, and a [`RepairReport`] of what was found.
//!
//! ```text
//!   points ─▶ CellComplex ─thin─▶ skeleton ─max spanning tree─▶ loops ─▶ membranes ─size < thin─▶ cut
//!   (solid)   (closed: all         (collapses,                 (one per    (pulled back    (flip its
//!              points in it)        recorded)                   handle)     along a loop)   points)
//!   the same on the dual of the outside ─▶ tunnels ─size < grow─▶ fill
//! ```
//!
//! Vocabulary (the doubled grid of [`complex`]): *elements* are points, edges, faces and cells;
//! a *free pair* is an element with one coface that has none; *thinning* removes free pairs;
//! the *skeleton* is what remains; a *loop* is a skeleton edge a maximum spanning tree (weighted
//! by the solid's thickness around each edge, [`distance`]) leaves out, one per handle; the
//! *membrane* of a skeleton edge is what retracted onto it: the support of its indicator
//! cochain pulled back through the collapses (an edge collapsed with a face takes the sum mod 2
//! of the face's other edges) — a set of edges crossing every loop through it once. Its *size* is
//! its area, each edge counting its dual quad (TopoMender's weights: dual-quad areas plus what
//! retracted onto the edge); a loop's size is its smallest membrane along its cycle, every edge
//! of the cycle measured (64 at a time: one play of the collapses backwards sizes 64 membranes). A cut takes one point of each membrane edge out of the solid; a fill (on the dual)
//! puts the four points of each primal face its membrane crosses in. A change is kept only when
//! the solid lost exactly one loop: its Euler characteristic up by one, its components and the
//! outside's unchanged; otherwise a ball around the membrane's edge is tried, else the loop is
//! reported and left.
//!
//! The solid is the iso's inside ([`Iso`]: `value < iso`, or `value > iso` when inside is
//! above; ties outside), whose complex is closed; the outside's is the dual, its border layer
//! kept whole (it stands for everything beyond the grid, so no membrane ends on it). The
//! surface MC33 extracts at the same iso has these complexes' topology on sign-like data whose
//! outside is three times stronger than its inside ([`sign_like`]; a SOG's ±1 signs are read so
//! by `topo-repair`); around flipped points the values are made so.
//!
//! The complex lives on the grid's finest points (TopoMender works on the octree's cells; the
//! areas are the same, the memory is not): a box one point larger than the solid's bounds, at
//! most [`CellComplex::MAX_ELEMENTS`] elements.

pub mod complex;
pub mod distance;
pub mod skeleton;
pub mod thin;

use std::collections::HashSet;

pub use complex::CellComplex;
pub use distance::squared_distance_to_absent;
pub use skeleton::{sheet_loops, spanning_loops, SheetLoop, SkeletonEdge};
pub use thin::{thin, Thinning};

use crate::error::{Error, Result};
use crate::grid::DenseGrid;
use crate::volume::{Inside, Iso};

/// What to repair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepairOptions {
    /// Handles whose narrowest cross-section (squared model units) is below this are cut;
    /// ≤ 0 skips cutting.
    pub thin: f64,
    /// Tunnels whose narrowest spanning disc (squared model units) is below this are filled;
    /// ≤ 0 skips filling.
    pub grow: f64,
}

/// A handle (a loop of the solid) or a tunnel (a loop of the outside).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopKind {
    /// A loop through the solid: cut to remove it.
    Handle,
    /// A loop through the outside: filled to remove it.
    Tunnel,
}

impl LoopKind {
    /// "handle" or "tunnel".
    pub fn name(self) -> &'static str {
        match self {
            LoopKind::Handle => "handle",
            LoopKind::Tunnel => "tunnel",
        }
    }
}

/// One loop found, and what was done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operation {
    /// Handle or tunnel.
    pub kind: LoopKind,
    /// The area of its narrowest cross-section, squared model units.
    pub size: f64,
    /// Where (world coordinates of that cross-section's skeleton edge).
    pub at: [f64; 3],
    /// Whether it was cut (a handle) or filled (a tunnel).
    pub performed: bool,
    /// Lattice points flipped to do it.
    pub points_changed: u64,
}

/// One edge of a skeleton, for a skeleton file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkeletonRecord {
    /// The pass: handles (the solid's skeleton) or tunnels (the outside's).
    pub kind: LoopKind,
    /// The area retracted onto it (infinite while it bounds a face).
    pub weight: f64,
    /// Its two ends in doubled lattice coordinates of the input grid (points at even
    /// coordinates; the outside's nodes are cells, at odd ones; −1 or 2n − 1 beyond the grid).
    pub ends: [[i64; 3]; 2],
    /// Whether it was cut or filled.
    pub removed: bool,
}

/// What [`repair`] found and did.
#[derive(Debug, Clone, Default)]
pub struct RepairReport {
    /// Every handle found (cut or not), thinnest first.
    pub handles: Vec<Operation>,
    /// Every tunnel found after cutting (filled or not), thinnest first.
    pub tunnels: Vec<Operation>,
    /// Lattice points flipped in all.
    pub points_changed: u64,
    /// The box of lattice points the complexes covered.
    pub box_points: [usize; 3],
    /// The skeletons' edges (empty unless asked for).
    pub skeleton: Vec<SkeletonRecord>,
    /// Thinning rounds of the two passes (0 when skipped).
    pub rounds: [u32; 2],
    /// Faces and cells thinning could not remove in each pass (beside the dual's border): the
    /// sheets a knotted solid's outside needs (its spine is two-dimensional). Loops they hold
    /// are found by a reduction over their faces ([`sheet_loops`]) and measured like the others.
    pub stuck: [u64; 2],
}

impl RepairReport {
    /// Handles cut.
    pub fn cuts(&self) -> impl Iterator<Item = &Operation> {
        self.handles.iter().filter(|o| o.performed)
    }
    /// Tunnels filled.
    pub fn fills(&self) -> impl Iterator<Item = &Operation> {
        self.tunnels.iter().filter(|o| o.performed)
    }
}

/// Cuts the small handles and fills the small tunnels of the solid inside `iso` in `grid`: around
/// every flipped point the values become sign-like (so MC33 cuts and joins where the complex
/// does), and the rest of the grid is untouched. With `skeleton`, the report
/// lists the skeletons' edges.
///
/// # Errors
/// [`Error::Limit`] when the solid's box needs more than [`CellComplex::MAX_ELEMENTS`]
/// elements (checked before allocating); [`Error::InvalidInput`] for a non-finite iso or
/// threshold.
pub fn repair(grid: &mut DenseGrid<f32>, iso: Iso, opts: &RepairOptions, skeleton: bool) -> Result<RepairReport> {
    if !iso.value.is_finite() || !opts.thin.is_finite() || !opts.grow.is_finite() {
        return Err(Error::InvalidInput(format!(
            "iso {}, thin {} and grow {} must be finite",
            iso.value, opts.thin, opts.grow
        )));
    }
    let lattice = grid.lattice().clone();
    let dims = lattice.dims().map(|d| d as i64);
    // The solid on the box around it, one point larger on every side (outside beyond the lattice).
    let is_solid = |v: f32| iso.offset(v as f64) < 0.0;
    let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
    for (i, &v) in grid.data().iter().enumerate() {
        if is_solid(v) {
            let p = lattice.ijk(i).map(i64::from);
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    let mut report = RepairReport::default();
    if lo[0] > hi[0] {
        return Ok(report);
    }
    let n = complex_box(lo, hi)?;
    let lo = lo.map(|v| v - MARGIN);
    report.box_points = n;
    let in_lattice = |p: [i64; 3]| (0..3).all(|a| p[a] >= 0 && p[a] < dims[a]);
    let mut inside = vec![false; n[0] * n[1] * n[2]];
    for (k, f) in inside.iter_mut().enumerate() {
        let p = [lo[0] + (k % n[0]) as i64, lo[1] + (k / n[0] % n[1]) as i64, lo[2] + (k / (n[0] * n[1])) as i64];
        *f = in_lattice(p) && is_solid(grid.data()[lattice.linear(p.map(|v| v as u32))]);
    }
    let original = inside.clone();
    let frame = Frame { lo, n, lattice: &lattice };
    // The handles on the solid's complex, then the tunnels on the dual of what is left outside.
    if opts.thin > 0.0 {
        let records = skeleton.then_some(&mut report.skeleton);
        let (ops, rounds, stuck) = run_pass(&mut inside, &frame, Pass::Closed, LoopKind::Handle, opts.thin, records);
        report.handles = ops;
        report.rounds[0] = rounds;
        report.stuck[0] = stuck;
    }
    if opts.grow > 0.0 {
        let records = skeleton.then_some(&mut report.skeleton);
        let (ops, rounds, stuck) = run_pass(&mut inside, &frame, Pass::Dual, LoopKind::Tunnel, opts.grow, records);
        report.tunnels = ops;
        report.rounds[1] = rounds;
        report.stuck[1] = stuck;
    }
    // Around each flipped point (two points each way) every value becomes sign-like: the
    // largest distance from the iso within three points, M, below the iso on the solid's side
    // and 3M on the other. On such data the trilinear interpolant MC33 follows is inside exactly
    // where the closed complex is (an outside three times stronger wins every saddle; checked
    // on random lattices in the tests), so the surface cuts and joins where the repair did.
    // Elsewhere nothing moves.
    let before = grid.data().to_vec();
    let dims = lattice.dims().map(i64::from);
    let in_box = |q: [i64; 3]| (0..3).all(|a| q[a] >= lo[a] && q[a] < lo[a] + n[a] as i64);
    let box_index =
        |q: [i64; 3]| ((q[0] - lo[0]) + n[0] as i64 * ((q[1] - lo[1]) + n[1] as i64 * (q[2] - lo[2]))) as usize;
    let mut magnitude: std::collections::HashMap<[i64; 3], f64> = Default::default();
    for (k, (&now, &was)) in inside.iter().zip(&original).enumerate() {
        if now == was {
            continue;
        }
        let p = [lo[0] + (k % n[0]) as i64, lo[1] + (k / n[0] % n[1]) as i64, lo[2] + (k / (n[0] * n[1])) as i64];
        if !in_lattice(p) {
            continue;
        }
        report.points_changed += 1;
        let mut reach = 0f64;
        for o in 0..343 {
            let q = [p[0] + o % 7 - 3, p[1] + o / 7 % 7 - 3, p[2] + o / 49 - 3];
            if in_lattice(q) {
                reach = reach.max((f64::from(before[lattice.linear(q.map(|v| v as u32))]) - iso.value).abs());
            }
        }
        for o in 0..125 {
            let q = [p[0] + o % 5 - 2, p[1] + o / 5 % 5 - 2, p[2] + o / 25 - 2];
            if (0..3).all(|a| q[a] >= 0 && q[a] < dims[a]) {
                let m = magnitude.entry(q).or_default();
                *m = m.max(reach);
            }
        }
    }
    let data = grid.data_mut();
    for (q, reach) in magnitude {
        let at = lattice.linear(q.map(|v| v as u32));
        let solid = if in_box(q) { inside[box_index(q)] } else { is_solid(before[at]) };
        data[at] = sign_like(iso, solid, reach);
    }
    Ok(report)
}

/// Points of outside around the solid's bounds in the complexes' box.
const MARGIN: i64 = 3;

/// The points per axis of the box [`repair`] builds its complexes on for a solid whose inside
/// points span `lo..=hi` (lattice indices): what a caller can check before building the grid
/// (e.g. from [`SignedOctree::inside_box`](crate::grid::SignedOctree::inside_box)).
///
/// # Errors
/// [`Error::Limit`] when the box needs more than [`CellComplex::MAX_ELEMENTS`] elements.
pub fn complex_box(lo: [i64; 3], hi: [i64; 3]) -> Result<[usize; 3]> {
    let n = [0, 1, 2].map(|a| (hi[a] - lo[a] + 2 * MARGIN + 1).max(0) as usize);
    let needed = CellComplex::elements_for(n, true);
    if needed > CellComplex::MAX_ELEMENTS {
        return Err(Error::Limit {
            what: "cell complex elements (the solid's box, doubled)",
            requested: needed,
            allowed: CellComplex::MAX_ELEMENTS,
        });
    }
    Ok(n)
}

/// `m` (at least a hair) past the iso on the solid's side, or `3m` on the other.
pub fn sign_like(iso: Iso, solid: bool, m: f64) -> f32 {
    let towards_below = solid == (iso.inside == Inside::Below);
    let m = m.max(iso.value.abs() * 1e-6).max(1e-6);
    let step = if solid { m } else { 3.0 * m };
    let mut v = (if towards_below { iso.value - step } else { iso.value + step }) as f32;
    while (iso.offset(v as f64) < 0.0) != solid {
        v = if towards_below { v.next_down() } else { v.next_up() };
    }
    v
}

/// Where the box sits in the input lattice.
struct Frame<'a> {
    lo: [i64; 3],
    n: [usize; 3],
    lattice: &'a crate::grid::Lattice,
}

impl Frame<'_> {
    fn world(&self, x: [i64; 3]) -> [f64; 3] {
        self.lattice.to_world(x.map(|v| v as f64 / 2.0))
    }
}

/// Which complex a pass thins.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// The closed side's complex; a performed loop takes its footprint's points out of it.
    Closed,
    /// The dual of the open side; a performed loop puts its footprint's faces' points in.
    Dual,
}

/// Thins one complex, finds its loops and performs those under `threshold`.
fn run_pass(
    inside: &mut [bool],
    frame: &Frame,
    pass: Pass,
    kind: LoopKind,
    threshold: f64,
    records: Option<&mut Vec<SkeletonRecord>>,
) -> (Vec<Operation>, u32, u64) {
    let mut c = match pass {
        Pass::Closed => CellComplex::of_solid(frame.n, inside),
        Pass::Dual => CellComplex::dual_of_complement(frame.n, inside),
    };
    let spacing = frame.lattice.spacing();
    let d2 = squared_distance_to_absent(&c, spacing.map(|h| h / 2.0));
    let whole = c.clone();
    // The dual's border layer stands for everything beyond the lattice: kept whole, so a
    // membrane cannot end on it (a tunnel is filled across its hole, not out to the box).
    let t = thin(&mut c, pass == Pass::Dual);
    let stuck = (0..c.len())
        .filter(|&i| c.contains(i) && c.dimension(i) >= 2 && !(pass == Pass::Dual && c.on_border(i)))
        .count() as u64;
    // The surface lies between the last point of a side and the first of the other: half a
    // spacing beyond the solid's complex and short of the outside's, on average (measured on
    // tori: without this, handles come out at 0.5–0.75 of π r², tunnels at 1.2–1.3 of π (R − r)²).
    let half = spacing.iter().sum::<f64>() / 6.0;
    let bias = if pass == Pass::Closed { half } else { -half };
    let edges = spanning_loops(&c, |e| {
        let r = local_thickness(&c, &d2, e, spacing).sqrt() + bias;
        std::f64::consts::PI * r.max(0.0).powi(2)
    });
    // Doubled box coordinates of an element of this complex (the dual's are shifted by one).
    let shift = |x: [usize; 3]| match pass {
        Pass::Closed => x.map(|v| v as i64),
        Pass::Dual => x.map(|v| v as i64 - 1),
    };
    let to_input = |x: [usize; 3]| {
        let b = shift(x);
        [0, 1, 2].map(|a| b[a] + 2 * frame.lo[a])
    };
    let reach = 3.0 * spacing.iter().copied().fold(0.0, f64::max);
    let area = [spacing[1] * spacing[2], spacing[0] * spacing[2], spacing[0] * spacing[1]];
    let mut loops: Vec<&SkeletonEdge> = edges.iter().filter(|e| e.closes_loop && e.weight.is_finite()).collect();
    loops.sort_by(|a, b| a.weight.total_cmp(&b.weight).then(a.element.cmp(&b.element)));
    let candidate_sets = loop_candidates(&c, &edges, &loops);
    let pull = PullBack::new(&whole, &t.pairs);
    let mut bits = vec![0u64; whole.len()];
    let sizes = membrane_sizes(&whole, &pull, &candidate_sets, area, &mut bits);
    let mut ops = Vec::new();
    let mut done = HashSet::new();
    for (set, sizes) in candidate_sets.iter().zip(&sizes) {
        // The loop's size: its smallest membrane, over every candidate of its cycle.
        let best = (0..set.len()).min_by(|&a, &b| sizes[a].total_cmp(&sizes[b])).expect("a loop has its edge");
        let edge = set[best].0;
        let x = c.coords(edge);
        let at = frame.world(to_input(x));
        let mut op = Operation { kind, size: sizes[best], at, performed: false, points_changed: 0 };
        if op.size < threshold {
            let components = components(inside, frame.n);
            let mut support = Vec::new();
            pull.play(&mut bits, &[set[best].1.as_slice()], |i, _| support.push(i));
            support.sort_unstable();
            let membrane: Vec<[i64; 3]> = support.iter().map(|&i| shift(whole.coords(i))).collect();
            // Which points make the membrane: a cut takes each edge's lower point (else its
            // upper, else both) out of the solid; a fill puts the four points of each primal
            // face the dual edges cross into it.
            let ends = |lower: bool, upper: bool| -> Vec<[i64; 3]> {
                let mut v = Vec::new();
                for m in &membrane {
                    let odd: Vec<usize> = (0..3).filter(|&a| m[a] % 2 != 0).collect();
                    for k in 0..1usize << odd.len() {
                        let mut p = *m;
                        for (bit, &a) in odd.iter().enumerate() {
                            p[a] += if k >> bit & 1 == 1 { 1 } else { -1 };
                        }
                        let up = odd.iter().enumerate().all(|(bit, _)| k >> bit & 1 == 1);
                        if pass == Pass::Dual || (up && upper) || (!up && lower) {
                            v.push(p);
                        }
                    }
                }
                v
            };
            let tries: Vec<Vec<[i64; 3]>> = match pass {
                Pass::Closed => vec![ends(true, false), ends(false, true), ends(true, true)],
                Pass::Dual => vec![ends(true, true)],
            };
            let mut flipped = Vec::new();
            for points in tries {
                flipped = try_flip(inside, frame, pass, &points, components);
                if !flipped.is_empty() {
                    break;
                }
            }
            if flipped.is_empty() {
                // A ball around the membrane's edge: it empties (or fills) the core first (a
                // cavity: refused), then opens it and severs the loop.
                let b = shift(x);
                let starts: Vec<[i64; 3]> = (0..8)
                    .map(|k| {
                        [0, 1, 2].map(|a| {
                            b[a] + if b[a] % 2 == 0 {
                                0
                            } else if k >> a & 1 == 0 {
                                -1
                            } else {
                                1
                            }
                        })
                    })
                    .collect();
                let radius = 3.0 * (d2[edge] as f64).sqrt() + reach;
                let from = pass == Pass::Closed;
                flipped =
                    grow_section(inside, frame, None, &starts, b.map(|v| v as f64 / 2.0), radius, from, components);
            }
            if !flipped.is_empty() {
                op.performed = true;
                op.points_changed = flipped.len() as u64;
                done.insert(edge);
            }
        }
        ops.push(op);
    }
    ops.sort_by(|a, b| a.size.total_cmp(&b.size));
    if let Some(records) = records {
        records.extend(edges.iter().map(|e| SkeletonRecord {
            kind,
            weight: e.weight,
            ends: e.ends.map(|p| to_input(c.coords(p))),
            removed: done.contains(&e.element),
        }));
    }
    (ops, t.rounds, stuck)
}

/// The skeleton edges of the cycle loop edge `e` closes through the spanning tree (`e` first),
/// those `usable`.
fn fundamental_cycle(edges: &[SkeletonEdge], e: &SkeletonEdge, usable: impl Fn(usize) -> bool) -> Vec<usize> {
    let mut next: std::collections::HashMap<usize, Vec<(usize, usize)>> = Default::default();
    for t in edges.iter().filter(|t| !t.closes_loop) {
        next.entry(t.ends[0]).or_default().push((t.ends[1], t.element));
        next.entry(t.ends[1]).or_default().push((t.ends[0], t.element));
    }
    // Breadth first from one end of `e` to the other through the tree.
    let mut came: std::collections::HashMap<usize, (usize, usize)> = Default::default();
    let mut queue = std::collections::VecDeque::from([e.ends[0]]);
    came.insert(e.ends[0], (usize::MAX, usize::MAX));
    while let Some(p) = queue.pop_front() {
        if p == e.ends[1] {
            break;
        }
        for &(q, via) in next.get(&p).map(Vec::as_slice).unwrap_or(&[]) {
            if let std::collections::hash_map::Entry::Vacant(v) = came.entry(q) {
                v.insert((p, via));
                queue.push_back(q);
            }
        }
    }
    let mut path = vec![e.element];
    let mut p = e.ends[1];
    while let Some(&(from, via)) = came.get(&p) {
        if via == usize::MAX {
            break;
        }
        path.push(via);
        p = from;
    }
    path.retain(|&x| x == e.element || usable(x));
    path
}

/// Each loop's candidate cocycles, each with the skeleton edge it stands at: for a loop of the
/// graph (`loops`), the indicator of every edge along its cycle that bounds no face left by
/// thinning (such an indicator is a cocycle); for a loop held by sheets ([`sheet_loops`]), its
/// one dual cocycle.
fn loop_candidates(c: &CellComplex, edges: &[SkeletonEdge], loops: &[&SkeletonEdge]) -> Vec<Vec<(usize, Vec<usize>)>> {
    let mut sets: Vec<Vec<(usize, Vec<usize>)>> = loops
        .iter()
        .map(|e| {
            let along = fundamental_cycle(edges, e, |x| c.present_cofaces(x).0 == 0);
            along.into_iter().map(|x| (x, vec![x])).collect()
        })
        .collect();
    sets.extend(sheet_loops(c, edges).into_iter().map(|l| vec![(l.element, l.cocycle)]));
    sets
}

/// Thinning's collapses that move a cochain, in the order a pull-back plays them (the last
/// collapse first): each edge collapsed with a face, with the face's three other edges. Points,
/// faces and cells collapsed carry no cochain of edges; an edge collapsed away from a point
/// takes 0, which its never-written bits already are.
struct PullBack {
    steps: Vec<[u32; 4]>,
}

impl PullBack {
    fn new(whole: &CellComplex, pairs: &[(u32, u32)]) -> Self {
        let steps = pairs
            .iter()
            .rev()
            .filter(|&&(s, _)| whole.dimension(s as usize) == 1)
            .map(|&(s, t)| {
                let mut step = [s; 4];
                for (k, (f, _)) in whole.faces(t as usize).filter(|&(f, _)| f != s as usize).enumerate() {
                    step[k + 1] = f as u32;
                }
                step
            })
            .collect();
        PullBack { steps }
    }

    /// Pulls up to 64 cocycles of the thinned complex (bit `k` for the one whose support is
    /// `supports[k]`) back onto the whole complex: an edge collapsed with a face takes the sum
    /// (mod 2) of the face's other edges. Each result is a cocycle whose support — a membrane of
    /// edges — crosses every loop its cocycle counts once: removing it cuts them there. Calls
    /// `visit` once for every edge of the whole complex with some bit set (`bits` is scratch of
    /// the whole complex's length, zero where no step writes; left so).
    ///
    /// A collapsed edge's bits are read only after they are written in the same play: when an
    /// edge is collapsed with a face, the face's other edges are still present, so they are
    /// collapsed later (played earlier) or never (the supports, or zero).
    fn play(&self, bits: &mut [u64], supports: &[&[usize]], mut visit: impl FnMut(usize, u64)) {
        assert!(supports.len() <= 64);
        for (k, support) in supports.iter().enumerate() {
            for &e in *support {
                bits[e] ^= 1 << k;
            }
        }
        for &[s, a, b, c] in &self.steps {
            let v = bits[a as usize] ^ bits[b as usize] ^ bits[c as usize];
            bits[s as usize] = v;
            if v != 0 {
                visit(s as usize, v);
            }
        }
        for support in supports {
            for &e in *support {
                if bits[e] != 0 {
                    visit(e, bits[e]);
                    bits[e] = 0;
                }
            }
        }
    }
}

/// The size of every candidate's membrane (squared model units: each edge counts its dual
/// quad, `area` by axis), 64 candidates — of any loops — to a play of the collapses (`bits`:
/// [`PullBack::play`]'s scratch).
fn membrane_sizes(
    whole: &CellComplex,
    pull: &PullBack,
    sets: &[Vec<(usize, Vec<usize>)>],
    area: [f64; 3],
    bits: &mut [u64],
) -> Vec<Vec<f64>> {
    let all: Vec<(usize, &[usize])> =
        sets.iter().enumerate().flat_map(|(l, set)| set.iter().map(move |(_, s)| (l, s.as_slice()))).collect();
    let mut counts = vec![[0u64; 3]; all.len()];
    for (batch, chunk) in all.chunks(64).enumerate() {
        let supports: Vec<&[usize]> = chunk.iter().map(|&(_, s)| s).collect();
        let counts = &mut counts[batch * 64..];
        pull.play(bits, &supports, |i, mut v| {
            let axis = whole.axis(i).expect("membranes are made of edges");
            while v != 0 {
                counts[v.trailing_zeros() as usize][axis] += 1;
                v &= v - 1;
            }
        });
    }
    let mut sizes: Vec<Vec<f64>> = sets.iter().map(|s| Vec::with_capacity(s.len())).collect();
    for ((l, _), n) in all.iter().zip(&counts) {
        sizes[*l].push((0..3).map(|a| n[a] as f64 * area[a]).sum());
    }
    sizes
}

/// Flips the given points (doubled box coordinates; beyond the box ignored) to the other side
/// (out of the solid for a cut, in for a fill) and keeps them when the solid has lost exactly
/// one loop (Euler characteristic up by one, components of both sides as `before`); otherwise
/// puts them back. The indices flipped.
fn try_flip(inside: &mut [bool], frame: &Frame, pass: Pass, points: &[[i64; 3]], before: (usize, usize)) -> Vec<usize> {
    let n = frame.n;
    let from = pass == Pass::Closed;
    let chi = CellComplex::of_solid(n, inside).euler();
    let mut flipped = Vec::new();
    for p in points {
        let q = p.map(|v| v.div_euclid(2));
        if p.iter().any(|v| v % 2 != 0) || (0..3).any(|a| q[a] < 0 || q[a] >= n[a] as i64) {
            continue;
        }
        let k = (q[0] + n[0] as i64 * (q[1] + n[1] as i64 * q[2])) as usize;
        if inside[k] == from {
            inside[k] = !from;
            flipped.push(k);
        }
    }
    if !flipped.is_empty() && CellComplex::of_solid(n, inside).euler() == chi + 1 && components(inside, n) == before {
        return flipped;
    }
    for k in flipped {
        inside[k] = from;
    }
    Vec::new()
}

/// The squared radius of the largest ball around an element near `e` (within two doubled
/// steps) that holds `e` and fits in the complex before thinning: the solid's reach around `e`
/// even where the skeleton runs a step off the middle.
fn local_thickness(c: &CellComplex, d2: &[f32], e: usize, spacing: [f64; 3]) -> f64 {
    let x = c.coords(e).map(|v| v as i64);
    let d = c.dims().map(|v| v as i64);
    let mut best = d2[e] as f64;
    for dz in -2..=2i64 {
        for dy in -2..=2i64 {
            for dx in -2..=2i64 {
                let y = [x[0] + dx, x[1] + dy, x[2] + dz];
                if (0..3).any(|a| y[a] < 0 || y[a] >= d[a]) {
                    continue;
                }
                let r2 = d2[c.index(y.map(|v| v as usize))] as f64;
                let gap = [dx, dy, dz].iter().zip(spacing).map(|(&k, h)| (k as f64 * h / 2.0).powi(2)).sum::<f64>();
                if gap <= r2 && r2 > best {
                    best = r2;
                }
            }
        }
    }
    best
}

/// The solid's components (points joined by edges) and the outside's (points joined through
/// any shared cell: the open complement's connectivity) on the box.
fn components(inside: &[bool], n: [usize; 3]) -> (usize, usize) {
    let mut sets = crate::math::UnionFind::new(inside.len());
    let index = |p: [usize; 3]| p[0] + n[0] * (p[1] + n[1] * p[2]);
    for z in 0..n[2] {
        for y in 0..n[1] {
            for x in 0..n[0] {
                let i = index([x, y, z]);
                // Half of the 26 neighbours (the later ones), the 3 along the axes for the solid.
                for o in NEXT {
                    let q = [x as i64 + o[0], y as i64 + o[1], z as i64 + o[2]];
                    if (0..3).any(|a| q[a] < 0 || q[a] >= n[a] as i64) {
                        continue;
                    }
                    let j = index(q.map(|v| v as usize));
                    let axial = o.iter().filter(|&&v| v != 0).count() == 1;
                    if inside[i] == inside[j] && (!inside[i] || axial) {
                        sets.union(i, j);
                    }
                }
            }
        }
    }
    let (mut solid, mut outside) = (0, 0);
    for i in 0..inside.len() {
        if sets.find(i) == i {
            if inside[i] {
                solid += 1;
            } else {
                outside += 1;
            }
        }
    }
    (solid, outside)
}

/// The 13 neighbour offsets after a point in x-fastest order.
const NEXT: [[i64; 3]; 13] = [
    [1, 0, 0],
    [-1, 1, 0],
    [0, 1, 0],
    [1, 1, 0],
    [-1, -1, 1],
    [0, -1, 1],
    [1, -1, 1],
    [-1, 0, 1],
    [0, 0, 1],
    [1, 0, 1],
    [-1, 1, 1],
    [0, 1, 1],
    [1, 1, 1],
];

/// Σ (−1)^dim over the elements around point `p` whose points are all in the solid, `p`
/// counted in: what the solid's Euler characteristic gains with `p` (or loses without it).
fn star_euler(inside: &[bool], n: [usize; 3], p: [i64; 3]) -> i64 {
    let at = |q: [i64; 3]| {
        (0..3).all(|a| q[a] >= 0 && q[a] < n[a] as i64)
            && (q == p || inside[(q[0] + n[0] as i64 * (q[1] + n[1] as i64 * q[2])) as usize])
    };
    let mut sum = 0;
    for o in 0..27 {
        let o = [o % 3 - 1, o / 3 % 3 - 1, o / 9 - 1];
        let axes: Vec<usize> = (0..3).filter(|&a| o[a] != 0).collect();
        let all = (0..1 << axes.len()).all(|k| {
            let mut q = p;
            for (bit, &a) in axes.iter().enumerate() {
                q[a] += if k >> bit & 1 == 1 { o[a] } else { 0 };
            }
            at(q)
        });
        if all {
            sum += if axes.len().is_multiple_of(2) { 1 } else { -1 };
        }
    }
    sum
}

/// Flips points holding `from` in the plane across `axis` at `level` (`section`; a ball when
/// `None`), nearest to `centre` first, spreading from `starts` (doubled box coordinates; those
/// at points) through neighbours in the section within `radius` (world units), until the solid has lost exactly one loop: its Euler characteristic
/// up by one with its components and the outside's as `before`. The indices flipped; none
/// (everything put back) when no such section is found.
#[allow(clippy::too_many_arguments)]
fn grow_section(
    inside: &mut [bool],
    frame: &Frame,
    section: Option<(usize, i64)>,
    starts: &[[i64; 3]],
    centre: [f64; 3],
    radius: f64,
    from: bool,
    before: (usize, usize),
) -> Vec<usize> {
    use std::cmp::Reverse;
    use std::collections::{BinaryHeap, HashSet};
    let n = frame.n;
    let h = frame.lattice.spacing();
    let (axis, level) = section.unwrap_or((3, 0));
    let gap =
        |p: [i64; 3]| (0..3).filter(|&a| a != axis).map(|a| ((p[a] as f64 - centre[a]) * h[a]).powi(2)).sum::<f64>();
    let index = |p: [i64; 3]| (p[0] + n[0] as i64 * (p[1] + n[1] as i64 * p[2])) as usize;
    let usable = |inside: &[bool], p: [i64; 3]| {
        (0..3).all(|a| p[a] >= 0 && p[a] < n[a] as i64) && inside[index(p)] == from && gap(p) <= radius * radius
    };
    let mut heap = BinaryHeap::new();
    let mut seen = HashSet::new();
    for s in starts.iter().filter(|s| s.iter().all(|v| v % 2 == 0)) {
        let p = s.map(|v| v / 2);
        if (axis == 3 || p[axis] == level) && usable(inside, p) && seen.insert(p) {
            heap.push((Reverse(gap(p).to_bits()), p));
        }
    }
    let mut flipped = Vec::new();
    let mut chi = 0;
    // Each check of the components walks the box: a ball that has passed this many states of
    // the right Euler characteristic without the right components will not find one (a knot's
    // outside: no ball fills its loop), so it stops.
    let mut checks = 0;
    while let Some((_, p)) = heap.pop() {
        let k = index(p);
        if from {
            chi -= star_euler(inside, n, p);
            inside[k] = false;
        } else {
            inside[k] = true;
            chi += star_euler(inside, n, p);
        }
        flipped.push(k);
        if chi == 1 {
            if components(inside, n) == before {
                return flipped;
            }
            checks += 1;
            if checks == MAX_COMPONENT_CHECKS {
                break;
            }
        }
        for a in (0..3).filter(|&a| a != axis) {
            for d in [-1, 1] {
                let mut q = p;
                q[a] += d;
                if usable(inside, q) && seen.insert(q) {
                    heap.push((Reverse(gap(q).to_bits()), q));
                }
            }
        }
    }
    for k in flipped {
        inside[k] = from;
    }
    Vec::new()
}

/// Component checks a ball of [`grow_section`] makes at most.
const MAX_COMPONENT_CHECKS: u32 = 16;

#[cfg(test)]
mod tests;
