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
    // The first slice fixes size and type; the total is checked before the others are read,
    // and each slice is appended as it is read (memory: the volume and one slice).
    let count = numbered.len() as u32;
    let mut acc: Option<AnyGrid> = None;
    let mut first_dims = [0u32; 3];
    for (z, (_, f)) in numbered.iter().enumerate() {
        let g = crate::open_volume(f, limits)?.read_grid(limits)?;
        let dims = g.lattice().dims();
        let Some(all) = &mut acc else {
            if dims[2] != 1 {
                return Err(Ctx::new(f, "image stack").bad("a multi-page TIFF in a slice folder: one image per file"));
            }
            let total = g.lattice().num_points().saturating_mul(g.dtype().size() as u64).saturating_mul(count as u64);
            if total > limits.max_bytes {
                return Err(ctx.limit(
                    format!("{count} slices of {} x {} {}", dims[0], dims[1], g.dtype()),
                    total,
                    limits.max_bytes,
                ));
            }
            first_dims = dims;
            let n = g.lattice().num_points() as usize * count as usize;
            macro_rules! start {
                ($($v:ident),*) => {
                    match g {
                        $( AnyGrid::$v(grid) => {
                            let mut data = grid.into_data();
                            data.reserve_exact(n.saturating_sub(data.len()));
                            AnyGrid::$v(DenseGrid::new(Lattice::new([dims[0], dims[1], 1]).map_err(|e| ctx.lib(e))?, data).map_err(|e| ctx.lib(e))?)
                        } )*
                    }
                };
            }
            acc = Some(start!(U8, I8, U16, I16, U32, I32, F32, F64));
            continue;
        };
        if dims != first_dims || all.dtype() != g.dtype() {
            return Err(Ctx::new(f, "image stack").bad(format!(
                "{} x {} x {} {} differs from the first slice's {} x {} x {} {}",
                dims[0],
                dims[1],
                dims[2],
                g.dtype(),
                first_dims[0],
                first_dims[1],
                first_dims[2],
                all.dtype()
            )));
        }
        let lattice = Lattice::new([dims[0], dims[1], z as u32 + 1]).map_err(|e| ctx.lib(e))?;
        macro_rules! append {
            ($($v:ident),*) => {
                match (acc.take(), g) {
                    $( (Some(AnyGrid::$v(a)), AnyGrid::$v(b)) => {
                        let mut data = a.into_data();
                        data.extend_from_slice(b.data());
                        AnyGrid::$v(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?)
                    } )*
                    _ => return Err(ctx.bad("slices of different sample types")),
                }
            };
        }
        acc = Some(append!(U8, I8, U16, I16, U32, I32, F32, F64));
    }
    let grid = acc.ok_or_else(|| ctx.bad("no image slices"))?;
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
