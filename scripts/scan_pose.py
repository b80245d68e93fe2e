#!/usr/bin/env python3
"""Where keycomp puts raw range scans on their model, against the scanner's own registration
(the one `.conf` file of the scans' folder: the bunny's `bun.conf`, the dragon's `dragon.conf`).

For each scan in --scans (the Stanford repository's `bunXXX.ply` range grids, and the same
points written alone as `.xyz`, a bare point cloud), runs `keycomp match SCAN MODEL --json` for
each --model, or with --index `keycomp query SCAN --index DIR --json` (the first result must be
the model), and compares the transform it reports (`transform`: scan file coordinates to model
file coordinates) with the .conf's: `bmesh FILE tx ty tz qi qj qk qr`, read as the rotation of
the conjugate of the unit quaternion (qi, qj, qk, qr) = (x, y, z, w) (the transpose of its
rotation), then the translation, taking the scan's points into the model's frame. The script
first checks that reading: moved by the .conf, the scan's points must lie within 0.3 % of the
model's bounding-box diagonal of its vertices (median, `--conf-check`; the other readings put
them 5 % or more away).

Prints per scan and kind: the rotation error (degrees), the median displacement of the scan's
points between the two transforms (% of the model's diagonal), the scale, the wall time; then,
per model and kind, how many are within the tolerances (--max-degrees, --max-percent,
--max-scale) and the median time. Pure Python; no third-party module. With --open3d PYTHON,
each scan's points are also registered onto each model by `scripts/open3d_register.py` (Open3D's
FPFH + RANSAC + point-to-plane ICP, told the units), run by that Python just before keycomp on
the same pair: rows `open3d points`, with the peer's own registration time beside its
process's wall time.

    python3 scripts/scan_pose.py --bin target/release/keycomp \\
        --scans ../shared/data/scans/bunny \\
        --model ../shared/data/scans/bun_zipper.ply ../shared/data/scans/bun_zipper_res3.ply \\
        --out bench-out/scan-pose
"""

import argparse
import json
import math
import pathlib
import statistics
import subprocess
import sys
import time


def ply_header(f):
    fmt, counts, props = None, [], {}
    current = None
    while True:
        line = f.readline()
        if not line:
            raise SystemExit("no end_header")
        w = line.split()
        if w[:1] == [b"format"]:
            fmt = w[1].decode()
        elif w[:1] == [b"element"]:
            current = w[1].decode()
            counts.append((current, int(w[2])))
            props[current] = []
        elif w[:1] == [b"property"]:
            props[current].append(w)
        elif line.strip() == b"end_header":
            return fmt, counts, props


def ply_vertices(path):
    """x y z of every vertex of an ascii PLY (the raw scans' format and the models') or of an
    OBJ's `v` lines (a model)."""
    if str(path).lower().endswith(".obj"):
        with open(path) as f:
            return [tuple(float(x) for x in line.split()[1:4])
                    for line in f if line.startswith("v ")]
    with open(path, "rb") as f:
        fmt, counts, _ = ply_header(f)
        if fmt != "ascii":
            raise SystemExit(f"{path}: only ascii PLY is read here")
        n = dict(counts)["vertex"]
        if counts[0][0] != "vertex":
            raise SystemExit(f"{path}: vertices must come first")
        return [tuple(float(x) for x in f.readline().split()[:3]) for _ in range(n)]


def quat_matrix(x, y, z, w):
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def apply(m, t, p, s=1.0):
    return tuple(s * sum(m[i][j] * p[j] for j in range(3)) + t[i] for i in range(3))


def angle_between(a, b):
    """Degrees of the rotation a·bᵀ."""
    tr = sum(a[i][j] * b[i][j] for i in range(3) for j in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1.0) / 2.0))))


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def grid_nearest(points, cell):
    """A uniform-grid lookup of the nearest of `points` (for the convention check)."""
    g = {}
    for p in points:
        g.setdefault(tuple(int(math.floor(c / cell)) for c in p), []).append(p)

    def nearest(q):
        k = tuple(int(math.floor(c / cell)) for c in q)
        best = math.inf
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for p in g.get((k[0] + dx, k[1] + dy, k[2] + dz), ()):
                        best = min(best, dist(p, q))
        return best

    return nearest


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--scans", required=True)
    ap.add_argument("--model", nargs="+", required=True)
    ap.add_argument("--index", help="query this index instead of matching each model")
    ap.add_argument("--out", required=True)
    ap.add_argument("--max-degrees", type=float, default=0.5)
    ap.add_argument("--max-percent", type=float, default=0.2)
    ap.add_argument("--max-scale", type=float, default=0.005)
    ap.add_argument("--conf-check", type=float, default=0.3, metavar="PERCENT",
                    help="how near the .conf must put each scan's points to the first model's "
                         "vertices (median, %% of its diagonal; a coarse model's vertices are "
                         "farther apart: 1 for the dragon's 5,205-vertex model)")
    ap.add_argument("--open3d", metavar="PYTHON",
                    help="also register each scan's points onto each model with "
                         "scripts/open3d_register.py run by this Python (alternated with keycomp)")
    a = ap.parse_args()

    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    scans_dir = pathlib.Path(a.scans)
    confs = sorted(scans_dir.glob("*.conf"))
    if len(confs) != 1:
        raise SystemExit(f"{scans_dir}: one .conf file expected, found {len(confs)}")
    conf_name = confs[0].name
    conf = {}
    for line in confs[0].read_text().splitlines():
        w = line.split()
        if w[:1] == ["bmesh"]:
            t = [float(x) for x in w[2:5]]
            qi, qj, qk, qr = (float(x) for x in w[5:9])
            # the rotation of the conjugate quaternion (the transpose of (qi, qj, qk, qr)'s):
            # the reading under which every scan lies on the model (checked below)
            conf[w[1]] = (quat_matrix(-qi, -qj, -qk, qr), t)
    scans = sorted(p for p in scans_dir.glob("*.ply") if p.name in conf)

    first_model = ply_vertices(a.model[0])
    lo = [min(p[i] for p in first_model) for i in range(3)]
    hi = [max(p[i] for p in first_model) for i in range(3)]
    diag = dist(lo, hi)
    near = grid_nearest(first_model, 0.05 * diag)
    # the reading of the .conf, checked: moved by it, a scan lies on the model
    for s in scans:
        m, t = conf[s.name]
        pts = ply_vertices(s)[::50]
        med = statistics.median(near(apply(m, t, p)) for p in pts)
        if med > 0.01 * a.conf_check * diag:
            raise SystemExit(f"{s.name}: {conf_name} read wrongly (median {100 * med / diag:.3f} %)")
    print(f"{conf_name} read as the conjugate's rotation, then the translation: every scan lies on {a.model[0]} "
          f"(diagonal {diag:.4f})", flush=True)

    clouds = {}
    for s in scans:
        c = out / (s.stem + ".xyz")
        c.write_text("".join(f"{p[0]} {p[1]} {p[2]}\n" for p in ply_vertices(s)))
        clouds[s.name] = c

    def measure(s, kind, name, tr, wall):
        """One row: how far the transform `tr` puts scan `s` from where the .conf puts it."""
        gm, gt = conf[s.name]
        if tr is None:
            print(f"{name} {kind} {s.name}: no transform ({wall:.2f} s)", flush=True)
            return {"scan": s.name, "kind": kind, "model": name, "found": True,
                    "degrees": None, "percent": None, "scale": None, "s": wall}
        deg = angle_between(tr["rotation"], gm)
        pts = ply_vertices(s)[::20]
        disp = statistics.median(
            dist(apply(tr["rotation"], tr["translation"], p, tr["scale"]),
                 apply(gm, gt, p)) for p in pts)
        pct = 100 * disp / diag
        print(f"{name} {kind} {s.name}: rotation {deg:.3f}°, displacement {pct:.3f} %, "
              f"scale {tr['scale']:.4f} ({wall:.2f} s)", flush=True)
        return {"scan": s.name, "kind": kind, "model": name, "found": True, "degrees": deg,
                "percent": pct, "scale": tr["scale"], "s": wall, "rms": tr.get("rms"),
                "registration_s": tr.get("seconds")}

    rows = []
    models = [None] if a.index else a.model
    for model in models:
        for kind in ("grid", "points"):
            for s in scans:
                f = s if kind == "grid" else clouds[s.name]
                if a.open3d and not a.index and kind == "points":
                    peer = pathlib.Path(__file__).with_name("open3d_register.py")
                    cmd = [a.open3d, str(peer), str(f), str(model)]
                    t0 = time.perf_counter()
                    r = subprocess.run(cmd, capture_output=True, text=True)
                    wall = time.perf_counter() - t0
                    if r.returncode != 0:
                        raise SystemExit(f"{' '.join(cmd)}: {r.stderr}")
                    rows.append(measure(s, "open3d " + kind, pathlib.Path(model).name,
                                        json.loads(r.stdout), wall))
                if a.index:
                    cmd = [a.bin, "query", str(f), "--index", a.index, "-k", "10", "--json"]
                else:
                    cmd = [a.bin, "match", str(f), str(model), "--json"]
                t0 = time.perf_counter()
                r = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                if r.returncode != 0:
                    raise SystemExit(f"{' '.join(cmd)}: {r.stderr}")
                o = json.loads(r.stdout)
                if a.index:
                    hit = o["results"][0] if o["results"] else {}
                    found = bool(hit) and any(
                        pathlib.Path(hit["path"]).name == pathlib.Path(m).name for m in a.model)
                    tr = hit.get("transform")
                    name = pathlib.Path(hit["path"]).name if hit else "-"
                else:
                    found, tr, name = True, o.get("transform"), pathlib.Path(model).name
                if not found:
                    rows.append({"scan": s.name, "kind": kind, "model": name, "found": False,
                                 "degrees": None, "percent": None, "scale": None, "s": wall})
                    print(f"{name} {kind} {s.name}: not first ({wall:.2f} s)", flush=True)
                    continue
                rows.append(measure(s, kind, name, tr, wall))
    (out / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    print()
    print("| model | input | within tolerances | rotation ° (median) | displacement % (median) "
          "| median s | registration s (median) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    def reg_median(sel):
        reg = [r["registration_s"] for r in sel if r.get("registration_s") is not None]
        return f"{statistics.median(reg):.2f}" if reg else "-"

    keys = sorted({(r["model"], r["kind"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for model, kind in keys:
        sel = [r for r in rows if r["model"] == model and r["kind"] == kind]
        ok = [r for r in sel if r["degrees"] is not None and r["degrees"] <= a.max_degrees
              and r["percent"] <= a.max_percent and abs(r["scale"] - 1) <= a.max_scale]
        degs = [r["degrees"] for r in sel if r["degrees"] is not None]
        pcts = [r["percent"] for r in sel if r["percent"] is not None]
        print(f"| {model} | {kind} | {len(ok)}/{len(sel)} | "
              f"{statistics.median(degs) if degs else float('nan'):.3f} | "
              f"{statistics.median(pcts) if pcts else float('nan'):.3f} | "
              f"{statistics.median(r['s'] for r in sel):.2f} | "
              f"{reg_median(sel)} |")


if __name__ == "__main__":
    sys.exit(main())
