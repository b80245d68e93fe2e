#!/usr/bin/env python3
"""A range-scan query on an index of N real shapes, end to end, against the peer's detection.

Builds an index of N shapes with `keycomp index add` (the collections' meshes and the scanned
object's model, then, while fewer than N, copies of the collections' OFF meshes under a seeded
random rotation and scale, written to WORK/copies), then alternates, round by round,
`keycomp query SCAN --index WORK/index -k 10` and the peer's detection of the scanned object's
model, and prints each one's wall times, median and peak resident memory, the ratio of the
medians, and the query's first results.

    python3 scripts/scan_query_speed.py --bin target/release/keycomp \\
        --peer "../peer-venv/bin/python ../shared/peers/peer_kc.py {mesh}" \\
        --collection ../shared/data/watertight ../shared/data/psb ../shared/data/tosca \\
            ../shared/data/faust ../shared/data/models ../shared/data/kids \\
        --model ../shared/data/scans/bun_zipper.ply \\
        --scan ../shared/data/scans/bunny/bun000.ply --shapes 1000 --work /tmp/scan-speed

The index is built once (its time and throughput are printed too) and reused by a later run
with the same WORK folder; `--fresh` rebuilds it. `--base BIN` also alternates another build's
query on the same index (a before/after in one run).
"""

import argparse
import json
import math
import os
import random
import shutil
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_compare import run  # noqa: E402

MESH_SUFFIXES = (".off", ".obj", ".ply", ".stl")


def meshes_in(folder: str) -> list[str]:
    out = []
    for root, _, files in os.walk(folder):
        out += [os.path.join(root, f) for f in files if f.lower().endswith(MESH_SUFFIXES)]
    return sorted(out)


def read_off(path: str) -> tuple[list[list[float]], list[str]]:
    """Vertices and the face lines (kept as text) of an ASCII OFF file."""
    with open(path) as f:
        tokens_lines = [ln for ln in (l.split("#")[0].strip() for l in f) if ln]
    head = tokens_lines[0]
    rest = tokens_lines[1:]
    if head != "OFF":
        if not head.startswith("OFF"):
            raise ValueError(f"{path}: not an OFF file")
        rest = [head[3:].strip()] + rest
    nv, nf = (int(x) for x in rest[0].split()[:2])
    verts = [[float(x) for x in ln.split()[:3]] for ln in rest[1 : 1 + nv]]
    return verts, rest[1 + nv : 1 + nv + nf]


def rotation(rng: random.Random) -> list[list[float]]:
    """A uniformly random rotation matrix (from a random unit quaternion)."""
    u1, u2, u3 = rng.random(), rng.random(), rng.random()
    a, b = math.sqrt(1 - u1), math.sqrt(u1)
    w, x = a * math.sin(2 * math.pi * u2), a * math.cos(2 * math.pi * u2)
    y, z = b * math.sin(2 * math.pi * u3), b * math.cos(2 * math.pi * u3)
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def write_copy(src: str, dst: str, rng: random.Random) -> None:
    verts, faces = read_off(src)
    r, s = rotation(rng), rng.uniform(0.5, 2.0)
    with open(dst + ".tmp", "w") as f:
        f.write(f"OFF\n{len(verts)} {len(faces)} 0\n")
        for v in verts:
            p = [s * sum(r[i][j] * v[j] for j in range(3)) for i in range(3)]
            f.write(f"{p[0]:.9g} {p[1]:.9g} {p[2]:.9g}\n")
        f.write("\n".join(faces) + "\n")
    os.replace(dst + ".tmp", dst)


def peer_input(model: str, work: str) -> str:
    """The model as the peer reads it: itself when OFF or binary PLY, else an OFF copy of the
    ASCII PLY without its unreferenced vertices, which the peer's geodesic solver refuses
    (written to WORK, outside the timed runs)."""
    with open(model, "rb") as f:
        head = f.read(4096)
    if not head.startswith(b"ply") or b"format ascii" not in head:
        return model
    with open(model) as f:
        lines = iter(f.read().splitlines())
    nv = nf = 0
    for line in lines:
        if line.startswith("element vertex"):
            nv = int(line.split()[2])
        elif line.startswith("element face"):
            nf = int(line.split()[2])
        elif line.strip() == "end_header":
            break
    verts = [" ".join(next(lines).split()[:3]) for _ in range(nv)]
    faces = [[int(x) for x in next(lines).split()[1:]] for _ in range(nf)]
    used = sorted({v for face in faces for v in face})
    new = {v: i for i, v in enumerate(used)}
    out = os.path.join(work, os.path.splitext(os.path.basename(model))[0] + ".off")
    with open(out, "w") as f:
        f.write(f"OFF\n{len(used)} {nf} 0\n")
        f.write("\n".join(verts[v] for v in used) + "\n")
        f.write("\n".join(f"{len(face)} " + " ".join(str(new[v]) for v in face) for face in faces))
        f.write("\n")
    return out


def build_index(args) -> None:
    files = sorted({f for c in args.collection for f in meshes_in(c)} | {args.model})
    offs = [f for f in files if f.lower().endswith(".off")]
    copies = os.path.join(args.work, "copies")
    os.makedirs(copies, exist_ok=True)
    rng = random.Random(args.seed)
    i = 0
    while len(files) < args.shapes:
        if not offs:
            sys.exit("not enough meshes: the collections hold no OFF file to copy")
        src = offs[i % len(offs)]
        dst = os.path.join(copies, f"copy{i:05d}-{os.path.basename(src)}")
        write_copy(src, dst, rng)
        files.append(dst)
        i += 1
    files = files[: args.shapes]
    if args.model not in files:
        files[-1] = args.model
    index = os.path.join(args.work, "index")
    start = time.perf_counter()
    proc = subprocess.run(
        [args.bin, "index", "add", *files, "--index", index],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"index add failed:\n{proc.stderr.decode(errors='replace')[-2000:]}")
    print(f"index add: {len(files)} shapes ({i} rotated copies) in {wall:.1f} s, "
          f"{len(files) / wall:.1f} shapes/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", required=True, help="the keycomp binary")
    parser.add_argument("--peer", required=True, help="the peer's command line, with {mesh}")
    parser.add_argument("--collection", nargs="+", required=True, help="folders of meshes")
    parser.add_argument("--model", required=True, help="the scanned object's model")
    parser.add_argument("--scan", required=True, help="the range scan to query with")
    parser.add_argument("--shapes", type=int, default=1000, help="index size (default 1000)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the copies' poses")
    parser.add_argument("--work", required=True, help="folder for the copies and the index")
    parser.add_argument("--fresh", action="store_true", help="rebuild the index")
    parser.add_argument("--base", help="another keycomp build whose query is alternated too")
    args = parser.parse_args()
    if args.rounds < 1 or args.shapes < 1:
        parser.error("--rounds and --shapes must be at least 1")
    if args.fresh and os.path.isdir(args.work):
        shutil.rmtree(args.work)
    index = os.path.join(args.work, "index")
    if not os.path.isdir(index):
        build_index(args)
    peer_model = peer_input(args.model, args.work)
    commands = [("query", f"{args.bin} query {{mesh}} --index {index} -k 10", args.scan)]
    if args.base:
        commands.append(("base query", f"{args.base} query {{mesh}} --index {index} -k 10",
                         args.scan))
    commands.append(("peer", args.peer, peer_model))
    times = {name: [] for name, _, _ in commands}
    peak = {name: 0 for name, _, _ in commands}
    for _ in range(args.rounds):
        for name, command, mesh in commands:
            wall, kb = run(command, mesh)
            times[name].append(wall)
            peak[name] = max(peak[name], kb)
    med = {k: statistics.median(v) for k, v in times.items()}
    print("| command | input | wall s (rounds) | median s | peak MB |")
    print("|---|---|---|---:|---:|")
    for name, _, mesh in commands:
        shown = args.model if name == "peer" else mesh
        rounds = ", ".join(f"{t:.2f}" for t in times[name])
        print(f"| {name} | {os.path.basename(shown)} | {rounds} | {med[name]:.2f} | "
              f"{peak[name] / 1024:.0f} |")
    print(f"peer detection / query: {med['peer'] / med['query']:.1f}x")
    if args.base:
        print(f"peer detection / base query: {med['peer'] / med['base query']:.1f}x; "
              f"query / base query: {med['query'] / med['base query']:.2f}")
    answer = subprocess.run(
        [args.bin, "query", args.scan, "--index", index, "-k", "3", "--json"],
        capture_output=True,
        text=True,
    )
    if answer.returncode == 0:
        results = json.loads(answer.stdout).get("results", [])
        print("first results:", ", ".join(os.path.basename(r.get("path", "?")) for r in results))


if __name__ == "__main__":
    main()
