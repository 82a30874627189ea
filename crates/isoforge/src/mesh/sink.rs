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

/// Receives a mesh as it is produced, in batches (one per slab of the walk, empty ones included).
/// Vertices are numbered from 0 in arrival order over all batches; a batch's polygons refer to
/// vertices of the batch **before** (mt-bcc's segments from the centres of the cells below), of the
/// batch itself, and of the **next** batch (the vertices on the slab above), never further away:
/// writers that need corner positions keep three batches.
pub trait MeshSink {
    /// Takes the next batch.
    ///
    /// # Errors
    /// Whatever writing fails with.
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), ExternalError>;

    /// Takes the next batch in buffers the caller owns: a sink that keeps batches may take the
    /// buffers themselves and leave others in their place (emptied or holding stale data; the
    /// caller clears them before reuse), instead of copying. By default, [`push`](MeshSink::push).
    ///
    /// # Errors
    /// Whatever writing fails with.
    fn push_owned(&mut self, batch: &mut OwnedBatch) -> std::result::Result<(), ExternalError> {
        self.push(batch.batch())
    }
}

/// A [`MeshSink`] written behind the walk: each batch is copied into a recycled buffer and handed
/// to `inner` on a background thread, so packing and writing slab k overlap the walk of slab
/// k + 1 (the mirror of [`Prefetch`](crate::volume::Prefetch) on the output side).
///
/// ```text
///   walker:         batch → copy into a free buffer (or a new one, at most `depth`) → full
///   writer thread:  full → inner.push → buffer back to free
/// ```
/// Batches reach `inner` in order, each exactly once. The thread lives in a
/// [`std::thread::scope`], so it borrows `inner`; it stops at `inner`'s first error, which the
/// walker's next [`push`](MeshSink::push) (or [`WriteBehind::finish`]) returns; dropping the
/// `WriteBehind` stops it too, so no error on either side can leave a thread blocked.
pub struct WriteBehind<'scope> {
    full: Option<std::sync::mpsc::SyncSender<OwnedBatch>>,
    free: std::sync::mpsc::Receiver<OwnedBatch>,
    made: usize,
    depth: usize,
    thread: Option<std::thread::ScopedJoinHandle<'scope, Result<(), ExternalError>>>,
}

/// A batch's data, owned: what a walker fills and hands over with [`MeshSink::push_owned`], and
/// the buffers [`WriteBehind`] recycles.
#[derive(Debug, Default)]
pub struct OwnedBatch {
    /// New vertices' positions.
    pub positions: Vec<[f32; 3]>,
    /// Their normals (empty when off).
    pub normals: Vec<[f32; 3]>,
    /// New triangles.
    pub triangles: Vec<[u32; 3]>,
    /// New quads.
    pub quads: Vec<[u32; 4]>,
}

impl OwnedBatch {
    fn set(&mut self, b: MeshBatch<'_>) {
        fn copy<T: Copy>(to: &mut Vec<T>, from: &[T]) {
            to.clear();
            to.extend_from_slice(from);
        }
        copy(&mut self.positions, b.positions);
        copy(&mut self.normals, b.normals);
        copy(&mut self.triangles, b.triangles);
        copy(&mut self.quads, b.quads);
    }

    /// The batch these buffers hold.
    pub fn batch(&self) -> MeshBatch<'_> {
        MeshBatch { positions: &self.positions, normals: &self.normals, triangles: &self.triangles, quads: &self.quads }
    }
}

impl std::fmt::Debug for WriteBehind<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WriteBehind").field("made", &self.made).field("depth", &self.depth).finish()
    }
}

impl<'scope> WriteBehind<'scope> {
    /// Starts the writer thread on `scope`, at most `depth` (≥ 1) batches in flight.
    pub fn spawn<'env>(
        scope: &'scope std::thread::Scope<'scope, 'env>,
        inner: &'scope mut (dyn MeshSink + Send),
        depth: usize,
    ) -> Self {
        use std::sync::mpsc::{channel, sync_channel};
        let depth = depth.max(1);
        let (full, full_rx) = sync_channel::<OwnedBatch>(depth);
        let (free_tx, free) = channel::<OwnedBatch>();
        let thread = scope.spawn(move || {
            for b in full_rx {
                inner.push(b.batch())?;
                // The walker may be gone (finished or failed): the buffer is then dropped.
                let _ = free_tx.send(b);
            }
            Ok(())
        });
        WriteBehind { full: Some(full), free, made: 0, depth, thread: Some(thread) }
    }

    /// Waits for every batch to be written; returns the writer's first error.
    ///
    /// # Errors
    /// What `inner` failed with.
    pub fn finish(mut self) -> Result<(), ExternalError> {
        self.full = None;
        self.join()
    }

    /// The writer thread's outcome (it has stopped, or stops once `full` is closed).
    fn join(&mut self) -> Result<(), ExternalError> {
        match self.thread.take() {
            Some(t) => t.join().unwrap_or_else(|_| Err("the mesh writing thread panicked".into())),
            None => Err("the mesh writing thread has stopped".into()),
        }
    }
}

impl MeshSink for WriteBehind<'_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> Result<(), ExternalError> {
        let mut b = self.free_buffer()?;
        b.set(batch);
        self.send(b)
    }

    /// Sends the caller's buffers themselves to the writer (no copy) and leaves a recycled set
    /// (stale contents) or an empty one in their place.
    fn push_owned(&mut self, batch: &mut OwnedBatch) -> Result<(), ExternalError> {
        let mut b = self.free_buffer()?;
        std::mem::swap(&mut b, batch);
        self.send(b)
    }
}

impl WriteBehind<'_> {
    /// A recycled buffer, else a new one while fewer than `depth` exist, else waits for one;
    /// the channels fail only when the writer has stopped, i.e. on its error.
    fn free_buffer(&mut self) -> Result<OwnedBatch, ExternalError> {
        match self.free.try_recv() {
            Ok(b) => Ok(b),
            Err(_) if self.made < self.depth => {
                self.made += 1;
                Ok(OwnedBatch::default())
            }
            Err(_) => match self.free.recv() {
                Ok(b) => Ok(b),
                Err(_) => self.stopped().map(|()| OwnedBatch::default()),
            },
        }
    }

    /// Hands a full buffer to the writer.
    fn send(&mut self, b: OwnedBatch) -> Result<(), ExternalError> {
        match self.full.as_ref().map(|f| f.send(b)) {
            Some(Ok(())) => Ok(()),
            _ => self.stopped(),
        }
    }

    /// The writer stopped early: its error.
    fn stopped(&mut self) -> Result<(), ExternalError> {
        self.full = None;
        self.join().and(Err("the mesh writing thread stopped early (this is a bug, please report)".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records every batch (positions' first x and the triangles); fails at batch `fail_at`.
    #[derive(Default)]
    struct Record {
        got: Vec<(f32, Vec<[u32; 3]>)>,
        fail_at: Option<usize>,
    }

    impl MeshSink for Record {
        fn push(&mut self, b: MeshBatch<'_>) -> Result<(), ExternalError> {
            if Some(self.got.len()) == self.fail_at {
                return Err(format!("out.ply: batch {}: no space left on device", self.got.len()).into());
            }
            self.got.push((b.positions[0][0], b.triangles.to_vec()));
            Ok(())
        }
    }

    fn batch_data(k: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        (vec![[k as f32, 0.0, 0.0]; 1 + k as usize % 3], (0..k % 5).map(|i| [k, i, k + i]).collect())
    }

    #[test]
    fn batches_arrive_in_order_and_complete() {
        let mut rec = Record::default();
        std::thread::scope(|s| {
            let mut w = WriteBehind::spawn(s, &mut rec, 2);
            for k in 0..200 {
                let (p, t) = batch_data(k);
                w.push(MeshBatch { positions: &p, normals: &[], triangles: &t, quads: &[] }).unwrap();
            }
            w.finish().unwrap();
        });
        assert_eq!(rec.got.len(), 200);
        for (k, (x, t)) in rec.got.iter().enumerate() {
            assert_eq!((*x, t), (k as f32, &batch_data(k as u32).1), "batch {k}");
        }
    }

    /// Owned batches reach the writer in order and unchanged, whatever buffers come back.
    #[test]
    fn owned_batches_arrive_in_order_and_complete() {
        let mut rec = Record::default();
        std::thread::scope(|s| {
            let mut w = WriteBehind::spawn(s, &mut rec, 2);
            let mut own = OwnedBatch::default();
            for k in 0..200 {
                let (p, t) = batch_data(k);
                own.positions.clear();
                own.positions.extend_from_slice(&p);
                own.triangles.clear();
                own.triangles.extend_from_slice(&t);
                w.push_owned(&mut own).unwrap();
            }
            w.finish().unwrap();
        });
        assert_eq!(rec.got.len(), 200);
        for (k, (x, t)) in rec.got.iter().enumerate() {
            assert_eq!((*x, t), (k as f32, &batch_data(k as u32).1), "batch {k}");
        }
    }

    #[test]
    fn the_writers_error_reaches_the_walker_and_stops_the_writer() {
        let mut rec = Record { fail_at: Some(7), ..Default::default() };
        let mut first_error = None;
        std::thread::scope(|s| {
            let mut w = WriteBehind::spawn(s, &mut rec, 3);
            for k in 0..1000 {
                let (p, t) = batch_data(k);
                if let Err(e) = w.push(MeshBatch { positions: &p, normals: &[], triangles: &t, quads: &[] }) {
                    first_error = Some((k, e.to_string()));
                    break;
                }
            }
        });
        let (k, e) = first_error.expect("the error arrives");
        assert_eq!(e, "out.ply: batch 7: no space left on device");
        assert!((7..=7 + 3 + 2).contains(&k), "noticed at push {k}: at most `depth` batches late");
        assert_eq!(rec.got.len(), 7, "nothing written after the failing batch");
        // An error at the last batch comes out of `finish`.
        let mut rec = Record { fail_at: Some(4), ..Default::default() };
        let e = std::thread::scope(|s| {
            let mut w = WriteBehind::spawn(s, &mut rec, 8);
            for k in 0..5 {
                let (p, t) = batch_data(k);
                w.push(MeshBatch { positions: &p, normals: &[], triangles: &t, quads: &[] }).unwrap();
            }
            w.finish().unwrap_err().to_string()
        });
        assert_eq!(e, "out.ply: batch 4: no space left on device");
    }

    #[test]
    fn dropping_early_stops_the_writer_without_deadlock() {
        let mut rec = Record::default();
        // The scope joins the thread: this returns only if the writer stops.
        std::thread::scope(|s| {
            let mut w = WriteBehind::spawn(s, &mut rec, 2);
            let (p, t) = batch_data(1);
            w.push(MeshBatch { positions: &p, normals: &[], triangles: &t, quads: &[] }).unwrap();
            drop(w);
        });
        assert!(rec.got.len() <= 1);
        std::thread::scope(|s| drop(WriteBehind::spawn(s, &mut rec, 2)));
    }
}
