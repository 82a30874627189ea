//! A folder of numbered 2D images (`slice_000.tif`, `img12.png`, …) as one volume: slice z = the
//! images in the order of the number in their names (the last run of digits), which must run
//! without gaps or repeats. Every image must have the first one's size and sample type.

use std::path::{Path, PathBuf};

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};

use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Whether a file name is an image slice this module reads.
pub(crate) fn is_image(p: &Path) -> bool {
    let n = p.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    n.ends_with(".png") || n.ends_with(".tif") || n.ends_with(".tiff")
}

/// The last run of digits in a file stem.
fn number(p: &Path) -> Option<u64> {
    let stem = p.file_stem()?.to_string_lossy().into_owned();
    let stem = stem.trim_end_matches(".tif").to_string();
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end].rfind(|c: char| !c.is_ascii_digit()).map_or(0, |i| i + 1);
    stem[start..end].parse().ok()
}

/// Opens the numbered image slices of folder `dir`.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for names without a number, repeated or missing numbers
/// (named), slices that differ in size or type; the image readers' errors for each file.
pub fn open_image_stack(dir: &Path, files: Vec<PathBuf>, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(dir, "image stack");
    let mut numbered = Vec::with_capacity(files.len());
    for f in files {
        let n = number(&f).ok_or_else(|| {
            ctx.bad(format!("{}: no slice number in the name", f.file_name().unwrap_or_default().to_string_lossy()))
        })?;
        numbered.push((n, f));
    }
    numbered.sort();
    for w in numbered.windows(2) {
        let name = |p: &PathBuf| p.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if w[1].0 == w[0].0 {
            return Err(ctx.bad(format!(
                "{} and {} have the same slice number {}",
                name(&w[0].1),
                name(&w[1].1),
                w[0].0
            )));
        }
        if w[1].0 != w[0].0 + 1 {
            return Err(ctx.bad(format!(
                "slice numbers jump from {} ({}) to {} ({}): missing slices",
                w[0].0,
                name(&w[0].1),
                w[1].0,
                name(&w[1].1)
            )));
        }
    }
    let mut slices: Vec<AnyGrid> = Vec::with_capacity(numbered.len());
    let mut total = 0u64;
    for (_, f) in &numbered {
        let g = crate::open_volume(f, limits)?.read_grid(limits)?;
        if let Some(first) = slices.first() {
            let (a, b) = (first.lattice().dims(), g.lattice().dims());
            if a != b || first.dtype() != g.dtype() {
                return Err(Ctx::new(f, "image stack").bad(format!(
                    "{} x {} x {} {} differs from the first slice's {} x {} x {} {}",
                    b[0],
                    b[1],
                    b[2],
                    g.dtype(),
                    a[0],
                    a[1],
                    a[2],
                    first.dtype()
                )));
            }
        } else if g.lattice().dims()[2] != 1 {
            return Err(Ctx::new(f, "image stack").bad("a multi-page TIFF in a slice folder: one image per file"));
        }
        total += g.lattice().num_points() * g.dtype().size() as u64;
        if total > limits.max_bytes {
            return Err(ctx.limit(format!("{} slices", numbered.len()), total, limits.max_bytes));
        }
        slices.push(g);
    }
    let [w, h, _] = slices[0].lattice().dims();
    let lattice = Lattice::new([w, h, slices.len() as u32]).map_err(|e| ctx.lib(e))?;
    macro_rules! stack {
        ($v:ident) => {{
            let mut data = Vec::with_capacity(lattice.num_points() as usize);
            for s in &slices {
                if let AnyGrid::$v(g) = s {
                    data.extend_from_slice(g.data());
                }
            }
            AnyGrid::$v(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?)
        }};
    }
    let grid = match &slices[0] {
        AnyGrid::U8(_) => stack!(U8),
        AnyGrid::I8(_) => stack!(I8),
        AnyGrid::U16(_) => stack!(U16),
        AnyGrid::I16(_) => stack!(I16),
        AnyGrid::U32(_) => stack!(U32),
        AnyGrid::I32(_) => stack!(I32),
        AnyGrid::F32(_) => stack!(F32),
        AnyGrid::F64(_) => stack!(F64),
    };
    Ok(VolumeReader::decoded(ctx, grid))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slice_numbers_come_from_the_last_digits() {
        assert_eq!(number(Path::new("scan2_slice_0042.tif")), Some(42));
        assert_eq!(number(Path::new("img7.png")), Some(7));
        assert_eq!(number(Path::new("a.b.12.tiff")), Some(12));
        assert_eq!(number(Path::new("slice.png")), None);
    }
}
