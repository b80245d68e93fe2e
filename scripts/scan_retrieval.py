#!/usr/bin/env python3
"""Real range scans against a collection: whether `keycomp query` ranks the scanned object
first, with the object's model indexed at several resolutions.

For each model file given with --model, a collection is indexed: every file under the
--collection folders plus that model (the collection is indexed once and copied). Every scan
under --scans is then queried against each collection twice: the file as distributed (a PLY
range grid, read and triangulated by keycomp) and the same points alone (an .xyz file written
from the scan's vertices, without the grid: a bare point cloud). A query finds its object when
the model's path comes first; its rank is printed (99: not in the top 10).

    python3 scripts/scan_retrieval.py --bin target/release/keycomp \\
        --collection ../shared/data/watertight ../shared/data/psb \\
        --model ../shared/data/scans/bun_zipper.ply ../shared/data/scans/bun_zipper_res2.ply \\
                ../shared/data/scans/bun_zipper_res3.ply \\
        --scans ../shared/data/scans/bunny --surface canonical --out bench-out/scans

Extra query options (e.g. `--verify 1`) go after `--query-args`. Nothing is written outside
--out, which must not exist yet or be a folder this script made before.

With --tables, the same scans (grids and points) are also measured by `keycomp bench retrieval
--queries DIR --truth CSV` against each collection, with the D2 and FPFH baselines: OUT/tables
holds the collection (links to the --collection folders and the model), its labels (each
folder's classes.csv, the model's class 'scanned') and the ground truth, and each model's run
writes OUT/bench-<model>/ (results.json, the printed tables in tables.txt).
"""

import argparse
import json
import pathlib
import shutil
import statistics
import subprocess
import sys
import time


def ply_vertices(path):
    """The x y z of every vertex of an ascii PLY (the raw scans' format)."""
    with open(path, "rb") as f:
        count = None
        while True:
            line = f.readline()
            if not line:
                raise SystemExit(f"{path}: no end_header")
            words = line.split()
            if words[:2] == [b"element", b"vertex"]:
                count = int(words[2])
            if words[:1] == [b"format"] and words[1] != b"ascii":
                raise SystemExit(f"{path}: only ascii PLY scans are converted to points")
            if line.strip() == b"end_header":
                break
        if count is None:
            raise SystemExit(f"{path}: no vertex element")
        return [f.readline().split()[:3] for _ in range(count)]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stderr}")
    return r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--collection", nargs="+", required=True)
    ap.add_argument("--model", nargs="+", required=True)
    ap.add_argument("--scans", required=True)
    ap.add_argument("--surface", default="canonical", choices=["as-read", "canonical"])
    ap.add_argument("--out", required=True)
    ap.add_argument("--tables", action="store_true",
                    help="also run bench retrieval --queries/--truth (baselines included)")
    ap.add_argument("--query-args", nargs=argparse.REMAINDER, default=[])
    a = ap.parse_args()

    out = pathlib.Path(a.out)
    marker = out / ".scan_retrieval"
    if out.exists():
        if not marker.exists():
            raise SystemExit(f"{out}: exists and was not made by this script")
        shutil.rmtree(out)
    out.mkdir()
    marker.touch()

    scans = sorted(pathlib.Path(a.scans).glob("*.ply"))
    if not scans:
        raise SystemExit(f"{a.scans}: no .ply scans")
    points = out / "points"
    points.mkdir()
    clouds = []
    for s in scans:
        c = points / (s.stem + ".xyz")
        c.write_text("".join(" ".join(v.decode() for v in p) + "\n" for p in ply_vertices(s)))
        clouds.append(c)

    base = out / "index-base"
    t = time.perf_counter()
    run([a.bin, "index", "add", *a.collection, "--index", str(base), "--surface", a.surface])
    print(f"collection indexed in {time.perf_counter() - t:.1f} s ({a.surface})")

    results = []
    for model in a.model:
        model = pathlib.Path(model)
        index = out / f"index-{model.stem}"
        shutil.copytree(base, index)
        run([a.bin, "index", "add", str(model), "--index", str(index)])
        for kind, files in (("grid", scans), ("points", clouds)):
            ranks, times = [], []
            for f in files:
                t = time.perf_counter()
                o = json.loads(
                    run([a.bin, "query", str(f), "--index", str(index), "-k", "10", "--json",
                         *a.query_args])
                )
                times.append(time.perf_counter() - t)
                paths = [r["path"] for r in o["results"]]
                hit = [i for i, p in enumerate(paths) if pathlib.Path(p).name == model.name]
                ranks.append(hit[0] + 1 if hit else 99)
            first = sum(r == 1 for r in ranks)
            top = sum(r != 99 for r in ranks)
            results.append({"model": model.name, "kind": kind, "ranks": ranks,
                            "first": first, "top10": top,
                            "median_query_s": statistics.median(times)})
            print(f"{model.name} {kind}: first {first}/{len(ranks)}, top 10 {top}/{len(ranks)}, "
                  f"median query {statistics.median(times):.2f} s, ranks {ranks}", flush=True)
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n")
    if a.tables:
        tables(a, out, scans, clouds)


def tables(a, out, scans, clouds):
    """`keycomp bench retrieval` with the scans as external queries, one run per model."""
    t = out / "tables"
    queries = t / "queries"
    queries.mkdir(parents=True)
    for f in [*scans, *clouds]:
        (queries / f.name).symlink_to(f.resolve())
    labels = ["file,class"]
    for c in a.collection:
        c = pathlib.Path(c)
        csv = c / "classes.csv"
        if not csv.exists():
            raise SystemExit(f"{csv}: --tables needs each collection folder's classes.csv")
        for line in csv.read_text().splitlines()[1:]:
            if line.strip():
                labels.append(f"{c.name}/{line.strip()}")
    for model in a.model:
        model = pathlib.Path(model)
        coll = t / f"collection-{model.stem}"
        coll.mkdir()
        for c in a.collection:
            (coll / pathlib.Path(c).name).symlink_to(pathlib.Path(c).resolve())
        (coll / model.name).symlink_to(model.resolve())
        (t / f"labels-{model.stem}.csv").write_text(
            "\n".join([*labels, f"{model.name},scanned"]) + "\n")
        (t / f"truth-{model.stem}.csv").write_text(
            "query,source\n" + "".join(f"{f.name},{model.name}\n" for f in [*scans, *clouds]))
        report = run([a.bin, "bench", "retrieval", "--collection", str(coll),
                      "--labels", str(t / f"labels-{model.stem}.csv"),
                      "--queries", str(queries), "--truth", str(t / f"truth-{model.stem}.csv"),
                      "--partial", "none", "--surface", a.surface,
                      "--cache", str(t / "cache"), "--out", str(out / f"bench-{model.stem}")])
        (out / f"bench-{model.stem}" / "tables.txt").write_text(report)
        print(f"== {model.name}\n{report}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
