//! Volumes that arrive slab by slab (files larger than memory, decoders).

use crate::grid::Lattice;
use crate::mesh::ExternalError;

/// Supplies a volume's z-slabs in order (k = 0, 1, …), nx·ny samples each, x fastest: what the
/// Flying Edges walker streams from (`FlyingEdgesWalker::stream`).
pub trait SlabSource<S> {
    /// The lattice of the whole volume.
    fn lattice(&self) -> &Lattice;
    /// Writes the next slab into `out`.
    ///
    /// # Errors
    /// Whatever reading the slab fails with.
    fn read_slab(&mut self, out: &mut [S]) -> std::result::Result<(), ExternalError>;
    /// Makes `slab` (of nx·ny samples) the next slab: [`read_slab`](Self::read_slab) into it,
    /// unless the source holds the slab in a buffer of its own and swaps buffers instead of
    /// copying ([`Prefetch`](super::Prefetch) does). `slab` keeps its length either way.
    ///
    /// # Errors
    /// As [`read_slab`](Self::read_slab).
    fn take_slab(&mut self, slab: &mut Vec<S>) -> std::result::Result<(), ExternalError> {
        self.read_slab(slab)
    }
}
