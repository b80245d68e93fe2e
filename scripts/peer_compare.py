#!/usr/bin/env python3
"""Wall time and peak memory of keycomp against a peer program, alternated in one run.

For every mesh, each round runs every command once, in order (keycomp variants, then the peer),
so slow and fast moments of a shared machine fall on all of them alike. It prints, per mesh and
command, the wall times of the rounds, their median, the peak resident memory (the largest of
the rounds) and the ratio of the peer's median to each keycomp median.

    python3 scripts/peer_compare.py --rounds 3 \
        --peer "../peer-venv/bin/python ../shared/peers/peer_kc.py {mesh}" \
        --keycomp "now=target/release/keycomp detect {mesh} --json" \
        ../shared/data/models/nefertiti.obj ../shared/data/kids/0001.null.0.off

`{mesh}` in a command is replaced by the mesh's path; every command's standard output is
discarded. A command that fails stops the run with its exit code and standard error.
"""

import argparse
import os
import shlex
import statistics
import subprocess
import sys
import time


def run(command: str, mesh: str) -> tuple[float, int]:
    """Wall seconds and peak resident kilobytes of one run of `command` on `mesh`."""
    argv = [a.replace("{mesh}", mesh) for a in shlex.split(command)]
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if proc.returncode != 0:
        sys.exit(f"{' '.join(argv)} failed with exit code {proc.returncode}:\n{err}")
    return wall, usage.ru_maxrss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("meshes", nargs="+", help="mesh files")
    parser.add_argument("--peer", required=True, help="the peer's command line, with {mesh}")
    parser.add_argument(
        "--keycomp",
        action="append",
        required=True,
        help="NAME=COMMAND, a keycomp command line with {mesh}; repeatable",
    )
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")
    commands = []
    for spec in args.keycomp:
        name, sep, command = spec.partition("=")
        if not sep or not name or not command:
            parser.error(f"--keycomp {spec!r}: expected NAME=COMMAND")
        commands.append((name, command))
    commands.append(("peer", args.peer))

    print("| mesh | command | wall s (rounds) | median s | peak MB | peer / this |")
    print("|---|---|---|---:|---:|---:|")
    for mesh in args.meshes:
        walls = {name: [] for name, _ in commands}
        peaks = {name: 0 for name, _ in commands}
        for _ in range(args.rounds):
            for name, command in commands:
                wall, rss = run(command, mesh)
                walls[name].append(wall)
                peaks[name] = max(peaks[name], rss)
        peer = statistics.median(walls["peer"])
        for name, _ in commands:
            med = statistics.median(walls[name])
            rounds = ", ".join(f"{w:.2f}" for w in walls[name])
            ratio = f"{peer / med:.1f}×" if name != "peer" else ""
            print(
                f"| {os.path.basename(mesh)} | {name} | {rounds} | {med:.2f} | "
                f"{peaks[name] / 1024:.0f} | {ratio} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
