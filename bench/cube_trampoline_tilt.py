#!/usr/bin/python3
"""Why cube-trampoline's finest refinement step cost more Newton iterations than a direct finest
step (issue 16): the two runs did not move alike. With the quadric decimation the preview's coarse
sheet (100 of 441 vertices, an irregular triangulation) tips the landing cube over, the refinement
follows the preview's motion (PD eq. 5), and a cube rocking on an edge takes more iterations per
step than the level cube of the direct finest run on its regular 21 x 21 grid. The scene now uses
`coarsening: "grid"` (symmetric sub-grids); `--quadric` puts back the scene as it was (vertex
counts 200 / 100 for the sheet and 20 / 8 for the cube) to compare.

For scenes/cube-trampoline.json and with the cube dropped already tilted (so that the
direct run rocks too), runs `pd simulate` progressively and directly on the finest mesh, both at
once (one per core, one thread each). Prints per run: Newton iterations per finest step, the
refinement's over the direct run's, and the cube's rotation (also the preview's) from its pose at rest (degrees, from
frame 20 on, before the cube lands, to the last frame; fitted over the cube's vertices).

Usage: bench/cube_trampoline_tilt.py BUILD_DIR OUT_DIR [--frames N] [--tilts DEG ...] [--quadric]
"""
import argparse
import json
import os

import h5py
import numpy as np

import scene_variants

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "scenes", "cube-trampoline.json")
TILT_AXIS = [1.0, 0.0, 0.3]  # horizontal, off the cube's edges so that it lands on a corner


def rotation_deg(rest, posed):
    """Angle (degrees) of the best-fitting rotation from `rest` to `posed` (rows: vertices), Kabsch."""
    a, b = rest - rest.mean(axis=0), posed - posed.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(u @ vt))
    r = (u @ np.diag([1.0, 1.0, d]) @ vt).T
    return float(np.degrees(np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))))


def cube_angles(positions, cube_vertices, frames):
    """The cube's rotation at `frames`; the cube is the scene's last object, its rows come last."""
    cube = slice(positions.shape[1] - cube_vertices, positions.shape[1])
    return [rotation_deg(positions[20, cube], positions[t, cube]) for t in frames]


def cube_vertices_on_level(frame_file, level):
    """The cube's vertex count on `level` (the cube is the scene's last object)."""
    with h5py.File(frame_file, "r") as f:
        offsets = f[f"hierarchy/{level}/object_offsets"][:]
    return int(offsets[-1] - offsets[-2])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--tilts", type=float, nargs="*", default=[10.0, 25.0],
                    help="initial tilts of the cube (degrees) besides the scene's level drop")
    ap.add_argument("--quadric", action="store_true",
                    help="quadric decimation to the old counts instead of the scene's grid coarsening")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    pd = os.path.join(a.build, "client", "pd")
    scene = json.load(open(SCENE))
    sheet_vertices = (scene["objects"][0]["mesh"]["cells"][0] + 1) * (scene["objects"][0]["mesh"]["cells"][1] + 1)
    if a.quadric:  # the scene as it was before 2026-12-06's grid coarsening
        scene["objects"][0]["hierarchy"] = {"vertex_counts": [200, 100]}
        scene["objects"][1]["hierarchy"] = {"vertex_counts": [20, 8]}
    checked = list(range(40, a.frames + 1, 20))
    print("| cube dropped | run | finest its/step | refinement / direct | cube rotation (deg) at frames "
          + ", ".join(map(str, checked)) + " |")
    print("| --- | --- | ---: | ---: | --- |")
    for tilt in [0.0] + a.tilts:
        solver = {}
        path = SCENE
        if tilt or a.quadric:
            variant = json.loads(json.dumps(scene))
            if tilt:
                variant["objects"][1]["transform"]["rotation"] = {"axis": TILT_AXIS, "angle_deg": tilt}
            path = os.path.join(a.out, f"cube-trampoline-tilt{tilt:g}.json")
            with open(path, "w") as f:
                json.dump(variant, f)
        runs = {mode: scene_variants.start(pd, path, solver, f"tilt{tilt:g}-{mode}", a.out,
                                           ["--mode", mode, "--frames", str(a.frames), "--threads", "1"])
                for mode in ("progressive", "direct")}
        levels = {mode: scene_variants.finish(started) for mode, started in runs.items()}
        finest = {mode: r[max(r)] for mode, r in levels.items()}
        its = {mode: float(np.mean(f["iterations"])) for mode, f in finest.items()}
        dropped = "level" if not tilt else f"tilted {tilt:g} deg"
        coarsest = min(levels["progressive"])
        preview = levels["progressive"][coarsest]
        preview_cube = cube_vertices_on_level(runs["progressive"][1], coarsest)
        print(f"| {dropped} | preview | | | "
              + ", ".join(f"{x:.1f}" for x in cube_angles(preview["positions"], preview_cube, checked)) + " |")
        for mode in ("progressive", "direct"):
            cube_vertices = finest[mode]["vertices"] - sheet_vertices
            angles = cube_angles(finest[mode]["positions"], cube_vertices, checked)
            ratio = f"{its['progressive'] / its['direct']:.2f}x" if mode == "progressive" else ""
            print(f"| {dropped} | {mode} | {its[mode]:.2f} | {ratio} | " + ", ".join(f"{x:.1f}" for x in angles) + " |",
                  flush=True)


if __name__ == "__main__":
    main()
