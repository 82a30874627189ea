//! ③ Extractor: turns one [`Cell`](crate::walk::Cell) at a time into triangles.
//!
//! In: a cell (corner values, case, access to shared edge vertices). Out: triangles pushed through
//! the cell. Numbering and tables live in [`cube`].
//!
//! | extractor | output | manifold | closed when the surface stays inside the lattice | topology of the trilinear interpolant | sharp features |
//! |---|---|---|---|---|---|
//! | [`MarchingCubes`] [Lorensen87] | triangles | yes (edge and vertex) | yes | no (fixed choice on ambiguous faces) | no |

pub mod cube;
pub mod marching_cubes;
pub mod masked;
pub mod mc33;
pub mod squares;
pub mod tetrahedra;

pub use marching_cubes::MarchingCubes;
pub use masked::{Masked, PointMask};
pub use mc33::MarchingCubes33;
pub use squares::{marching_squares, Polyline, Saddle};
pub use tetrahedra::{Decomposition, MarchingTetrahedra};

use crate::walk::Cell;

/// Processes one cell at a time; walkers call it for every cell with a crossing.
pub trait Extractor {
    /// Emits the cell's triangles through `cell`.
    fn process<C: Cell>(&mut self, cell: &mut C);

    /// Whether walkers must also call [`process`](Extractor::process) for cells whose eight
    /// corners are all on one side (extractors that sample off the lattice, such as cell centres
    /// of a field, can find a surface there).
    fn visits_uniform_cells(&self) -> bool {
        false
    }
}
