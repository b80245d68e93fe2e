"""Tests of the Python package against the keycomp binary on the same files."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import keycomp

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"


def keycomp_binary():
    exe = os.environ.get("KEYCOMP_BIN") or shutil.which("keycomp")
    for candidate in [exe, ROOT / "target" / "release" / "keycomp", ROOT / "target" / "debug" / "keycomp"]:
        if candidate and Path(candidate).is_file():
            return str(candidate)
    pytest.skip("no keycomp binary built (cargo build) to compare with")


def write_off(path, vertices, faces):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(vertices)} {len(faces)} 0\n")
        for v in vertices:
            f.write(" ".join(repr(float(x)) for x in v) + "\n")
        for t in faces:
            f.write("3 " + " ".join(str(int(i)) for i in t) + "\n")


def sphere_with_bumps(n_theta=40, n_phi=80, heights=(0.5,) * 6):
    """A closed UV sphere with six bumps on the axes (+x, +y, +z, -x, -y, -z, of the given
    heights), made here (no data files)."""
    verts = [(0.0, 0.0, 1.0)]
    for i in range(1, n_theta):
        th = np.pi * i / n_theta
        for j in range(n_phi):
            ph = 2 * np.pi * j / n_phi
            d = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
            bump = 0.0
            for h, c in zip(heights, np.eye(3).tolist() + (-np.eye(3)).tolist()):
                bump += h * np.exp(-np.sum((d - np.array(c)) ** 2) / 0.05)
            verts.append(tuple((1 + bump) * d))
    verts.append((0.0, 0.0, -1.0))
    faces = []
    ring = lambda i, j: 1 + (i - 1) * n_phi + (j % n_phi)
    for j in range(n_phi):
        faces.append((0, ring(1, j), ring(1, j + 1)))
    for i in range(1, n_theta - 1):
        for j in range(n_phi):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            faces += [(a, c, b), (b, c, d)]
    last = len(verts) - 1
    for j in range(n_phi):
        faces.append((last, ring(n_theta - 1, j + 1), ring(n_theta - 1, j)))
    return np.array(verts), np.array(faces)


@pytest.fixture(scope="module")
def shape(tmp_path_factory):
    v, f = sphere_with_bumps()
    path = tmp_path_factory.mktemp("shapes") / "bumps.off"
    write_off(path, v, f)
    return path, v, f


def test_a_paper_preset_detects_on_the_mesh_as_given_like_the_cli(shape):
    path, v, f = shape
    cli = json.loads(subprocess.run([keycomp_binary(), "detect", str(path), "--json", "--preset", "kc1"],
                                    check=True, capture_output=True).stdout)
    det = keycomp.detect(v, f, preset="kc1")
    assert len(det.vertices) == len(v) == cli["vertices"]
    assert det.to_dict()["keypoints"] == cli["keypoints"]
    assert len(keycomp.detect(v, f, preset="kc1", surface="canonical").vertices) != len(v)


def test_read_mesh_round_trip(shape):
    path, v, f = shape
    rv, rf = keycomp.read_mesh(path)
    assert rv.shape == v.shape and rv.dtype == np.float64
    assert rf.dtype == np.int64
    np.testing.assert_array_equal(rf, f)
    np.testing.assert_array_equal(rv, v)


def test_detect_from_arrays_equals_the_cli(shape):
    path, v, f = shape
    cli = json.loads(subprocess.run([keycomp_binary(), "detect", str(path), "--json", "--seed", "3"],
                                    check=True, capture_output=True).stdout)
    det = keycomp.detect(v, f, seed=3)
    ours = det.to_dict()
    for d in (cli, ours):
        d.pop("timings_ms", None)
        d.pop("mesh")
    assert ours == cli
    assert det.keypoints.tolist() == cli["keypoints"]
    assert len(det.components) == len(cli["components"])
    for c, j in zip(det.components, cli["components"]):
        assert c.vertices.tolist() == j["vertices"] and c.center == j["center"]
    # the same through a trimesh-like object and through the path
    class Like:
        vertices, faces = v, f
    assert keycomp.detect(Like(), seed=3).keypoints.tolist() == cli["keypoints"]
    assert keycomp.detect(str(path), seed=3).keypoints.tolist() == cli["keypoints"]


def test_errors_are_exceptions_with_keycomp_messages(tmp_path):
    with pytest.raises(OSError, match="nosuch.off"):
        keycomp.read_mesh(tmp_path / "nosuch.off")
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    with pytest.raises(ValueError, match="bad.off"):
        keycomp.read_mesh(bad)
    with pytest.raises(ValueError, match="unknown preset"):
        keycomp.detect(np.zeros((3, 3)), np.array([[0, 1, 2]]), preset="kc9")
    with pytest.raises(ValueError, match="face 0 refers to vertex 7"):
        keycomp.detect(np.zeros((3, 3)), np.array([[0, 1, 7]]))


def test_index_add_query_remove(shape, tmp_path):
    path, v, f = shape
    other = tmp_path / "ball.off"
    vb, fb = sphere_with_bumps(20, 40)
    write_off(other, vb * np.array([1.0, 1.0, 0.6]), fb)
    index = keycomp.Index(tmp_path / "index")
    assert len(index) == 0
    assert index.add([path, other]) == 2
    assert index.add([path]) == 0, "an unchanged file is skipped"
    assert len(index) == 2
    results = index.query(path, k=5)
    assert results[0].path == str(path) and results[0].score > 0
    assert results[0].matches
    # the CLI reads the index written from Python and ranks alike
    cli = json.loads(subprocess.run([keycomp_binary(), "query", str(path), "--index", str(tmp_path / "index"),
                                     "--json"], check=True, capture_output=True).stdout)
    assert [r["path"] for r in cli["results"]] == [r.path for r in results]
    assert index.query((v, f), k=1)[0].path == str(path)
    assert index.remove([other]) == 1
    assert len(index) == 1


def range_grid_ply(path, n=60):
    """A range scan as scanners write it: an ascii PLY with a rows x cols range grid, no faces."""
    pts = []
    for r in range(n):
        for c in range(n):
            x, y = c / n - 0.5, r / n - 0.5
            z = 0.3 * np.exp(-(x * x + y * y) * 8.0) + 0.05 * np.sin(9 * x) * np.cos(7 * y)
            pts.append((x, y, z))
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nobj_info num_cols %d\nobj_info num_rows %d\n" % (n, n))
        f.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(pts))
        f.write("element range_grid %d\nproperty list uchar int vertex_indices\nend_header\n" % len(pts))
        for p in pts:
            f.write("%.9g %.9g %.9g\n" % p)
        for i in range(len(pts)):
            f.write("1 %d\n" % i)
    return np.array(pts)


def test_scans_and_point_clouds_on_canonical_surfaces(shape, tmp_path):
    path, v, f = shape
    scan = tmp_path / "scan.ply"
    pts = range_grid_ply(scan)
    cloud = tmp_path / "bumps.xyz"
    np.savetxt(cloud, v)
    index = keycomp.Index(tmp_path / "index")
    assert index.add([path, scan], surface="canonical") == 2
    # a bare point cloud of the shape's vertices finds the shape
    assert index.query(cloud, k=2)[0].path == str(path)
    # the index's choice is kept: another one raises with keycomp's message
    with pytest.raises(ValueError, match="canonical surfaces"):
        index.add([cloud], surface="as-read")
    with pytest.raises(ValueError, match="'as-read' or 'canonical'"):
        keycomp.match(path, path, surface="remeshed")
    # the scan matches its own points, read as a bare cloud, better than another shape
    xyz = tmp_path / "scan.xyz"
    np.savetxt(xyz, pts)
    own = keycomp.match(scan, xyz, surface="canonical").score
    assert own > keycomp.match(scan, path, surface="canonical").score
    assert own > 0


def test_match_is_high_for_a_shape_and_itself(shape):
    path, v, f = shape
    m = keycomp.match(path, (v, f))
    assert m.score > 0.9 and m.matches


def test_the_pose_check_keeps_a_shape_and_itself_and_refuses_bad_weights(shape, tmp_path):
    path, v, f = shape
    m = keycomp.match(path, (v, f), pose=0.5)
    assert m.pose == 1.0 and m.score > 0.9
    assert keycomp.match(path, (v, f)).pose is None, "off by default"
    index = keycomp.Index(tmp_path / "pose")
    assert index.add([path]) == 1
    assert index.query(path, k=1, pose=0.5)[0].score > 0.9
    with pytest.raises(ValueError, match="pose"):
        keycomp.match(path, path, pose=1.5)
    with pytest.raises(ValueError, match="pose"):
        index.query(path, pose=-0.1)


def test_a_half_is_verified_on_its_source_by_default(tmp_path):
    # bumps of six heights: with equal ones the shape has the cube's symmetries, and a half
    # fits it as well in any of them (only a tessellation could tell them apart)
    v, f = sphere_with_bumps(heights=(0.5, 0.3, 0.6, 0.4, 0.7, 0.35))
    path = tmp_path / "uneven.off"
    write_off(path, v, f)
    # the faces on one side of a plane: a fragment with a boundary
    keep = (v[f].mean(axis=1) @ np.array([0.3, 0.2, 1.0])) > 0.0
    used, faces = np.unique(f[keep], return_inverse=True)
    half = (v[used], faces.reshape(-1, 3))
    m = keycomp.match(half, path)
    # a perfect alignment puts about 1 - exp(-pi * 0.03**2 * 512) = 0.77 of a unit-area
    # sample within 0.03 of 512 other points drawn on the same surface
    assert m.verified is not None and m.verified > 0.65, m.verified
    assert keycomp.match(half, path, verify=0.0).verified is None
    assert keycomp.match(path, (v, f)).verified is None, "a closed shape is not verified"
    # the half moved by a known similarity is put back where it was cut from
    c, s_ = np.cos(0.8), np.sin(0.8)
    rot = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    moved = (half[0] @ rot.T * 3.0 + np.array([5.0, -2.0, 1.0]), half[1])
    t = keycomp.match(moved, path).transform
    assert t is not None and t.rms is not None
    back = moved[0] @ (np.array(t.matrix)[:3, :3]).T + np.array(t.matrix)[:3, 3]
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    assert np.median(np.linalg.norm(back - half[0], axis=1)) < 0.005 * diag
    assert abs(t.scale * 3.0 - 1.0) < 0.01, t.scale
    index = keycomp.Index(tmp_path / "verify")
    assert index.add([path]) == 1
    assert index.query(half, k=1)[0].path == str(path)
    with pytest.raises(ValueError, match="verification"):
        keycomp.match(half, path, verify=1.5)
    with pytest.raises(ValueError, match="verification"):
        index.query(half, verify=-0.1)


def test_meshes_in_memory_and_merge(shape, tmp_path):
    path, v, f = shape
    a = keycomp.Index(tmp_path / "a")
    assert a.add([("in-memory/bumps", v, f)]) == 1
    assert a.add([("in-memory/bumps", v, f)]) == 0, "the same mesh again is skipped"
    b = keycomp.Index(tmp_path / "b")
    assert b.add([path]) == 1
    merged = keycomp.Index(tmp_path / "merged")
    assert merged.merge([tmp_path / "a", tmp_path / "b"]) == 2
    assert len(merged) == 2
    top = merged.query(path, k=2)
    assert {r.path for r in top} == {"in-memory/bumps", str(path)}
    assert top[0].score > 0.9 and top[1].score > 0.9
    with pytest.raises(ValueError, match="takes paths"):
        a.add([42])


def test_a_glb_written_by_trimesh_gives_the_keypoints_of_the_off(shape, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    _, v, f = shape
    v32 = v.astype(np.float32).astype(np.float64)  # GLB stores float32
    off = tmp_path / "same.off"
    write_off(off, v32, f)
    glb = tmp_path / "same.glb"
    trimesh.Trimesh(vertices=v, faces=f, process=False).export(glb)
    gv, gf = keycomp.read_mesh(glb)
    np.testing.assert_array_equal(gv, v32)
    np.testing.assert_array_equal(gf, f)
    assert keycomp.detect(glb).keypoints.tolist() == keycomp.detect(off).keypoints.tolist()
    # the trimesh object itself, without a file
    assert (keycomp.detect(trimesh.Trimesh(vertices=v32, faces=f, process=False)).keypoints.tolist()
            == keycomp.detect(off).keypoints.tolist())
