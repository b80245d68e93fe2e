"""Index a collection in shards on a Ray cluster, then merge the shards into one index.

    python -m keycomp.ray_index PATH... --index DST --shards N [--address ADDR]
                                [--work DIR] [--retries R] [--chunk C]

The mesh files are listed as `keycomp index add` lists them (folders searched recursively,
sorted), split into N shards of consecutive files, and each shard is indexed by one Ray task
into its own index `WORK/shard-NNN` (WORK defaults to `DST.shards`, next to DST; on a real
cluster it must be storage every node sees, as must the mesh files). A task adds its files
in chunks of C, each chunk committed before the next, so a task that dies (a killed worker,
a lost node) is retried (up to R times) and its retry skips what is already committed: nothing
is lost or indexed twice. When every shard is done, the shards are merged into DST in one
commit (`keycomp.Index.merge`: same-content duplicates stored once). Progress goes to stderr;
the summary (JSON) to stdout. Exit status 0, or 2 when a file could not be analysed or a shard
failed for good (the other shards are still merged).

On a cluster: `ray start --head` on one machine, `ray start --address HEAD:6379` on the
others, then run this with `--address HEAD:6379` (or `--address auto` on a node). Without
`--address`, a local Ray instance is started with the CPUs Ray detects.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import keycomp

# Fault injection for the tests: when this environment variable names a file that does not
# exist yet, the first task that has committed a chunk creates it and kills its own worker
# process, as a crash would. Never set in normal use.
FAULT_ENV = "KEYCOMP_RAY_FAULT_MARKER"


def shards_of(files: list[str], n: int) -> list[list[str]]:
    """`files` split into at most `n` runs of consecutive files, sizes differing by at most 1."""
    n = max(1, min(n, len(files)))
    size, extra = divmod(len(files), n)
    out, start = [], 0
    for i in range(n):
        end = start + size + (1 if i < extra else 0)
        out.append(files[start:end])
        start = end
    return out


def index_shard(shard_dir: str, files: list[str], chunk: int, fault_marker: str | None) -> dict:
    """Indexes `files` into the index at `shard_dir`, `chunk` files per commit. Returns the
    summed `Index.add_files` summaries of the chunks."""
    index = keycomp.Index(shard_dir)
    total = {"added": 0, "replaced": 0, "unchanged": 0, "failed": [], "shapes": 0}
    for start in range(0, len(files), chunk):
        s = index.add_files(files[start : start + chunk])
        for key in ("added", "replaced", "unchanged"):
            total[key] += s[key]
        total["failed"].extend(s["failed"])
        total["shapes"] = s["shapes"]
        if fault_marker and not os.path.exists(fault_marker) and start + chunk < len(files):
            Path(fault_marker).write_text(f"{shard_dir} killed after {start + chunk} files\n")
            os._exit(1)  # a crash: the worker process dies with nothing reported
    return total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m keycomp.ray_index",
        description="Index mesh files in shards on a Ray cluster, then merge the shards.",
    )
    parser.add_argument("paths", nargs="+", help="mesh files or folders (searched recursively)")
    parser.add_argument("--index", required=True, help="the merged index (created if needed)")
    parser.add_argument("--shards", type=int, required=True, help="number of shards (Ray tasks)")
    parser.add_argument("--address", help="Ray cluster address (default: start a local Ray)")
    parser.add_argument("--work", help="folder of the shard indexes (default: INDEX.shards)")
    parser.add_argument("--retries", type=int, default=3, help="retries of a failed task (default 3)")
    parser.add_argument("--chunk", type=int, default=32, help="files per commit in a task (default 32)")
    parser.add_argument("--num-cpus", type=int, help="CPUs of a local Ray instance (default: all)")
    args = parser.parse_args(argv)
    if args.shards < 1 or args.chunk < 1 or args.retries < 0:
        parser.error("--shards and --chunk must be at least 1, --retries at least 0")

    import ray  # only this module needs Ray

    try:
        files = keycomp.mesh_files(args.paths)
    except (OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if not files:
        print("error: no mesh files (.off, .obj, .ply, .stl, .gltf, .glb) in the paths given", file=sys.stderr)
        return 2
    dst = Path(args.index)
    work = Path(args.work) if args.work else dst.with_name(dst.name + ".shards")
    if not work.parent.is_dir():
        print(f"error: {work}: {work.parent} does not exist (parent folders are not created)", file=sys.stderr)
        return 2
    work.mkdir(exist_ok=True)
    # absolute paths: the tasks may run elsewhere, and the index stores the paths given
    files = [str(Path(f).resolve()) for f in files]
    shards = shards_of(files, args.shards)

    t0 = time.monotonic()
    if args.address:
        ray.init(address=args.address, log_to_driver=False)
    else:
        ray.init(num_cpus=args.num_cpus, log_to_driver=False, include_dashboard=False)
    fault = os.environ.get(FAULT_ENV)
    task = ray.remote(max_retries=args.retries, retry_exceptions=True)(index_shard)
    dirs = [str((work / f"shard-{i:03d}").resolve()) for i in range(len(shards))]
    pending = {
        task.remote(d, shard, args.chunk, fault): (i, len(shard)) for i, (d, shard) in enumerate(zip(dirs, shards))
    }
    print(f"indexing {len(files)} files in {len(shards)} shards under {work}", file=sys.stderr)
    summaries, broken = {}, []
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        ref = done[0]
        i, n = pending.pop(ref)
        try:
            s = ray.get(ref)
        except Exception as e:  # the task failed for good, after its retries
            broken.append({"shard": i, "error": str(e).splitlines()[0] if str(e) else repr(e)})
            print(f"shard {i}: failed after {args.retries} retries: {broken[-1]['error']}", file=sys.stderr)
            continue
        summaries[i] = s
        print(
            f"shard {i}: {n} files, {s['added'] + s['replaced']} indexed, {s['unchanged']} unchanged, "
            f"{len(s['failed'])} failed ({len(summaries)}/{len(shards)} shards, {time.monotonic() - t0:.1f} s)",
            file=sys.stderr,
        )
    ray.shutdown()
    merged_from = [dirs[i] for i in sorted(summaries) if summaries[i]["shapes"] > 0]
    added = keycomp.Index(dst).merge(merged_from) if merged_from else 0
    failed = [f for i in sorted(summaries) for f in summaries[i]["failed"]]
    for f in failed:
        print(f"  failed: {f['message']}", file=sys.stderr)
    summary = {
        "index": str(dst),
        "files": len(files),
        "shards": len(shards),
        "merged": added,
        "shapes": len(keycomp.Index(dst)),
        "failed": failed,
        "broken_shards": broken,
        "seconds": round(time.monotonic() - t0, 3),
    }
    print(json.dumps(summary))
    return 2 if failed or broken else 0


if __name__ == "__main__":
    sys.exit(main())
