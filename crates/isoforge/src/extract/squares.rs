//! Marching squares: isolines of a 2D image (or of one slice of a volume) as oriented polylines.
//!
//! The 2D member of the extractor family, with the same conventions as the 3D ones: inside ⇔
//! value below iso (ties outside, or above with [`Inside::Above`](crate::volume::Inside)), one
//! vertex per crossed pixel edge shared by the two cells beside it, and saddle cells resolved by
//! the asymptotic decider (\[Nielson91\]; the same exact test as MC33's faces) unless a fixed rule is
//! asked for.
//!
//! ```text
//!   c3 (i, j+1) ── e23 ── c2 (i+1, j+1)      cell (i, j); corners counter-clockwise with y up
//!      │                     │               (in an image, whose rows go down, they run clockwise)
//!     e30                   e12
//!      │                     │
//!   c0 (i, j)  ── e01 ── c1 (i+1, j)
//! ```
//!
//! Contours run counter-clockwise around inside regions (y up), i.e. the inside is on their left;
//! a contour is closed, or open with both ends on the image border.

use super::mc33::saddle_inside;
use crate::volume::Iso;

/// How saddle cells (inside corners on one diagonal, outside on the other) are resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Saddle {
    /// The bilinear interpolant decides (its saddle value against iso): topologically correct.
    #[default]
    Decider,
    /// Inside corners always join across the cell (scikit-image `fully_connected='low'` for inside
    /// = below).
    JoinInside,
    /// Outside corners always join (scikit-image's default `fully_connected='low'` when inside is
    /// above, or `'high'` for inside below).
    JoinOutside,
}

/// One isoline: points in pixel-index coordinates (x = column i, y = row j).
#[derive(Debug, Clone, PartialEq)]
pub struct Polyline {
    /// The points; for a closed contour the first point is not repeated at the end.
    pub points: Vec<[f64; 2]>,
    /// Whether the contour closes on itself (otherwise both ends lie on the image border).
    pub closed: bool,
}

impl Polyline {
    /// Euclidean length, including the closing segment of a closed contour.
    pub fn length(&self) -> f64 {
        let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let open: f64 = self.points.windows(2).map(|w| d(w[0], w[1])).sum();
        match (self.closed, self.points.first(), self.points.last()) {
            (true, Some(&a), Some(&b)) => open + d(b, a),
            _ => open,
        }
    }

    /// Signed area (shoelace, y up): positive for a counter-clockwise closed contour.
    pub fn signed_area(&self) -> f64 {
        let n = self.points.len();
        (0..n)
            .map(|k| {
                let (a, b) = (self.points[k], self.points[(k + 1) % n]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum::<f64>()
            / 2.0
    }
}

const NONE: u32 = u32::MAX;

/// The isolines of an `nx × ny` image (row-major, x fastest) at `iso`.
///
/// Open contours come first in the order of their starting edge, then closed ones; each starts at
/// its lowest-numbered edge (horizontal edges row by row, then vertical edges).
///
/// # Panics
/// When `values.len() != nx · ny`.
pub fn marching_squares(dims: [u32; 2], values: &[f64], iso: Iso, saddle: Saddle) -> Vec<Polyline> {
    let [nx, ny] = dims.map(|d| d as usize);
    assert_eq!(values.len(), nx * ny, "marching_squares: {} values for {nx} × {ny}", values.len());
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let d: Vec<f32> = values.iter().map(|&v| iso.offset(v)).collect();
    let horizontal = (nx - 1) * ny;
    let h = |i: usize, j: usize| (j * (nx - 1) + i) as u32; // edge (i, j) → (i + 1, j)
    let v = |i: usize, j: usize| (horizontal + j * nx + i) as u32; // edge (i, j) → (i, j + 1)
    let edges = horizontal + nx * (ny - 1);
    let mut next = vec![NONE; edges];
    let mut has_prev = vec![false; edges];
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let c = [j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i].map(|k| d[k]);
            let inside = c.map(|x| x < 0.0);
            let ring = [h(i, j), v(i + 1, j), h(i, j + 1), v(i, j)];
            let mut xs = [(0u32, false); 4];
            let mut n = 0;
            for k in 0..4 {
                if inside[k] != inside[(k + 1) % 4] {
                    xs[n] = (ring[k], inside[k]);
                    n += 1;
                }
            }
            let mut link = |from: u32, to: u32| {
                next[from as usize] = to;
                has_prev[to as usize] = true;
            };
            match n {
                2 => {
                    let (exit, entry) = if xs[0].1 { (xs[0].0, xs[1].0) } else { (xs[1].0, xs[0].0) };
                    link(exit, entry);
                }
                4 => {
                    let centre_in = match saddle {
                        Saddle::Decider => saddle_inside(c[0] as f64, c[1] as f64, c[2] as f64, c[3] as f64),
                        Saddle::JoinInside => true,
                        Saddle::JoinOutside => false,
                    };
                    for k in 0..4 {
                        if xs[k].1 {
                            let m = if centre_in { (k + 1) % 4 } else { (k + 3) % 4 };
                            link(xs[k].0, xs[m].0);
                        }
                    }
                }
                _ => {}
            }
        }
    }
    let point = |e: u32| -> [f64; 2] {
        let e = e as usize;
        let (a, b, axis) = if e < horizontal {
            let (i, j) = (e % (nx - 1), e / (nx - 1));
            (j * nx + i, j * nx + i + 1, 0)
        } else {
            let k = e - horizontal;
            (k, k + nx, 1)
        };
        let (da, db) = (d[a] as f64, d[b] as f64);
        let t = if da == db { 0.5 } else { (da / (da - db)).clamp(0.0, 1.0) };
        let mut p = [(a % nx) as f64, (a / nx) as f64];
        p[axis] += t;
        p
    };
    let mut seen = vec![false; edges];
    let mut out = Vec::new();
    let follow = |start: u32, closed: bool, seen: &mut Vec<bool>| {
        let mut pts = Vec::new();
        let mut e = start;
        while e != NONE && !seen[e as usize] {
            seen[e as usize] = true;
            pts.push(point(e));
            e = next[e as usize];
        }
        Polyline { points: pts, closed }
    };
    // Open contours start on an edge with a successor and no predecessor (the image border).
    for e in 0..edges as u32 {
        if next[e as usize] != NONE && !has_prev[e as usize] && !seen[e as usize] {
            out.push(follow(e, false, &mut seen));
        }
    }
    for e in 0..edges as u32 {
        if next[e as usize] != NONE && !seen[e as usize] {
            out.push(follow(e, true, &mut seen));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(nx: usize, ny: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
        (0..nx * ny).map(|k| f((k % nx) as f64, (k / nx) as f64)).collect()
    }

    #[test]
    fn a_circle_is_one_closed_counter_clockwise_contour_of_the_right_length() {
        let (n, r) = (101usize, 30.0);
        let img = image(n, n, |x, y| ((x - 50.0).powi(2) + (y - 50.3).powi(2)).sqrt());
        let c = marching_squares([n as u32, n as u32], &img, Iso::below(r), Saddle::Decider);
        assert_eq!(c.len(), 1);
        assert!(c[0].closed);
        assert!(c[0].signed_area() > 0.0, "inside on the left");
        let len = c[0].length();
        assert!((len - 2.0 * std::f64::consts::PI * r).abs() / len < 2e-3, "length {len}");
        // Inside above: same points, the other way round.
        let a = marching_squares([n as u32, n as u32], &img, Iso::above(r), Saddle::Decider);
        assert!(a[0].signed_area() < 0.0);
        assert!((a[0].length() - len).abs() < 1e-9);
    }

    #[test]
    fn a_contour_leaving_the_image_is_open_with_ends_on_the_border() {
        let img = image(10, 8, |x, _| x);
        let c = marching_squares([10, 8], &img, Iso::below(4.5), Saddle::Decider);
        assert_eq!(c.len(), 1);
        assert!(!c[0].closed);
        assert_eq!(c[0].points.len(), 8);
        let (a, b) = (c[0].points[0], *c[0].points.last().unwrap());
        assert!(a[1] == 0.0 || a[1] == 7.0);
        assert!(b[1] == 0.0 || b[1] == 7.0);
        assert!((c[0].length() - 7.0).abs() < 1e-12);
    }

    #[test]
    fn saddles_follow_the_decider_or_the_fixed_rule() {
        // 2 × 2 saddle: inside on the diagonal (0, 0)–(1, 1).
        let deep = [-3.0, 1.0, 1.0, -3.0]; // centre −1 < 0: inside joins
        let shallow = [-1.0, 3.0, 3.0, -1.0]; // centre +1: inside separated
        let count = |v: &[f64], s| marching_squares([2, 2], v, Iso::below(0.0), s).len();
        assert_eq!(count(&deep, Saddle::Decider), 2);
        assert_eq!(count(&shallow, Saddle::Decider), 2);
        // Joined or not shows in which edges pair: the decider's pairing differs between the two.
        let pairs = |v: &[f64], s| {
            let c = marching_squares([2, 2], v, Iso::below(0.0), s);
            let mut ends: Vec<[i64; 4]> = c
                .iter()
                .map(|p| {
                    let (a, b) = (p.points[0], p.points[1]);
                    [a[0], a[1], b[0], b[1]].map(|x| (x * 4.0).round() as i64)
                })
                .collect();
            ends.sort();
            ends
        };
        assert_eq!(pairs(&deep, Saddle::Decider), pairs(&deep, Saddle::JoinInside));
        assert_eq!(pairs(&shallow, Saddle::Decider), pairs(&shallow, Saddle::JoinOutside));
        assert_ne!(pairs(&deep, Saddle::JoinInside), pairs(&deep, Saddle::JoinOutside));
    }

    #[test]
    fn every_contour_of_a_field_inside_the_image_is_closed() {
        // Several blobs and a ring, all away from the border.
        let img = image(120, 90, |x, y| {
            let b = |cx: f64, cy: f64, r: f64| ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - r;
            b(30.0, 30.0, 12.0).min(b(80.0, 40.0, 20.0).abs() - 4.0).min(b(60.0, 70.0, 6.5))
        });
        let c = marching_squares([120, 90], &img, Iso::below(0.0), Saddle::Decider);
        assert_eq!(c.len(), 4, "blob, ring (outer and inner), small blob");
        assert!(c.iter().all(|p| p.closed));
        // The ring's hole is wound the other way.
        assert_eq!(c.iter().filter(|p| p.signed_area() < 0.0).count(), 1);
    }
}
