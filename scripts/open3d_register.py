#!/usr/bin/env python3
"""The peer of `keycomp match` for a pose: Open3D's global registration (FPFH features, RANSAC on
their correspondences) refined by point-to-plane ICP, told the units: every length is a fixed
share of the model's bounding-box diagonal, which keycomp does not need to be told.

    PYTHON scripts/open3d_register.py SOURCE TARGET [--voxel-share 0.01] [--seed 0]

SOURCE (a scan's points: .ply, .xyz) is registered onto TARGET (a mesh, sampled uniformly at
100,000 points on its faces, or a point cloud). A scan whose PLY has faces (a range grid) is
sampled so too; pass its points as .xyz to use them as they are.
Parameters, those of Open3D's global-registration tutorial in units of the voxel v = share ×
TARGET's diagonal: both clouds down-sampled on a v grid; normals from 30 neighbours within 2v;
FPFH within 5v (100 neighbours); RANSAC on the features' mutual nearest neighbours, 3 points a
sample, inliers within 1.5v, edge-length (0.9) and distance checkers, 100,000 iterations at
confidence 0.999; then point-to-plane ICP from that pose within 0.4v on the full clouds (normals
within 2v), 60 iterations. Open3D's RANSAC is seeded (`--seed`).

Prints one JSON object: `rotation` (3×3, row-major), `translation`, `scale` (1: a rigid
registration), `fitness` and `inlier_rmse` of the ICP, and `seconds` spent registering (reading,
down-sampling, features, RANSAC, ICP; not the import of open3d). `pip install open3d-cpu`
(the benchmark's only use of it).
"""

import argparse
import json
import sys
import time

import numpy as np
import open3d as o3d

# points sampled uniformly on a mesh given as TARGET or SOURCE
SAMPLES = 100_000


def read_points(path):
    if str(path).endswith(".xyz"):
        pts = np.loadtxt(path, usecols=(0, 1, 2), ndmin=2)
        return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    mesh = o3d.io.read_triangle_mesh(str(path))
    if len(mesh.triangles) > 0:
        # a mesh's surface, not its vertices: a coarse model's vertices are sparser than the
        # voxel, and FPFH on them fails (0 of 10 scans on the bunny at 1.9k vertices)
        return mesh.sample_points_uniformly(number_of_points=SAMPLES)
    if len(mesh.vertices) > 0:
        return o3d.geometry.PointCloud(mesh.vertices)
    return o3d.io.read_point_cloud(str(path))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("source")
    ap.add_argument("target")
    ap.add_argument("--voxel-share", type=float, default=0.01)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    o3d.utility.random.seed(a.seed)
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)

    t0 = time.perf_counter()
    src, dst = read_points(a.source), read_points(a.target)
    if len(src.points) == 0 or len(dst.points) == 0:
        raise SystemExit(f"{a.source} or {a.target}: no points")
    v = a.voxel_share * np.linalg.norm(dst.get_max_bound() - dst.get_min_bound())

    def features(cloud):
        down = cloud.voxel_down_sample(v)
        down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * v, max_nn=30))
        fpfh = o3d.pipelines.registration.compute_fpfh_feature(
            down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * v, max_nn=100))
        return down, fpfh

    sd, sf = features(src)
    dd, df = features(dst)
    reg = o3d.pipelines.registration
    coarse = reg.registration_ransac_based_on_feature_matching(
        sd, dd, sf, df, True, 1.5 * v,
        reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         reg.CorrespondenceCheckerBasedOnDistance(1.5 * v)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    for c in (src, dst):
        c.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * v, max_nn=30))
    fine = reg.registration_icp(
        src, dst, 0.4 * v, coarse.transformation,
        reg.TransformationEstimationPointToPlane(),
        reg.ICPConvergenceCriteria(max_iteration=60))
    seconds = time.perf_counter() - t0
    m = np.asarray(fine.transformation)
    json.dump({"rotation": m[:3, :3].tolist(), "translation": m[:3, 3].tolist(), "scale": 1.0,
               "fitness": fine.fitness, "inlier_rmse": fine.inlier_rmse, "seconds": seconds},
              sys.stdout)
    print()


if __name__ == "__main__":
    main()
