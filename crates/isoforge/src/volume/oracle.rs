//! Root finders for the crossing of a continuous field on an edge.

/// Finds where `g` changes class (`g < 0` inside, `g ≥ 0` outside) on [0, 1].
pub trait Oracle {
    /// The parameter of the crossing, given `g0 = g(0)` and `g1 = g(1)` of opposite class.
    fn root(&self, g: impl Fn(f32) -> f32, g0: f32, g1: f32) -> f32;
}

/// Linear interpolation of the end values: no evaluation (what sampled grids use).
#[derive(Debug, Clone, Copy, Default)]
pub struct Linear;

impl Oracle for Linear {
    #[inline]
    fn root(&self, _g: impl Fn(f32) -> f32, g0: f32, g1: f32) -> f32 {
        super::linear_crossing(g0, g1)
    }
}

/// Bisection to `tolerance` (in edge-length units), then linear within the last bracket.
#[derive(Debug, Clone, Copy)]
pub struct Bisection {
    /// Bracket width at which to stop, as a fraction of the edge.
    pub tolerance: f32,
    /// Most evaluations.
    pub max_iterations: u32,
}

impl Default for Bisection {
    fn default() -> Self {
        Bisection { tolerance: 1e-5, max_iterations: 24 }
    }
}

impl Oracle for Bisection {
    fn root(&self, g: impl Fn(f32) -> f32, g0: f32, g1: f32) -> f32 {
        let (mut a, mut b, mut ga, mut gb) = (0.0f32, 1.0f32, g0, g1);
        let inside_a = g0 < 0.0;
        for _ in 0..self.max_iterations {
            if b - a <= self.tolerance {
                break;
            }
            let m = 0.5 * (a + b);
            let gm = g(m);
            if (gm < 0.0) == inside_a {
                (a, ga) = (m, gm);
            } else {
                (b, gb) = (m, gm);
            }
        }
        a + (b - a) * super::linear_crossing(ga, gb)
    }
}

/// Illinois (modified regula falsi): superlinear on smooth fields, never leaves its bracket.
#[derive(Debug, Clone, Copy)]
pub struct Illinois {
    /// Bracket width at which to stop, as a fraction of the edge.
    pub tolerance: f32,
    /// Most evaluations.
    pub max_iterations: u32,
}

impl Default for Illinois {
    fn default() -> Self {
        Illinois { tolerance: 1e-5, max_iterations: 16 }
    }
}

impl Oracle for Illinois {
    fn root(&self, g: impl Fn(f32) -> f32, g0: f32, g1: f32) -> f32 {
        let (mut a, mut b, mut ga, mut gb) = (0.0f32, 1.0f32, g0, g1);
        let inside_a = g0 < 0.0;
        let mut last_side = 0i8;
        for _ in 0..self.max_iterations {
            let t = a + (b - a) * super::linear_crossing(ga, gb);
            let gt = g(t);
            if (gt < 0.0) == inside_a {
                (a, ga) = (t, gt);
                if last_side == -1 {
                    gb *= 0.5; // Illinois step: the stale end would otherwise stall the bracket.
                }
                last_side = -1;
            } else {
                (b, gb) = (t, gt);
                if last_side == 1 {
                    ga *= 0.5;
                }
                last_side = 1;
            }
            if b - a <= self.tolerance || gt == 0.0 {
                break;
            }
        }
        a + (b - a) * super::linear_crossing(ga, gb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check<O: Oracle>(o: O) {
        // g(t) = t² − 0.3 has its root at √0.3.
        let g = |t: f32| t * t - 0.3;
        let t = o.root(g, g(0.0), g(1.0));
        assert!((t - 0.3f32.sqrt()).abs() < 1e-4, "{t}");
        // Reversed classes.
        let h = |t: f32| 0.3 - t * t;
        let t = o.root(h, h(0.0), h(1.0));
        assert!((t - 0.3f32.sqrt()).abs() < 1e-4, "{t}");
    }

    #[test]
    fn oracles_find_roots() {
        check(Bisection::default());
        check(Illinois::default());
        let t = Linear.root(|_| unreachable!(), -1.0, 3.0);
        assert_eq!(t, 0.25);
    }
}
