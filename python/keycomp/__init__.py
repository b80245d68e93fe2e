"""keycomp: key-components of 3D meshes (Sipiran & Bustos 2013) for matching and partial retrieval.

The compiled module `keycomp._keycomp` does the work; its names are re-exported here.
`keycomp.ray_index` indexes a collection in shards on a Ray cluster.
"""

from ._keycomp import (
    Component,
    DetectionResult,
    Index,
    Match,
    MatchResult,
    QueryResult,
    __version__,
    detect,
    match,
    mesh_files,
    read_mesh,
)

__all__ = [
    "Component",
    "DetectionResult",
    "Index",
    "Match",
    "MatchResult",
    "QueryResult",
    "__version__",
    "detect",
    "match",
    "mesh_files",
    "read_mesh",
]
