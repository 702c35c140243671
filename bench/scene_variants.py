"""Run a scene with some solver keys overridden and read back each level's step statistics.

Shared by the bench scripts that compare solver settings side by side (friction_stopping.py,
hessian_projection.py). The variant scene is written beside the original so that relative mesh
paths still resolve, and removed afterwards.
"""
import argparse
import json
import os
import subprocess

import h5py
import numpy as np


def parse_command_line():
    """BUILD_DIR OUT_DIR [--frames N] [SCENE.json ...]: returns (pd binary, out dir created, frames
    or 0 for the scene's count, scene paths)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=0)
    ap.add_argument("scenes", nargs="*")
    a = ap.parse_intermixed_args()
    os.makedirs(a.out, exist_ok=True)
    return os.path.join(a.build, "client", "pd"), a.out, a.frames, a.scenes


def start(pd, scene_path, solver, tag, out_dir, args):
    """Starts `pd simulate` on the scene with scene["solver"] updated by `solver`; returns
    (process, frame file, variant path). `args`: extra pd simulate arguments."""
    scene = json.load(open(scene_path))
    scene.setdefault("solver", {}).update(solver)
    stem = os.path.splitext(os.path.basename(scene_path))[0]
    variant = os.path.join(os.path.dirname(scene_path), f".{stem}-{tag}.json")
    out = os.path.join(out_dir, f"{stem}-{tag}.h5")
    with open(variant, "w") as f:
        json.dump(scene, f)
    cmd = [pd, "simulate", variant, "--out", out, "--force", "--quiet", "--allow-unconverged"] + list(args)
    return subprocess.Popen(cmd), out, variant


def finish(started):
    """Waits for start()'s process; returns {level: stats} of its frame file (see read_levels)."""
    process, out, variant = started
    try:
        if process.wait() != 0:
            raise RuntimeError(f"pd simulate on {variant} exited with {process.returncode}")
    finally:
        os.remove(variant)
    return read_levels(out)


def run(pd, scene_path, solver, tag, out_dir, args):
    return finish(start(pd, scene_path, solver, tag, out_dir, args))


def read_levels(path):
    """Per stored level: positions (frames x vertices x 3), per-step Newton iterations, solve
    seconds, projection fallbacks (zeros in files from before they were recorded), and the count of
    unconverged steps. Frame 0 (the initial state) is left out of the per-step arrays."""
    levels = {}
    with h5py.File(path, "r") as h:
        for key, level in h["levels"].items():
            if "stats" not in level or "newton_iterations" not in level["stats"]:
                continue
            stats = level["stats"]
            its = stats["newton_iterations"][1:]
            if len(its) == 0:
                continue
            fallbacks = stats["projection_fallbacks"][1:] if "projection_fallbacks" in stats else np.zeros_like(its)
            levels[int(key)] = {
                "positions": level["positions"][...],
                "iterations": its,
                "seconds": stats["solve_seconds"][1:],
                "fallbacks": fallbacks,
                "unconverged": int(np.sum(stats["newton_converged"][1:] == 0)),
                "vertices": level["positions"].shape[1],
            }
    return levels
