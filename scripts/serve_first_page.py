#!/usr/bin/env python3
"""Time to the first page of `keycomp serve`: what a browser fetches to show the collection.

Starts `keycomp serve --index INDEX` on a free port and times, from the server's first answer:
the page and its scripts, `/api/index`, the first page of shapes (`/api/shapes?limit=48`) and
its 48 thumbnails (6 at a time, as a browser fetches from one host). Prints each step and the
total, for ROUNDS fresh servers (the first with the thumbnails folder as found, so a new index
renders its thumbnails; later ones read them from the cache), the server's peak resident
memory, and what it holds afterwards: its own (RssAnon) and the memory-mapped index (RssFile).

    python3 scripts/serve_first_page.py --keycomp target/release/keycomp --index index

Standard library only.
"""

import argparse
import concurrent.futures
import json
import re
import subprocess
import sys
import time
import urllib.error
import urllib.request


def fetch(url):
    try:
        with urllib.request.urlopen(url, timeout=600) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def one_round(args):
    server = subprocess.Popen(
        [args.keycomp, "serve", "--index", args.index, "--addr", "127.0.0.1:0"],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        m = re.search(r"http://([^/]+)/", server.stderr.readline())
        if not m:
            sys.exit("no address from keycomp serve")
        base = f"http://{m.group(1)}"
        t0 = time.monotonic()
        steps = []
        for path in ["/", "/assets/app.js", "/assets/three.min.js", "/api/index"]:
            fetch(base + path)
        steps.append(("page, scripts, /api/index", time.monotonic() - t0))
        t = time.monotonic()
        status, body = fetch(base + "/api/shapes?offset=0&limit=48&filter=")
        shapes = json.loads(body)["shapes"]
        steps.append((f"/api/shapes (first 48 of {json.loads(body)['total']})", time.monotonic() - t))
        t = time.monotonic()
        with concurrent.futures.ThreadPoolExecutor(6) as pool:
            codes = list(pool.map(lambda s: fetch(f"{base}/api/shapes/{s['id']}/thumb.png")[0], shapes))
        ok = sum(1 for c in codes if c == 200)
        steps.append((f"48 thumbnails ({ok} pictures, {len(codes) - ok} without a file)", time.monotonic() - t))
        total = time.monotonic() - t0
        with open(f"/proc/{server.pid}/status") as f:
            status = f.read()
        kb = lambda key: int(re.search(key + r":\s+(\d+) kB", status).group(1)) / 1024
        # resident file pages are the memory-mapped index (page cache, given back under pressure)
        return steps, total, (kb("VmHWM"), kb("RssAnon"), kb("RssFile"))
    finally:
        server.terminate()
        server.wait()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--keycomp", default="target/release/keycomp")
    ap.add_argument("--index", default="index")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    for r in range(args.rounds):
        steps, total, (peak, anon, mapped) = one_round(args)
        parts = ", ".join(f"{name} {sec * 1e3:.0f} ms" for name, sec in steps)
        print(f"round {r + 1}: total {total * 1e3:.0f} ms ({parts}); server peak {peak:.0f} MB, "
              f"then {anon:.0f} MB own and {mapped:.0f} MB of mapped files")


if __name__ == "__main__":
    main()
