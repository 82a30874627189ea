"""isoforge.find_contours against skimage.measure.find_contours."""

import numpy as np
import pytest

import isoforge

measure = pytest.importorskip("skimage.measure")


def canonical(contours):
    """Each contour (a closed one rotated to start at its smallest point, direction kept), sorted
    by its points rounded to 1e-3; isoforge interpolates offsets in float32, skimage in float64."""
    out = []
    for c in contours:
        c = np.asarray(c, dtype=np.float64)
        if len(c) > 1 and np.array_equal(c[0], c[-1]):
            ring = c[:-1]
            k = min(range(len(ring)), key=lambda i: tuple(np.round(ring[i], 3)))
            c = np.vstack([np.roll(ring, -k, axis=0), ring[k:k + 1]])
        out.append(c)
    return sorted(out, key=lambda c: (len(c), tuple(map(tuple, np.round(c, 3)))))


def same(a, b):
    ca, cb = canonical(a), canonical(b)
    return len(ca) == len(cb) and all(x.shape == y.shape and np.allclose(x, y, atol=1e-5) for x, y in zip(ca, cb))


def images():
    rng = np.random.default_rng(7)
    yield rng.random((40, 50))
    y, x = np.mgrid[-20:21, -30:31]
    yield np.sin(x / 4.0) * np.cos(y / 5.0)
    # Saddles: a checkerboard.
    yield np.indices((9, 11)).sum(axis=0) % 2 * 1.0


@pytest.mark.parametrize("fully_connected", ["low", "high"])
@pytest.mark.parametrize("positive_orientation", ["low", "high"])
def test_same_contours_as_skimage(fully_connected, positive_orientation):
    for image in images():
        for level in (0.25, 0.5, 0.7):
            a = measure.find_contours(image, level, fully_connected, positive_orientation)
            b = isoforge.find_contours(image, level, fully_connected, positive_orientation)
            assert same(a, b)


def test_default_level_and_errors():
    image = np.random.default_rng(1).random((20, 20))
    assert same(measure.find_contours(image), isoforge.find_contours(image))
    with pytest.raises(ValueError):
        isoforge.find_contours(np.zeros((3, 3, 3)))
    with pytest.raises(ValueError):
        isoforge.find_contours(image, 0.5, fully_connected="x")
