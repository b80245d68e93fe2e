from ._keycomp import (
    Component as Component,
    DetectionResult as DetectionResult,
    Index as Index,
    Match as Match,
    MatchResult as MatchResult,
    QueryResult as QueryResult,
    __version__ as __version__,
    detect as detect,
    match as match,
    mesh_files as mesh_files,
    read_mesh as read_mesh,
)
