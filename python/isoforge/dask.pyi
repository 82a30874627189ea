"""Type stubs of isoforge.dask (issue 48)."""

import os
from typing import Any, Dict, Iterable, Literal, Optional, Sequence, Union, overload

import numpy as np

from . import Mesh

__all__ = ["extract"]

_Chunks = Union[int, Sequence[int], Sequence[Sequence[int]]]

_Path = Union[str, "os.PathLike[str]"]

@overload
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
    labels: None = ...,
    out: None = ...,
) -> Mesh: ...
@overload
def extract(
    array: Union[np.ndarray, Any],
    iso: None = ...,
    *,
    method: str = ...,
    spacing: Sequence[float] = ...,
    origin: Sequence[float] = ...,
    chunks: Optional[_Chunks] = ...,
    client: Optional[Any] = ...,
    normals: bool = ...,
    fan_in: int = ...,
    threads: Optional[int] = 1,
    labels: Union[Literal[True], Iterable[float]],
    out: None = ...,
) -> Dict[float, Mesh]: ...
@overload
def extract(
    array: Union[np.ndarray, Any],
    iso: Optional[float] = ...,
    *,
    method: str = ...,
    spacing: Sequence[float] = ...,
    origin: Sequence[float] = ...,
    chunks: Optional[_Chunks] = ...,
    client: Optional[Any] = ...,
    normals: bool = ...,
    fan_in: int = ...,
    threads: Optional[int] = 1,
    labels: Union[None, Literal[True], Iterable[float]] = ...,
    out: _Path,
) -> Dict[Any, Any]: ...
