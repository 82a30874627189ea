//! Where a mesh goes when it is produced slab by slab instead of held in memory.

/// An error from a [`MeshSink`] or a slab source (file I/O, decoding), passed through the walk.
pub type ExternalError = Box<dyn std::error::Error + Send + Sync>;

/// One batch of a streamed mesh.
#[derive(Debug, Clone, Copy)]
pub struct MeshBatch<'a> {
    /// New vertices' positions.
    pub positions: &'a [[f32; 3]],
    /// Their normals (empty when off).
    pub normals: &'a [[f32; 3]],
    /// New triangles.
    pub triangles: &'a [[u32; 3]],
    /// New quads.
    pub quads: &'a [[u32; 4]],
}

/// Receives a mesh as it is produced, in batches (one per slab of the walk). Vertices are numbered
/// from 0 in arrival order over all batches; a batch's polygons refer to vertices of earlier
/// batches, of the batch itself, and of the **next** batch (the vertices on the slab above), never
/// further ahead.
pub trait MeshSink {
    /// Takes the next batch.
    ///
    /// # Errors
    /// Whatever writing fails with.
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), ExternalError>;
}
