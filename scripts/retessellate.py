#!/usr/bin/env python3
"""Independent re-tessellations of the repeatability benchmark's shapes, for
`keycomp bench repeatability --remeshed DIR` (rows `retessellation` and `isometry-remeshed`).

Every mesh the benchmark reads from a data folder laid out like ../shared/data (TOSCA
`tosca/*.off`, KIDS `kids/*.off`, FAUST `faust/tr_reg_000`-`005`) is remeshed on its own by
MeshLab's isotropic explicit remeshing (pymeshlab `meshing_isotropic_explicit_remeshing`:
edge splits, collapses, flips, tangential relaxation and reprojection onto the input, after
Botsch & Kobbelt 2004), a remesher that shares no code with keycomp, with no crease edges
(`featuredeg=180`: at MeshLab's default of 30 degrees the edges of sharp creases are kept
with their vertices, about 14 % of a TOSCA cat's remeshed vertices, exactly at the salient
places where keypoints lie, so the copies would share the original's tessellation there),
at five densities: a
target edge length of e times the square root of the mesh's area, e = 0.006, 0.008, 0.011,
0.015, 0.02 (strengths 1-5: about 32,000, 18,000, 9,500, 5,100 and 2,900 vertices per shape).
The copies are written as OUT/s<strength>/<folder>/<name>.off with OUT/remesh.json (the
remesher, its version and settings, and every copy's vertex count).

    python3 -m venv ../remesh-venv && ../remesh-venv/bin/pip install pymeshlab
    ../remesh-venv/bin/python scripts/retessellate.py --data ../shared/data --out bench-out/remeshed

With --collection DIR instead, every mesh of DIR (OFF, PLY, OBJ) is remeshed once, the edge
lengths of --edges taken in turn by the files in name order (default 0.008,0.011: about 18,000
and 9,500 vertices), and written as OUT/<name>.off, with DIR's classes.csv copied if it has
one: a collection in which every shape has its own triangles, at mixed densities, for
`keycomp bench retrieval --collection OUT`:

    ../remesh-venv/bin/python scripts/retessellate.py --collection ../shared/data/faust \
        --out bench-out/faust-remeshed

OUT must not exist yet, or be a folder this script made (it is then completed: copies already
there are kept).
"""

import argparse
import json
import math
import pathlib
import sys
import time

EDGES = [0.006, 0.008, 0.011, 0.015, 0.02]
ITERATIONS = 10
FEATURE_DEGREES = 180


def inputs(data):
    """The meshes the benchmark reads, as (folder name, path)."""
    out = []
    for folder, pattern in (("tosca", "*.off"), ("kids", "*.off")):
        out += [(folder, p) for p in sorted((data / folder).glob(pattern))]
    out += [(("faust"), data / "faust" / f"tr_reg_00{i}.ply") for i in range(6)]
    return [(f, p) for f, p in out if p.is_file()]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=pathlib.Path, default=pathlib.Path("../shared/data"))
    ap.add_argument("--out", type=pathlib.Path, required=True)
    ap.add_argument("--collection", type=pathlib.Path,
                    help="remesh every mesh of this folder once (see above)")
    ap.add_argument("--edges", default="0.008,0.011",
                    help="with --collection: edge lengths per square root of the area, in turn")
    args = ap.parse_args()
    try:
        import pymeshlab
    except ImportError:
        sys.exit("retessellate.py needs pymeshlab: pip install pymeshlab (see the docstring)")
    stamp = args.out / "remesh.json"
    if args.out.exists() and not stamp.exists():
        sys.exit(f"{args.out} exists and was not made by this script: give another --out")
    if args.collection is not None:
        files = sorted(p for p in args.collection.iterdir()
                       if p.suffix.lower() in (".off", ".ply", ".obj") and p.is_file())
        if not files:
            sys.exit(f"{args.collection}: no .off, .ply or .obj meshes found")
        edges = [float(e) for e in args.edges.split(",")]
        if not edges or any(not (e > 0) for e in edges):
            sys.exit(f"--edges {args.edges}: expected positive numbers separated by commas")
        jobs = [(f"{p.stem}.off", p, edges[i % len(edges)]) for i, p in enumerate(files)]
        run(pymeshlab, args.out, stamp, jobs, edges)
        labels = args.collection / "classes.csv"
        if labels.is_file():
            (args.out / "classes.csv").write_text(labels.read_text())
        return
    files = inputs(args.data)
    jobs = [(f"s{s}/{folder}/{path.stem}.off", path, e)
            for folder, path in files for s, e in enumerate(EDGES, start=1)]
    if not files:
        sys.exit(f"{args.data}: no tosca/, kids/ or faust/ meshes found")
    run(pymeshlab, args.out, stamp, jobs, EDGES)


def run(pymeshlab, out, stamp, jobs, edges):
    """Remeshes each (relative destination, source, edge per square root of area) of jobs."""
    manifest = json.loads(stamp.read_text()) if stamp.exists() else {"copies": {}}
    manifest.update({
        "remesher": "MeshLab isotropic explicit remeshing (pymeshlab meshing_isotropic_explicit_remeshing)",
        "pymeshlab": getattr(pymeshlab, "__version__", "unknown"),
        "iterations": ITERATIONS,
        "featuredeg": FEATURE_DEGREES,
        "edge_per_sqrt_area": edges,
    })
    out.mkdir(parents=True, exist_ok=True)
    for rel, path, e in jobs:
        dest = out / rel
        if dest.exists() and rel in manifest["copies"]:
            continue
        t = time.time()
        ms = pymeshlab.MeshSet()
        ms.load_new_mesh(str(path))
        area = ms.get_geometric_measures()["surface_area"]
        ms.meshing_isotropic_explicit_remeshing(
            iterations=ITERATIONS, targetlen=pymeshlab.PureValue(e * math.sqrt(area)),
            featuredeg=FEATURE_DEGREES)
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = dest.with_suffix(".tmp.off")
        ms.save_current_mesh(str(tmp), save_vertex_normal=False, save_vertex_color=False,
                             save_face_color=False)
        tmp.rename(dest)
        m = ms.current_mesh()
        manifest["copies"][rel] = {"source": str(path), "edge_per_sqrt_area": e,
                                   "vertices": m.vertex_number(), "faces": m.face_number()}
        print(f"{rel}: {m.vertex_number()} vertices ({time.time() - t:.1f} s)", flush=True)
        stamp.write_text(json.dumps(manifest, indent=1, sort_keys=True))
    stamp.write_text(json.dumps(manifest, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
