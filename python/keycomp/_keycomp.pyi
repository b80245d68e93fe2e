"""keycomp: key-components of 3D meshes (Sipiran & Bustos 2013) for matching and partial retrieval.

Type stubs of the compiled module (`keycomp._keycomp`, re-exported by `keycomp`). Meshes are given as a path (str or os.PathLike), a
(vertices, faces) pair of arrays, or an object with .vertices and .faces (a trimesh.Trimesh).
Errors raise OSError (a file cannot be read or written) or ValueError (bad data or arguments),
with keycomp's messages.
"""

import os
from typing import Any, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

MeshLike = Union[str, os.PathLike, Tuple[npt.ArrayLike, npt.ArrayLike], Any]

def read_mesh(path: Union[str, os.PathLike]) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """(vertices (n, 3) float64, faces (m, 3) int64) of a mesh file, ids as `keycomp detect` uses."""

def mesh_files(paths: Sequence[Union[str, os.PathLike]]) -> list[str]:
    """The mesh files among paths and below its folders, as `keycomp index add` lists them."""

class Component:
    id: int
    center: int
    area: float
    @property
    def vertices(self) -> npt.NDArray[np.int64]: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def keypoints(self) -> npt.NDArray[np.int64]: ...

class DetectionResult:
    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """(n, 3) positions of the mesh detection ran on (the canonical surface by default): the ids are its."""
    @property
    def faces(self) -> npt.NDArray[np.int64]:
        """(m, 3) triangles of that mesh."""
    @property
    def keypoints(self) -> npt.NDArray[np.int64]:
        """Keypoints (vertex ids), best first."""
    @property
    def components(self) -> list[Component]: ...
    def to_dict(self) -> dict[str, Any]:
        """`keycomp detect --json` without `timings_ms`."""

def detect(
    mesh: MeshLike,
    faces: Optional[npt.ArrayLike] = None,
    *,
    preset: str = "robust",
    surface: Optional[Literal["canonical", "as-read"]] = None,
    density: Optional[float] = None,
    fraction: Optional[float] = None,
    count: Optional[int] = None,
    r: Optional[float] = None,
    t: Optional[float] = None,
    n: Optional[int] = None,
    sigma: Optional[float] = None,
    seed: Optional[int] = None,
) -> DetectionResult:
    """Key-components with the parameters of `keycomp detect` (a preset, then options on top), on the
    canonical surface or the mesh as given (`surface="as-read"`); unless told, as `keycomp detect`:
    canonical with the robust preset, as given with the paper's presets."""

class Match:
    query_component: int
    target_component: int
    distance: float

class Transform:
    """Where a query sits on a shape: p' = scale * rotation @ p + translation, from the query's
    file coordinates to the shape's (column vectors; rotation and the 4x4 matrix row-major)."""
    rotation: list[list[float]]
    translation: list[float]
    scale: float
    matrix: list[list[float]]
    verified: float
    rms: Optional[float]

class QueryResult:
    path: str
    score: float
    matches: list[Match]
    transform: Optional[Transform]

class MatchResult:
    score: float
    matches: list[Match]
    rejected: int
    scale: Optional[float]
    pose: Optional[float]
    verified: Optional[float]
    transform: Optional[Transform]

def match(
    a: MeshLike,
    b: MeshLike,
    pose: float = 0.0,
    verify: Optional[float] = None,
    surface: Optional[Literal["canonical", "as-read"]] = None,
) -> MatchResult:
    """Part-to-part matching of two meshes, scans or point clouds, as
    `keycomp match A B [--pose W] [--verify W] [--surface canonical|as-read]`."""

class Index:
    def __init__(self, path: Union[str, os.PathLike]) -> None: ...
    @property
    def path(self) -> str: ...
    def add(
        self,
        items: Sequence[Union[str, os.PathLike, Tuple[Union[str, os.PathLike], npt.ArrayLike, npt.ArrayLike]]],
        surface: Optional[Literal["canonical", "as-read"]] = None,
    ) -> int:
        """Adds mesh, scan or point-cloud files (folders searched recursively) or
        (name, vertices, faces) meshes; returns shapes added or replaced. `surface` as
        `keycomp index add --surface` (recorded by a new index; another than the index's raises)."""
    def add_files(
        self,
        paths: Sequence[Union[str, os.PathLike]],
        surface: Optional[Literal["canonical", "as-read"]] = None,
    ) -> dict[str, Any]:
        """As `keycomp index add`: failures listed, the others stored (commits of 32 shapes).
        Returns {"added", "replaced", "unchanged", "failed": [{"path", "message"}], "shapes"}."""
    def merge(self, sources: Sequence[Union[str, os.PathLike]]) -> int:
        """Merges indexes built apart into this one (one commit); returns shapes added."""
    def remove(self, paths: Sequence[Union[str, os.PathLike]]) -> int: ...
    def query(
        self, mesh: MeshLike, k: int = 10, pose: float = 0.0, verify: Optional[float] = None
    ) -> list[QueryResult]: ...
    def __len__(self) -> int: ...
