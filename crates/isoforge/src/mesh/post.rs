//! What happens to a mesh after extraction: [`smooth`](super::smooth) then
//! [`decimate`](super::decimate), as one request ([`PostProcess`]) every front end fills the same way.

use std::time::Instant;

use super::decimate::{decimate, DecimateOptions, DecimateStats};
use super::smooth::{smooth, SmoothOptions, SmoothStats};
use super::Mesh;
use crate::error::Result;

/// Smoothing, then decimation; either may be absent.
///
/// Smoothing comes first: the staircase of a lattice surface is what keeps decimation from
/// removing triangles of flat or gently curved parts. The error bound of the decimation is
/// measured from the smoothed surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PostProcess {
    /// Smoothing, when asked for.
    pub smooth: Option<SmoothOptions>,
    /// Decimation, when asked for.
    pub decimate: Option<DecimateOptions>,
}

/// What [`PostProcess::apply`] did, with the time of each step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PostStats {
    /// Smoothing, and its seconds.
    pub smooth: Option<(SmoothStats, f64)>,
    /// Decimation, and its seconds.
    pub decimate: Option<(DecimateStats, f64)>,
}

impl PostProcess {
    /// Nothing to do.
    pub fn is_identity(&self) -> bool {
        self.smooth.is_none() && self.decimate.is_none()
    }

    /// The same steps with smoothing constrained to move no vertex farther than `d` (world
    /// units), unless a tighter bound is set already.
    pub fn constrained(&self, d: f64) -> PostProcess {
        let smooth = self.smooth.clone().map(|s| {
            let d = s.max_displacement.map_or(d, |m| m.min(d));
            s.constrained(d)
        });
        PostProcess { smooth, decimate: self.decimate.clone() }
    }

    /// Checks both steps' options.
    ///
    /// # Errors
    /// As [`SmoothOptions::validate`] and [`DecimateOptions::validate`].
    pub fn validate(&self) -> Result<()> {
        if let Some(s) = &self.smooth {
            s.validate()?;
        }
        if let Some(d) = &self.decimate {
            d.validate()?;
        }
        Ok(())
    }

    /// Applies the steps to `mesh` in place.
    ///
    /// # Errors
    /// As [`smooth`] and [`decimate`].
    pub fn apply(&self, mesh: &mut Mesh) -> Result<PostStats> {
        self.validate()?;
        let mut stats = PostStats::default();
        if let Some(s) = &self.smooth {
            let start = Instant::now();
            let st = smooth(mesh, s)?;
            stats.smooth = Some((st, start.elapsed().as_secs_f64()));
        }
        if let Some(d) = &self.decimate {
            let start = Instant::now();
            let st = decimate(mesh, d)?;
            stats.decimate = Some((st, start.elapsed().as_secs_f64()));
        }
        Ok(stats)
    }
}

impl PostStats {
    /// One line per step, for reports: `smoothed (sinc, 40 iterations) in 0.12 s`, `decimated …`.
    pub fn lines(&self, post: &PostProcess) -> Vec<String> {
        let mut out = Vec::new();
        if let (Some((s, secs)), Some(o)) = (&self.smooth, &post.smooth) {
            let bound = o.max_displacement.map_or(String::new(), |d| format!(", vertices kept within {d}"));
            out.push(format!(
                "smoothed ({}, {} iterations{bound}; {} fixed, {} held back, largest move {:.4}) in {secs:.3} s",
                o.smoother.name(),
                o.iterations,
                s.fixed,
                s.clamped,
                s.max_moved
            ));
        }
        if let Some((d, secs)) = &self.decimate {
            let error = d.error.map_or(String::new(), |e| format!(", input vertices within {e:.4} of the surface"));
            let r = &d.refused;
            out.push(format!(
                "decimated {} → {} triangles ({} collapses, {} vertices locked{error}; refused: {} link, {} \
                 component, {} fold-over, {} shape, {} error) in {secs:.3} s",
                d.triangles_before,
                d.triangles_after,
                d.collapses,
                d.locked,
                r.link,
                r.component,
                r.fold_over,
                r.shape,
                r.error
            ));
        }
        out
    }
}
