"""Type stubs of isoforge.dask (issue 48)."""

from typing import Any, Optional, Sequence, Union

import numpy as np

from . import Mesh

__all__ = ["extract"]

_Chunks = Union[int, Sequence[int], Sequence[Sequence[int]]]

def extract(
    array: Union[np.ndarray, Any],
    iso: float,
    *,
    method: str = ...,
    spacing: Sequence[float] = ...,
    origin: Sequence[float] = ...,
    chunks: Optional[_Chunks] = ...,
    client: Optional[Any] = ...,
    normals: bool = ...,
    fan_in: int = ...,
    threads: Optional[int] = 1,
) -> Mesh: ...
