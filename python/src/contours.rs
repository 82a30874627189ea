//! `find_contours` with scikit-image's exact output: the same segments per square (its case
//! table's directions, squares in row-major order, `value > level` above), masked-out and NaN
//! squares skipped, then joined into polylines in the order scikit-image joins them, so closed
//! contours start at the same point. Written from its documented behaviour, not its code.

use std::collections::{BTreeMap, HashMap, VecDeque};

type Point = [f64; 2];

fn key(p: Point) -> (u64, u64) {
    // +0.0 folds −0.0 into 0.0: points are compared by value.
    ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits())
}

fn fraction(from: f64, to: f64, level: f64) -> f64 {
    if to == from {
        0.0
    } else {
        (level - from) / (to - from)
    }
}

/// The oriented segments (low values on the left going from the first point to the second) of
/// the `rows × cols` image `v` (row-major), squares with a corner out of `mask` or NaN skipped.
pub fn segments(
    v: &[f64],
    rows: usize,
    cols: usize,
    level: f64,
    connect_high: bool,
    mask: Option<&[bool]>,
) -> Vec<[Point; 2]> {
    let mut out = Vec::new();
    for r0 in 0..rows.saturating_sub(1) {
        for c0 in 0..cols.saturating_sub(1) {
            let (r1, c1) = (r0 + 1, c0 + 1);
            let at = |r: usize, c: usize| r * cols + c;
            if let Some(m) = mask {
                if !(m[at(r0, c0)] && m[at(r0, c1)] && m[at(r1, c0)] && m[at(r1, c1)]) {
                    continue;
                }
            }
            let (ul, ur, ll, lr) = (v[at(r0, c0)], v[at(r0, c1)], v[at(r1, c0)], v[at(r1, c1)]);
            if ul.is_nan() || ur.is_nan() || ll.is_nan() || lr.is_nan() {
                continue;
            }
            let case = u8::from(ul > level)
                | u8::from(ur > level) << 1
                | u8::from(ll > level) << 2
                | u8::from(lr > level) << 3;
            if case == 0 || case == 15 {
                continue;
            }
            let (rf, cf) = (r0 as f64, c0 as f64);
            let top = [rf, cf + fraction(ul, ur, level)];
            let bottom = [rf + 1.0, cf + fraction(ll, lr, level)];
            let left = [rf + fraction(ul, ll, level), cf];
            let right = [rf + fraction(ur, lr, level), cf + 1.0];
            let mut seg = |a: Point, b: Point| out.push([a, b]);
            match case {
                1 => seg(top, left),
                2 => seg(right, top),
                3 => seg(right, left),
                4 => seg(left, bottom),
                5 => seg(top, bottom),
                6 if connect_high => {
                    seg(left, top);
                    seg(right, bottom);
                }
                6 => {
                    seg(right, top);
                    seg(left, bottom);
                }
                7 => seg(right, bottom),
                8 => seg(bottom, right),
                9 if connect_high => {
                    seg(top, right);
                    seg(bottom, left);
                }
                9 => {
                    seg(top, left);
                    seg(bottom, right);
                }
                10 => seg(bottom, top),
                11 => seg(bottom, left),
                12 => seg(left, right),
                13 => seg(top, right),
                _ => seg(left, top),
            }
        }
    }
    out
}

/// Joins segments into polylines: a segment extends the line ending at its start or starting at
/// its end; when it does both, the two lines merge into the older one (or the line closes, its
/// first point repeated at its end). Lines in the order their first segment came.
pub fn assemble(segments: &[[Point; 2]]) -> Vec<Vec<Point>> {
    let mut lines: BTreeMap<usize, VecDeque<Point>> = BTreeMap::new();
    let mut starts: HashMap<(u64, u64), usize> = HashMap::new();
    let mut ends: HashMap<(u64, u64), usize> = HashMap::new();
    let mut next = 0;
    for &[from, to] in segments {
        if key(from) == key(to) {
            continue;
        }
        let tail = starts.remove(&key(to));
        let head = ends.remove(&key(from));
        match (tail, head) {
            (Some(t), Some(h)) if t == h => {
                if let Some(l) = lines.get_mut(&h) {
                    l.push_back(to);
                }
            }
            (Some(t), Some(h)) => {
                let (Some(tl), Some(hl)) = (lines.remove(&t), lines.remove(&h)) else { continue };
                if t > h {
                    let mut l = hl;
                    l.extend(tl);
                    starts.insert(key(l[0]), h);
                    ends.insert(key(l[l.len() - 1]), h);
                    lines.insert(h, l);
                } else {
                    starts.remove(&key(hl[0]));
                    let mut l = hl;
                    l.extend(tl);
                    starts.insert(key(l[0]), t);
                    ends.insert(key(l[l.len() - 1]), t);
                    lines.insert(t, l);
                }
            }
            (None, None) => {
                lines.insert(next, VecDeque::from([from, to]));
                starts.insert(key(from), next);
                ends.insert(key(to), next);
                next += 1;
            }
            (Some(t), None) => {
                if let Some(l) = lines.get_mut(&t) {
                    l.push_front(from);
                }
                starts.insert(key(from), t);
            }
            (None, Some(h)) => {
                if let Some(l) = lines.get_mut(&h) {
                    l.push_back(to);
                }
                ends.insert(key(to), h);
            }
        }
    }
    lines.into_values().map(Vec::from).collect()
}
