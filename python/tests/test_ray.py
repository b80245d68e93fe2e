"""`python -m keycomp.ray_index` on a local Ray instance: the merged index equals `keycomp index
add` of the same files, also when a task's worker is killed mid-shard and retried."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from test_keycomp import keycomp_binary, sphere_with_bumps, write_off

pytest.importorskip("ray")


def listing(binary, index):
    out = subprocess.run([binary, "index", "list", "--index", str(index), "--json"],
                         check=True, capture_output=True).stdout
    return sorted((r["path"], r["hash"], r["components"]) for r in json.loads(out))


def query(binary, index, mesh):
    out = subprocess.run([binary, "query", str(mesh), "--index", str(index), "--json"],
                         check=True, capture_output=True).stdout
    return [(r["path"], r["score"]) for r in json.loads(out)["results"]]


def test_sharded_indexing_equals_index_add_and_survives_a_killed_task(tmp_path):
    binary = keycomp_binary()
    shapes = tmp_path / "shapes"
    shapes.mkdir()
    v, f = sphere_with_bumps(16, 32)
    for i in range(6):
        scale = np.array([1.0, 1.0 + 0.15 * i, 1.0 - 0.08 * i])
        write_off(shapes / f"shape-{i}.off", v * scale, f)
    marker = tmp_path / "killed"
    env = dict(os.environ, KEYCOMP_RAY_FAULT_MARKER=str(marker))
    dst = tmp_path / "merged"
    run = subprocess.run(
        [sys.executable, "-m", "keycomp.ray_index", str(shapes), "--index", str(dst),
         "--shards", "3", "--chunk", "1", "--num-cpus", "2"],
        env=env, capture_output=True, text=True, timeout=600,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout.strip().splitlines()[-1])
    assert summary["shapes"] == 6 and summary["failed"] == [] and summary["broken_shards"] == []
    assert marker.exists(), "one task must have been killed after its first commit"
    assert "shard" in run.stderr  # progress

    ref = tmp_path / "ref"
    files = sorted(str(p.resolve()) for p in shapes.iterdir())
    subprocess.run([binary, "index", "add", *files, "--index", str(ref)], check=True, capture_output=True)
    merged = listing(binary, dst)
    assert merged == listing(binary, ref)
    assert len({p for p, _, _ in merged}) == 6, "each file once"
    assert query(binary, dst, files[2]) == query(binary, ref, files[2])
    verify = subprocess.run([binary, "index", "verify", "--index", str(dst)], capture_output=True, text=True)
    assert verify.returncode == 0, verify.stdout + verify.stderr
