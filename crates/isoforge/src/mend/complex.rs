//! The cubical cell complex of a lattice, in doubled coordinates.
//!
//! Every element of the lattice's cubical complex has one address `x` in a grid twice as fine:
//! a coordinate is even where the element sits on a lattice plane and odd where it spans the
//! interval between two planes, so the element's dimension is its number of odd coordinates.
//!
//! ```text
//!   x = (2i, 2j, 2k)        a point (dimension 0)
//!   x = (2i+1, 2j, 2k)      an edge along x (dimension 1)
//!   x = (2i+1, 2j+1, 2k)    a face across z (dimension 2)
//!   x = (2i+1, 2j+1, 2k+1)  a cell (dimension 3)
//!
//!   faces of x:    x ± e_a for every odd coordinate a    (the boundary: one dimension less)
//!   cofaces of x:  x ± e_a for every even coordinate a   (one dimension more)
//! ```
//!
//! A *solid* is a set of points; its complex holds the elements whose points are all in it
//! (closed under faces). The rest of the elements — those with at least one point not in the
//! solid — form an open set whose **dual** is again a complex: element `x` maps to `x + 1` in a
//! grid one element larger on every side (parity flips, so dimensions become 3 − d), and the
//! elements beyond the lattice are in it. Thinning the dual is thinning the outside.

/// A cubical complex on a doubled grid: which elements are present.
#[derive(Debug, Clone)]
pub struct CellComplex {
    /// Elements per axis (doubled coordinates).
    dims: [usize; 3],
    /// Strides of the three axes in `present`.
    strides: [usize; 3],
    /// 1 where the element is present.
    present: Vec<u8>,
}

impl CellComplex {
    /// The most elements a complex may hold (2²⁸: a few hundred megabytes with thinning's
    /// weights and links; about 323³ lattice points).
    pub const MAX_ELEMENTS: u64 = 1 << 28;

    /// The elements a complex on `points` lattice points needs (its dual: one more per side).
    pub fn elements_for(points: [usize; 3], dual: bool) -> u64 {
        let extra = if dual { 2 } else { 0 };
        points.iter().map(|&n| (2 * n as u64).saturating_sub(1) + extra).product()
    }

    /// The complex of the solid `solid` (one flag per lattice point, x fastest) on `points`:
    /// an element is present when all its points are in the solid.
    ///
    /// # Panics
    /// When `solid.len()` is not the number of points or the complex is over
    /// [`CellComplex::MAX_ELEMENTS`] (callers check [`CellComplex::elements_for`] first).
    pub fn of_solid(points: [usize; 3], solid: &[bool]) -> Self {
        let mut c = Self::empty(points.map(|n| 2 * n - 1));
        let [nx, ny, _] = points;
        for (i, &s) in solid.iter().enumerate() {
            let p = [i % nx, i / nx % ny, i / (nx * ny)];
            let x = c.index([2 * p[0], 2 * p[1], 2 * p[2]]);
            c.present[x] = s as u8;
        }
        c.close_over_points();
        c
    }

    /// The dual of the open complement of [`CellComplex::of_solid`]: element `y` is present
    /// when the primal element `y − 1` has a point outside the solid or lies beyond the lattice.
    pub fn dual_of_complement(points: [usize; 3], solid: &[bool]) -> Self {
        let primal = Self::of_solid(points, solid);
        let mut c = Self::empty(points.map(|n| 2 * n + 1));
        let d = c.dims;
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    let y_at = [x, y, z];
                    let beyond = (0..3).any(|a| y_at[a] == 0 || y_at[a] == d[a] - 1);
                    let present = beyond || primal.present[primal.index([x - 1, y - 1, z - 1])] == 0;
                    let i = c.index(y_at);
                    c.present[i] = present as u8;
                }
            }
        }
        c
    }

    fn empty(dims: [usize; 3]) -> Self {
        let n = dims.iter().map(|&d| d as u64).product::<u64>();
        assert!(n <= Self::MAX_ELEMENTS, "complex of {n} elements");
        CellComplex { dims, strides: [1, dims[0], dims[0] * dims[1]], present: vec![0; n as usize] }
    }

    /// Sets every element of dimension > 0 to the AND of its points, axis by axis.
    fn close_over_points(&mut self) {
        let d = self.dims;
        for a in 0..3 {
            let s = self.strides[a];
            for z in 0..d[2] {
                for y in 0..d[1] {
                    for x in 0..d[0] {
                        let at = [x, y, z];
                        // Axes below `a` are already closed; axes above must still be points.
                        if at[a] % 2 == 0 || (a + 1..3).any(|b| at[b] % 2 == 1) {
                            continue;
                        }
                        let i = self.index(at);
                        self.present[i] = self.present[i - s] & self.present[i + s];
                    }
                }
            }
        }
    }

    /// Elements per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Total elements (present or not).
    pub fn len(&self) -> usize {
        self.present.len()
    }

    /// Whether the grid holds no element.
    pub fn is_empty(&self) -> bool {
        self.present.is_empty()
    }

    /// The index of doubled coordinates `x`.
    #[inline]
    pub fn index(&self, x: [usize; 3]) -> usize {
        x[0] + x[1] * self.strides[1] + x[2] * self.strides[2]
    }

    /// The doubled coordinates of index `i`.
    #[inline]
    pub fn coords(&self, i: usize) -> [usize; 3] {
        [i % self.dims[0], i / self.dims[0] % self.dims[1], i / self.strides[2]]
    }

    /// Whether element `i` is present.
    #[inline]
    pub fn contains(&self, i: usize) -> bool {
        self.present[i] != 0
    }

    /// Removes element `i`.
    #[inline]
    pub(crate) fn remove(&mut self, i: usize) {
        self.present[i] = 0;
    }

    /// Whether element `i` lies on the grid's outer layer.
    #[inline]
    pub fn on_border(&self, i: usize) -> bool {
        let x = self.coords(i);
        (0..3).any(|a| x[a] == 0 || x[a] + 1 == self.dims[a])
    }

    /// The dimension of element `i` (its odd coordinates).
    #[inline]
    pub fn dimension(&self, i: usize) -> u32 {
        self.coords(i).iter().map(|&c| (c & 1) as u32).sum()
    }

    /// The axis an edge runs along (its one odd coordinate), or a face's normal (its one even
    /// coordinate); `None` for points and cells.
    pub fn axis(&self, i: usize) -> Option<usize> {
        let x = self.coords(i);
        match self.dimension(i) {
            1 => (0..3).find(|&a| x[a] % 2 == 1),
            2 => (0..3).find(|&a| x[a].is_multiple_of(2)),
            _ => None,
        }
    }

    /// The faces of element `i` (present or not), with the axis each lies across.
    #[inline]
    pub fn faces(&self, i: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        let x = self.coords(i);
        (0..3).filter(move |&a| x[a] % 2 == 1).flat_map(move |a| [(i - self.strides[a], a), (i + self.strides[a], a)])
    }

    /// The cofaces of element `i` within the grid (present or not).
    #[inline]
    pub fn cofaces(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let x = self.coords(i);
        (0..3).filter(move |&a| x[a].is_multiple_of(2)).flat_map(move |a| {
            let lo = (x[a] > 0).then(|| i - self.strides[a]);
            let hi = (x[a] + 1 < self.dims[a]).then(|| i + self.strides[a]);
            lo.into_iter().chain(hi)
        })
    }

    /// The present cofaces of `i`: how many, and one of them.
    #[inline]
    pub fn present_cofaces(&self, i: usize) -> (u32, usize) {
        let mut n = 0;
        let mut one = usize::MAX;
        for c in self.cofaces(i) {
            if self.contains(c) {
                n += 1;
                one = c;
            }
        }
        (n, one)
    }

    /// Present elements by dimension.
    pub fn counts(&self) -> [u64; 4] {
        let mut n = [0u64; 4];
        for i in 0..self.len() {
            if self.contains(i) {
                n[self.dimension(i) as usize] += 1;
            }
        }
        n
    }

    /// The Euler characteristic of the present elements (Σ (−1)^d · count).
    pub fn euler(&self) -> i64 {
        let n = self.counts();
        n[0] as i64 - n[1] as i64 + n[2] as i64 - n[3] as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ball(n: usize, r: f64) -> Vec<bool> {
        let c = (n - 1) as f64 / 2.0;
        (0..n * n * n)
            .map(|i| {
                let p = [i % n, i / n % n, i / (n * n)].map(|v| v as f64 - c);
                p[0] * p[0] + p[1] * p[1] + p[2] * p[2] < r * r
            })
            .collect()
    }

    #[test]
    fn a_solid_ball_and_its_outside_have_the_euler_characteristics_of_a_ball_and_a_shell() {
        let n = 12;
        let solid = ball(n, 4.2);
        let c = CellComplex::of_solid([n; 3], &solid);
        assert_eq!(c.euler(), 1, "a ball is contractible");
        // The outside of a ball in a box, with the box's border layer: a thick sphere (χ = 2).
        let d = CellComplex::dual_of_complement([n; 3], &solid);
        assert_eq!(d.euler(), 2);
    }

    #[test]
    fn one_point_makes_one_element_and_a_full_cube_all_27() {
        let c = CellComplex::of_solid([2; 3], &[true, false, false, false, false, false, false, false]);
        assert_eq!(c.counts(), [1, 0, 0, 0]);
        let c = CellComplex::of_solid([2; 3], &[true; 8]);
        assert_eq!(c.counts(), [8, 12, 6, 1]);
        assert_eq!(c.euler(), 1);
    }

    #[test]
    fn faces_and_cofaces_are_inverse() {
        let c = CellComplex::of_solid([3; 3], &[true; 27]);
        for i in 0..c.len() {
            for (f, _) in c.faces(i) {
                assert!(c.cofaces(f).any(|x| x == i));
                assert_eq!(c.dimension(f) + 1, c.dimension(i));
            }
        }
    }
}
