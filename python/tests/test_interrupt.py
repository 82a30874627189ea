"""Ctrl-C during an extraction: the walk is cancelled and KeyboardInterrupt raised; the GIL is
free meanwhile (another Python thread runs)."""

import _thread
import threading
import time

import numpy as np
import pytest

import isoforge


def noisy(n=160):
    # Noise: crossings everywhere, so classification, counting and fill all take a while.
    return np.random.default_rng(0).random((n, n, n), dtype=np.float32)


def test_ctrl_c_cancels_the_extraction():
    vol = noisy()
    t0 = time.perf_counter()
    isoforge.extract(vol, 0.5, method="mc", threads=1)
    full = time.perf_counter() - t0
    timer = threading.Timer(full * 0.05, _thread.interrupt_main)
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        isoforge.extract(vol, 0.5, method="mc", threads=1)
    cancelled = time.perf_counter() - t0
    timer.join()
    # Stopped before the fill (about half the walk) plus at most one 20 ms poll.
    assert cancelled < 0.8 * full + 0.05, (cancelled, full)
    # The module still works afterwards.
    assert len(isoforge.extract(vol[:20, :20, :20], 0.5).faces) > 0


def test_the_gil_is_released_during_extraction():
    vol = noisy()
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    t0 = time.perf_counter()
    isoforge.extract(vol, 0.5, method="mc", threads=1)
    elapsed = time.perf_counter() - t0
    stop.set()
    t.join()
    # The counter ran during the call (it ticks about once per ms when it gets the GIL).
    assert len(ticks) > 0.2 * elapsed * 1000, (len(ticks), elapsed)


def test_ctrl_c_cancels_a_walk_read_slab_by_slab():
    # A Fortran-ordered array is streamed from where numpy keeps it (issue 48): the streamed walk
    # asks after every slab whether to stop.
    vol = np.asfortranarray(noisy())
    t0 = time.perf_counter()
    isoforge.marching_cubes(vol, 0.5, threads=1)
    full = time.perf_counter() - t0
    timer = threading.Timer(full * 0.05, _thread.interrupt_main)
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        isoforge.marching_cubes(vol, 0.5, threads=1)
    cancelled = time.perf_counter() - t0
    timer.join()
    assert cancelled < 0.5 * full + 0.05, (cancelled, full)
