#!/usr/bin/env python3
"""Whether two keycomp builds give the same answers: each indexes the same files into a fresh
index, then answers the same queries with `query --json`; the answers are compared whole,
timings left out. Exits 1 when any answer differs.

    python3 scripts/compare_queries.py --a "BIN_A [ADD OPTIONS]" --b "BIN_B [ADD OPTIONS]" \
        --index FILE... --query FILE...

ADD OPTIONS go to `index add` (e.g. `--geodesic-vertices 10000` to give an older build the
newer default); queries use each index's own profile.
"""

import argparse
import json
import shlex
import subprocess
import sys
import tempfile


def strip_times(value):
    """The answer without its timings (keys naming milliseconds or seconds)."""
    if isinstance(value, dict):
        return {
            k: strip_times(v)
            for k, v in value.items()
            if not (k.endswith("_ms") or k.endswith("_s") or k in ("timings", "timings_ms"))
        }
    if isinstance(value, list):
        return [strip_times(v) for v in value]
    return value


def answers(command, index_files, queries, top):
    argv = shlex.split(command)
    binary, add_options = argv[0], argv[1:]
    with tempfile.TemporaryDirectory() as tmp:
        index = f"{tmp}/index"
        subprocess.run(
            [binary, "index", "add", *index_files, "--index", index, *add_options],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        out = []
        for q in queries:
            run = subprocess.run(
                [binary, "query", q, "--index", index, "-k", str(top), "--json"],
                check=True,
                capture_output=True,
                text=True,
            )
            out.append(strip_times(json.loads(run.stdout)))
        return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", required=True)
    parser.add_argument("--b", required=True)
    parser.add_argument("--index", nargs="+", required=True)
    parser.add_argument("--query", nargs="+", required=True)
    parser.add_argument("--top", type=int, default=10)
    args = parser.parse_args()
    a = answers(args.a, args.index, args.query, args.top)
    b = answers(args.b, args.index, args.query, args.top)
    same = 0
    for q, x, y in zip(args.query, a, b):
        verdict = "same" if x == y else "DIFFERENT"
        same += x == y
        print(f"{q}: {verdict}")
    print(f"{same} of {len(args.query)} answers the same")
    sys.exit(0 if same == len(args.query) else 1)


if __name__ == "__main__":
    main()
