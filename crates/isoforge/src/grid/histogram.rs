use super::AnyGrid;

/// A histogram of a grid's values over `[min, max]` in equal bins, with summary statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Mean value.
    pub mean: f64,
    /// Sample count per bin (bin `b` covers `[min + b·w, min + (b+1)·w)`, the last one closed).
    pub counts: Vec<u64>,
}

impl Histogram {
    /// The histogram of `grid` in `bins` bins (at least 1); `None` for an empty grid.
    pub fn of(grid: &AnyGrid, bins: usize) -> Option<Histogram> {
        let range = grid.value_range()?;
        let bins = bins.max(1);
        let mut counts = vec![0u64; bins];
        let (mut sum, mut n) = (0.0f64, 0u64);
        let width = (range.max - range.min) / bins as f64;
        for v in grid.values_f64() {
            let b = if width > 0.0 { (((v - range.min) / width) as usize).min(bins - 1) } else { 0 };
            counts[b] += 1;
            sum += v;
            n += 1;
        }
        Some(Histogram { min: range.min, max: range.max, mean: sum / n.max(1) as f64, counts })
    }

    /// Width of one bin.
    pub fn bin_width(&self) -> f64 {
        (self.max - self.min) / self.counts.len() as f64
    }

    /// The value below which `q` (0–1) of the samples lie, to bin resolution.
    pub fn quantile(&self, q: f64) -> f64 {
        let total: u64 = self.counts.iter().sum();
        let target = (q.clamp(0.0, 1.0) * total as f64).ceil() as u64;
        let mut acc = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            acc += c;
            if acc >= target.max(1) {
                return self.min + (b as f64 + 0.5) * self.bin_width();
            }
        }
        self.max
    }

    /// Otsu's threshold: the bin boundary maximising the between-class variance. A good first
    /// iso for two-phase data such as CT (air vs tissue).
    pub fn otsu(&self) -> f64 {
        let total: f64 = self.counts.iter().sum::<u64>() as f64;
        let centers: Vec<f64> = (0..self.counts.len()).map(|b| b as f64 + 0.5).collect();
        let sum_all: f64 = self.counts.iter().zip(&centers).map(|(&c, &x)| c as f64 * x).sum();
        let (mut w0, mut sum0, mut best, mut best_t) = (0.0, 0.0, -1.0, 0usize);
        for t in 0..self.counts.len().saturating_sub(1) {
            w0 += self.counts[t] as f64;
            sum0 += self.counts[t] as f64 * centers[t];
            let w1 = total - w0;
            if w0 == 0.0 || w1 == 0.0 {
                continue;
            }
            let (m0, m1) = (sum0 / w0, (sum_all - sum0) / w1);
            let between = w0 * w1 * (m0 - m1) * (m0 - m1);
            if between > best {
                best = between;
                best_t = t;
            }
        }
        self.min + (best_t as f64 + 1.0) * self.bin_width()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{DenseGrid, Lattice};

    #[test]
    fn otsu_splits_two_phases() {
        let l = Lattice::new([10, 10, 10]).unwrap();
        let g: AnyGrid = DenseGrid::from_fn(l, |p| if p[0] < 5 { 10u8 } else { 200 }).into();
        let h = Histogram::of(&g, 256).unwrap();
        let t = h.otsu();
        assert!(t > 10.0 && t < 200.0, "{t}");
        assert_eq!(h.mean, 105.0);
        assert!(h.quantile(0.25) < 20.0 && h.quantile(0.75) > 190.0);
    }
}
