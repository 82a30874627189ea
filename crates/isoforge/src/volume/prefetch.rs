//! [`Prefetch`]: a [`SlabSource`] read ahead by a background thread, so decoding slab k + 1
//! overlaps the walk of slab k.
//!
//! ```text
//!   reader thread:  buffer ← free (or a new one, at most `depth`) → src.read_slab(buffer) → full
//!   walker:         full → swapped into the walker's ring (`take_slab`) → its old buffer back to free
//! ```
//! At most `depth` slabs are in flight (decoded and not yet taken, or being decoded). The thread
//! lives in a [`std::thread::scope`], so it borrows the source; it stops at the first error (sent
//! as the next slab's result, so errors arrive in order) and as soon as the walker drops the
//! `Prefetch` (its sends and receives fail), so neither an early error on either side nor a drop
//! can leave it blocked.

use std::sync::mpsc::{channel, sync_channel, Receiver, Sender};
use std::thread::{Scope, ScopedJoinHandle};

use crate::grid::{Lattice, Sample};
use crate::mesh::ExternalError;

use super::SlabSource;

/// A slab source read ahead by a scoped background thread (see the module doc).
pub struct Prefetch<'scope, S> {
    lattice: Lattice,
    full: Receiver<Result<Vec<S>, ExternalError>>,
    free: Sender<Vec<S>>,
    taken: u64,
    slabs: u64,
    _thread: ScopedJoinHandle<'scope, ()>,
}

impl<S> std::fmt::Debug for Prefetch<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prefetch").field("lattice", &self.lattice).field("taken", &self.taken).finish()
    }
}

impl<'scope, S: Sample + Send + 'scope> Prefetch<'scope, S> {
    /// Starts reading `src`'s slabs (all `nz` of them, in order) on a thread of `scope`, at most
    /// `depth` (≥ 1) slabs ahead of the reads of the returned source.
    pub fn spawn<'env>(
        scope: &'scope Scope<'scope, 'env>,
        src: &'scope mut (dyn SlabSource<S> + Send),
        depth: usize,
    ) -> Self {
        let lattice = src.lattice().clone();
        let [nx, ny, nz] = lattice.dims().map(|d| d as usize);
        let slab_len = nx * ny;
        let depth = depth.max(1);
        let (full_tx, full) = sync_channel::<Result<Vec<S>, ExternalError>>(depth);
        let (free, free_rx) = channel::<Vec<S>>();
        let thread = scope.spawn(move || {
            let mut made = 0;
            for _ in 0..nz {
                // A recycled buffer, else a new one while fewer than `depth` exist, else wait.
                let mut buf = match free_rx.try_recv() {
                    Ok(b) => b,
                    Err(_) if made < depth => {
                        made += 1;
                        vec![S::from_f64(0.0); slab_len]
                    }
                    Err(_) => match free_rx.recv() {
                        Ok(b) => b,
                        Err(_) => return, // the walker is gone
                    },
                };
                let r = src.read_slab(&mut buf);
                let failed = r.is_err();
                if full_tx.send(r.map(|()| buf)).is_err() || failed {
                    return;
                }
            }
        });
        Prefetch { lattice, full, free, taken: 0, slabs: nz as u64, _thread: thread }
    }
}

impl<S: Sample> SlabSource<S> for Prefetch<'_, S> {
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn read_slab(&mut self, out: &mut [S]) -> Result<(), ExternalError> {
        let buf = self.next(out.len())?;
        out.copy_from_slice(&buf);
        self.recycle(buf);
        Ok(())
    }

    /// Swaps the decoded buffer in (no copy); `slab`'s old buffer goes back to the reader.
    fn take_slab(&mut self, slab: &mut Vec<S>) -> Result<(), ExternalError> {
        let mut buf = self.next(slab.len())?;
        std::mem::swap(slab, &mut buf);
        self.recycle(buf);
        Ok(())
    }
}

impl<S> Prefetch<'_, S> {
    /// The next decoded slab, checked to hold `len` samples.
    fn next(&mut self, len: usize) -> Result<Vec<S>, ExternalError> {
        let k = self.taken;
        if k >= self.slabs {
            return Err(format!("slab {k} asked of a volume of {} slabs", self.slabs).into());
        }
        let buf = match self.full.recv() {
            Ok(r) => r?,
            Err(_) => {
                return Err(format!("the reading thread stopped before slab {k} (this is a bug, please report)").into())
            }
        };
        if len != buf.len() {
            return Err(
                format!("slab {k}: {len} samples asked, {} read (this is a bug, please report)", buf.len()).into()
            );
        }
        self.taken += 1;
        Ok(buf)
    }

    /// Hands a slab-sized buffer back to the reading thread.
    fn recycle(&self, buf: Vec<S>) {
        // The thread may have finished (every slab sent): the buffer is then simply dropped.
        let _ = self.free.send(buf);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Slab k holds k·1000 + index; fails at `fail_at`; counts reads.
    struct Counter<'a> {
        lattice: Lattice,
        next: u32,
        fail_at: Option<u32>,
        reads: &'a AtomicUsize,
    }

    impl SlabSource<u32> for Counter<'_> {
        fn lattice(&self) -> &Lattice {
            &self.lattice
        }
        fn read_slab(&mut self, out: &mut [u32]) -> Result<(), ExternalError> {
            let k = self.next;
            self.reads.fetch_add(1, Ordering::SeqCst);
            if Some(k) == self.fail_at {
                return Err(format!("vol.raw: slab {k}: unexpected end of file").into());
            }
            for (i, o) in out.iter_mut().enumerate() {
                *o = k * 1000 + i as u32;
            }
            self.next += 1;
            Ok(())
        }
    }

    fn counter(nz: u32, fail_at: Option<u32>, reads: &AtomicUsize) -> Counter<'_> {
        Counter { lattice: Lattice::new([3, 2, nz]).unwrap(), next: 0, fail_at, reads }
    }

    #[test]
    fn slabs_arrive_in_order_and_complete() {
        let reads = AtomicUsize::new(0);
        let mut src = counter(40, None, &reads);
        std::thread::scope(|s| {
            let mut p = Prefetch::spawn(s, &mut src, 3);
            assert_eq!(p.lattice().dims(), [3, 2, 40]);
            let mut out = [0u32; 6];
            for k in 0..40 {
                p.read_slab(&mut out).unwrap();
                assert_eq!(out, std::array::from_fn(|i| k * 1000 + i as u32), "slab {k}");
            }
            let e = p.read_slab(&mut out).unwrap_err().to_string();
            assert!(e.contains("slab 40 asked of a volume of 40 slabs"), "{e}");
        });
        assert_eq!(reads.load(Ordering::SeqCst), 40);
    }

    #[test]
    fn taking_slabs_swaps_buffers_and_gives_the_same_slabs() {
        let reads = AtomicUsize::new(0);
        let mut src = counter(40, None, &reads);
        std::thread::scope(|s| {
            let mut p = Prefetch::spawn(s, &mut src, 3);
            let (mut slab, mut out) = (vec![0u32; 6], [0u32; 6]);
            for k in 0..40 {
                // Alternating: a swap (the buffer changes hands) and a copy.
                if k % 2 == 0 {
                    let before = slab.as_ptr();
                    p.take_slab(&mut slab).unwrap();
                    assert_ne!(slab.as_ptr(), before, "slab {k}: swapped, not copied");
                    assert_eq!(slab, (0..6).map(|i| k * 1000 + i).collect::<Vec<_>>(), "slab {k}");
                } else {
                    p.read_slab(&mut out).unwrap();
                    assert_eq!(out, std::array::from_fn(|i| k * 1000 + i as u32), "slab {k}");
                }
            }
            let mut short = vec![0u32; 5];
            let e = p.take_slab(&mut short).unwrap_err().to_string();
            assert!(e.contains("slab 40 asked of a volume of 40 slabs"), "{e}");
        });
        assert_eq!(reads.load(Ordering::SeqCst), 40);
    }

    #[test]
    fn an_error_arrives_in_place_with_its_message_and_stops_the_reader() {
        let reads = AtomicUsize::new(0);
        let mut src = counter(40, Some(7), &reads);
        std::thread::scope(|s| {
            let mut p = Prefetch::spawn(s, &mut src, 4);
            let mut out = [0u32; 6];
            for k in 0..7 {
                p.read_slab(&mut out).unwrap();
                assert_eq!(out[0], k * 1000);
            }
            let e = p.read_slab(&mut out).unwrap_err().to_string();
            assert_eq!(e, "vol.raw: slab 7: unexpected end of file");
            let e = p.read_slab(&mut out).unwrap_err().to_string();
            assert!(e.contains("stopped before slab 7"), "{e}");
        });
        assert_eq!(reads.load(Ordering::SeqCst), 8, "nothing read after the failing slab");
    }

    #[test]
    fn reading_ahead_is_bounded() {
        let reads = AtomicUsize::new(0);
        let mut src = counter(1000, None, &reads);
        std::thread::scope(|s| {
            let mut p = Prefetch::spawn(s, &mut src, 3);
            let mut out = [0u32; 6];
            p.read_slab(&mut out).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(100));
            // One taken, three buffers in flight: at most 1 + 3 (+ the one waiting for a buffer
            // that only the next read frees).
            let n = reads.load(Ordering::SeqCst);
            assert!((2..=5).contains(&n), "{n} slabs read ahead of 1 taken");
        });
    }

    #[test]
    fn dropping_early_stops_the_reader_without_deadlock() {
        let reads = AtomicUsize::new(0);
        let mut src = counter(100_000, None, &reads);
        // The scope joins the thread: this returns only if the reader stops.
        std::thread::scope(|s| {
            let mut p = Prefetch::spawn(s, &mut src, 2);
            let mut out = [0u32; 6];
            p.read_slab(&mut out).unwrap();
            drop(p);
        });
        assert!(reads.load(Ordering::SeqCst) < 10);
        // Dropped before any read.
        let mut src = counter(100_000, None, &reads);
        std::thread::scope(|s| drop(Prefetch::spawn(s, &mut src, 2)));
    }
}
