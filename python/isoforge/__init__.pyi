"""Type stubs of the isoforge package (issue 48)."""

import os
from typing import Callable, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__all__ = ["Mesh", "extract", "find_contours", "marching_cubes", "read_volume"]

_Path = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
_Field = Callable[[np.ndarray, np.ndarray, np.ndarray], npt.ArrayLike]

# marching_cubes and extract read arrays where numpy keeps them (any layout, no copy), without
# the GIL and without a lock: another thread writing the array during the call is a data race.
def marching_cubes(
    volume: np.ndarray,
    level: Optional[float] = ...,
    *,
    spacing: Sequence[float] = ...,
    gradient_direction: Literal["descent", "ascent"] = ...,
    step_size: int = ...,
    allow_degenerate: bool = ...,
    method: Literal["lewiner", "lorensen"] = ...,
    mask: Optional[npt.ArrayLike] = ...,
    threads: Optional[int] = ...,
) -> Tuple[
    npt.NDArray[np.float32], npt.NDArray[np.int64], npt.NDArray[np.float32], npt.NDArray[np.float32]
]: ...
def find_contours(
    image: npt.ArrayLike,
    level: Optional[float] = ...,
    fully_connected: Literal["low", "high"] = ...,
    positive_orientation: Literal["low", "high"] = ...,
    *,
    mask: Optional[npt.ArrayLike] = ...,
) -> list[npt.NDArray[np.float64]]: ...

class Mesh:
    vertices: npt.NDArray[np.float32]
    faces: npt.NDArray[np.int64]
    normals: npt.NDArray[np.float32]
    def __init__(
        self, vertices: npt.ArrayLike, faces: npt.ArrayLike, normals: Optional[npt.ArrayLike] = ...
    ) -> None: ...
    def check(self, self_intersections: bool = False) -> dict[str, Union[bool, int, float, None]]: ...
    def save(self, path: _Path) -> None: ...

def extract(
    source: Union[np.ndarray, _Path, _Field],
    iso: float,
    *,
    method: str = ...,
    spacing: Sequence[float] = ...,
    origin: Sequence[float] = ...,
    shape: Optional[Sequence[int]] = ...,
    threads: Optional[int] = ...,
    normals: bool = ...,
) -> Mesh: ...
def read_volume(path: _Path) -> Tuple[np.ndarray, dict[str, Tuple[float, float, float]]]: ...

def voxelize(
    mesh: Union[Mesh, np.ndarray],
    faces: Optional[np.ndarray] = None,
    *,
    resolution: int = 128,
    voxel_size: Optional[float] = None,
    band: float = 3.0,
    values: str = "sdf",
) -> Tuple[np.ndarray, dict[str, Tuple[float, float, float]]]: ...

def repair(
    mesh: Union[Mesh, np.ndarray],
    faces: Optional[np.ndarray] = None,
    *,
    resolution: int = 128,
    voxel_size: Optional[float] = None,
    band: float = 3.0,
) -> Mesh: ...
