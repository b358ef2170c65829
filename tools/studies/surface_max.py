#!/usr/bin/python3
"""Where a run's surface overlay error is largest, and why (docs/studies/surface_max.md).

Reads a run of `dynaguide run` on a phantom scene (run.h5 with /errors/surface_mm,
mesh_series.h5) and the phantom's truth.h5, and prints, for the largest errors
over the first WINDOW simulated frames:
  - the point's error (mm) and its frame;
  - how obliquely the left camera sees it: |cos| of the angle between the
    surface normal and the viewing ray (0 at the silhouette, 1 face on);
  - the distance (mm, reference geometry) to the nearest node tied to a track;
  - the worst track near it: the track's distance (mm) to the true surface,
    a wrong stereo match showing as a track off the surface.
Then the same three properties for all points, split by error, and the
paper's statistic beside ours: one typical feature (the point, visible in
every frame of the window, with the median RMS error) against the maximum
over all visible points.

Needs Debian's python3-numpy and python3-h5py.
"""
import argparse

import h5py
import numpy as np

NEIGHBOURS = 12        # truth points a normal is fitted to (the phantom's are ~1 mm apart)
TRACK_RADIUS_M = 5e-3  # tracks this close to a point are its neighbours


def unit_normals(xyz):
    """Per point, the normal of the plane through its nearest neighbours (PCA)."""
    d2 = ((xyz[:, None, :] - xyz[None, :, :]) ** 2).sum(-1)
    near = np.argsort(d2, axis=1)[:, :NEIGHBOURS]
    normals = np.empty_like(xyz)
    for i, idx in enumerate(near):
        centred = xyz[idx] - xyz[idx].mean(0)
        normals[i] = np.linalg.svd(centred, full_matrices=False)[2][-1]
    return normals


def distance_to_surface(points, surface, normals):
    """Each point's distance to the true surface: to the tangent plane of its nearest truth point."""
    nearest = ((points[:, None, :] - surface[None, :, :]) ** 2).sum(-1).argmin(1)
    return np.abs(((points - surface[nearest]) * normals[nearest]).sum(-1))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", help="the run's output folder (run.h5, mesh_series.h5)")
    parser.add_argument("truth", help="the phantom's truth.h5")
    parser.add_argument("--window", type=int, default=60, help="simulated frames measured (the protocol's window)")
    parser.add_argument("--top", type=int, default=10, help="largest errors listed")
    args = parser.parse_args()

    with h5py.File(f"{args.run}/run.h5", "r") as run, h5py.File(args.truth, "r") as truth, \
            h5py.File(f"{args.run}/mesh_series.h5", "r") as series:
        if "surface_mm" not in run["errors"]:
            raise SystemExit(f"{args.run}/run.h5 has no /errors/surface_mm: run it again with this dynaguide")
        frames = run["errors/frame"][: args.window]
        errors = run["errors/surface_mm"][: args.window]          # [row][point], NaN where unseen
        X_S = truth["surface_points/X_S_m"][:]                    # reference positions, scan frame
        xyz_C = truth["surface_points/xyz_C_m"][:]                # [frame][point][3]
        nodes_S = series["mesh/geometry_m"][:]
        steps = sorted(series["steps"].keys())
        tied = [series[f"steps/{s}/point/tied"][:].astype(bool) for s in steps[: len(frames)]]
        track_frame = run["tracks/frame"][:]
        track_xyz = run["tracks/xyz_C_m"][:]

    rows = []  # (error, row, point)
    cos_view = np.full(errors.shape, np.nan)
    tie_mm = np.full(errors.shape, np.nan)
    track_mm = np.full(errors.shape, np.nan)
    for r, f in enumerate(frames):
        seen = ~np.isnan(errors[r])
        surface = xyz_C[f]
        normals = unit_normals(surface)
        rays = surface / np.linalg.norm(surface, axis=1, keepdims=True)
        cos_view[r, seen] = np.abs((normals[seen] * rays[seen]).sum(1))
        tied_S = nodes_S[tied[r]]
        if len(tied_S):
            d2 = ((X_S[seen][:, None, :] - tied_S[None, :, :]) ** 2).sum(-1)
            tie_mm[r, seen] = 1e3 * np.sqrt(d2.min(1))
        here = track_xyz[track_frame == f]
        if len(here):
            off_mm = 1e3 * distance_to_surface(here, surface, normals)
            d2 = ((surface[seen][:, None, :] - here[None, :, :]) ** 2).sum(-1)
            near = d2 < TRACK_RADIUS_M ** 2
            track_mm[r, seen] = np.where(near.any(1), np.where(near, off_mm[None, :], 0).max(1), np.nan)
        rows += [(errors[r, p], r, p) for p in np.flatnonzero(seen)]

    rows.sort(reverse=True)
    print(f"largest surface errors over {len(frames)} simulated frames (frames {frames[0]}-{frames[-1]})")
    print("error_mm  frame  point  |cos view|  nearest_tie_mm  worst_track_near_mm")
    for e, r, p in rows[: args.top]:
        print(f"{e:8.3f}  {frames[r]:5d}  {p:5d}  {cos_view[r, p]:10.3f}  {tie_mm[r, p]:14.2f}  {track_mm[r, p]:19.3f}")

    seen = ~np.isnan(errors)
    e = errors[seen]
    print("\nall visible (frame, point) pairs, by error:")
    print("error band         pairs  median |cos view|  median nearest_tie_mm  median worst_track_near_mm")
    for lo, hi in [(0, 0.25), (0.25, 0.5), (0.5, 1.0), (1.0, np.inf)]:
        band = (e >= lo) & (e < hi)
        if band.any():
            print(f"[{lo:4.2f}, {hi:4.2f}) mm  {band.sum():7d}  {np.median(cos_view[seen][band]):17.3f}  "
                  f"{np.median(tie_mm[seen][band]):21.2f}  {np.nanmedian(track_mm[seen][band]):26.3f}")

    always = seen.all(0)
    rms = np.sqrt((errors[:, always] ** 2).mean(0))
    typical = np.flatnonzero(always)[np.argsort(rms)[len(rms) // 2]]
    course = errors[:, typical]
    print(f"\nthe paper's statistic, one typical feature (point {typical}, median RMS of the "
          f"{always.sum()} points seen in every frame): avg {course.mean():.3f}  max {course.max():.3f}  "
          f"RMS {np.sqrt((course ** 2).mean()):.3f} mm")
    print(f"ours, all visible points: avg {e.mean():.3f}  max {e.max():.3f}  RMS {np.sqrt((e ** 2).mean()):.3f} mm")


if __name__ == "__main__":
    main()
