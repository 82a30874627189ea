//! The allocation policy of programs that mesh again and again in one process.

/// Keeps the memory this process frees for its own next allocations instead of handing it back
/// to the kernel, so a program that meshes again (`isoforge extract --repeat`, the viewer's
/// requests, the benchmarks' warm loops) writes each new mesh into pages already mapped. With
/// glibc's defaults every block of 32 MiB or more (a large mesh's arrays) is its own `mmap`,
/// unmapped on `free`, and a mesh made again faults all of it in afresh: on a VM whose kernel
/// reports freed memory to the host, that made warm runs of MC on gyroid 256³ twice as slow, in
/// phases (docs/BENCHMARKS.md §6.19). One arena, no `mmap` for large blocks and no trimming of
/// the heap's top: freed blocks stay in the heap, and the process's footprint stays at its peak
/// until it exits. One-shot programs should not call it (it slowed the streamed file-to-file
/// path). Call it at start-up, before threads are spawned; it does nothing off glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets glibc's allocation policy (under glibc's own locks); the caller
    // calls it before the process starts any thread.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, libc::c_int::MAX);
    }
}
