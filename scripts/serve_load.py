#!/usr/bin/env python3
"""Load test of `keycomp serve`: CLIENTS concurrent clients post query files for SECONDS.

Starts `keycomp serve --index INDEX` on a free port, then each client posts the files in turn
(`POST /api/query?k=K`, multipart field `file`) until the time is up; prints the queries
answered per second, the latency's median and 95th percentile, the errors (any answer that is
not 200, or with --expect-class a first result of another class), and the
server's peak resident memory (VmHWM; the queries' own `keycomp query` processes are apart).

    python3 scripts/serve_load.py --keycomp target/release/keycomp --index index \\
        --clients 32 --seconds 60 demo-out/queries/*.off

Standard library only.
"""

import argparse
import json
import os
import re
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
import uuid


def multipart(path):
    """The body and content type of a multipart request carrying `path` as field `file`."""
    boundary = uuid.uuid4().hex
    with open(path, "rb") as f:
        data = f.read()
    head = (
        f"--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; "
        f"filename=\"{os.path.basename(path)}\"\r\nContent-Type: application/octet-stream\r\n\r\n"
    ).encode()
    return head + data + f"\r\n--{boundary}--\r\n".encode(), f"multipart/form-data; boundary={boundary}"


def peak_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        m = re.search(r"VmHWM:\s+(\d+) kB", f.read())
    return int(m.group(1)) if m else -1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--keycomp", default="target/release/keycomp")
    ap.add_argument("--index", default="index")
    ap.add_argument("--clients", type=int, default=32)
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("-k", type=int, default=10)
    ap.add_argument("--expect-class", action="store_true",
                    help="a query file named CLASS-… must have a CLASS-… shape first (the demo's queries)")
    ap.add_argument("--serve-arg", action="append", default=[],
                    help="an argument for keycomp serve (repeat: --serve-arg=--jobs --serve-arg=2)")
    ap.add_argument("files", nargs="+")
    args = ap.parse_args()

    server = subprocess.Popen(
        [args.keycomp, "serve", "--index", args.index, "--addr", "127.0.0.1:0", *args.serve_arg],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    line = server.stderr.readline()
    m = re.search(r"http://([^/]+)/", line)
    if not m:
        server.kill()
        sys.exit(f"no address from keycomp serve: {line!r}")
    base = f"http://{m.group(1)}"
    bodies = [(f, *multipart(f)) for f in args.files]

    latencies, errors, lock = [], [], threading.Lock()
    deadline = time.monotonic() + args.seconds

    def client(c):
        i = c
        while time.monotonic() < deadline:
            path, body, kind = bodies[i % len(bodies)]
            i += 1
            req = urllib.request.Request(f"{base}/api/query?k={args.k}", data=body,
                                         headers={"Content-Type": kind}, method="POST")
            t = time.monotonic()
            try:
                with urllib.request.urlopen(req, timeout=600) as r:
                    answer = json.load(r)
                top = answer["results"][0]["path"] if answer["results"] else ""
                cls = os.path.basename(path).split("-")[0]
                ok = not args.expect_class or os.path.basename(top).startswith(cls + "-")
                with lock:
                    latencies.append(time.monotonic() - t)
                    if not ok:
                        errors.append(f"{path}: first result {top}")
            except (urllib.error.URLError, OSError, ValueError) as e:
                with lock:
                    errors.append(f"{path}: {e}")

    start = time.monotonic()
    threads = [threading.Thread(target=client, args=(c,)) for c in range(args.clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.monotonic() - start
    peak = peak_kb(server.pid)
    server.terminate()
    server.wait()

    latencies.sort()
    q = lambda p: latencies[min(len(latencies) - 1, int(p * len(latencies)))] if latencies else float("nan")
    print(f"clients {args.clients}, {wall:.1f} s: {len(latencies)} answered, {len(latencies) / wall:.2f} queries/s, "
          f"latency p50 {q(0.5):.2f} s, p95 {q(0.95):.2f} s, errors {len(errors)}, server peak {peak / 1024:.0f} MB")
    for e in errors[:10]:
        print("  error:", e)
    sys.exit(1 if errors else 0)


if __name__ == "__main__":
    main()
