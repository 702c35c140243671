#!/usr/bin/python3
"""Newton's two friction stopping rules side by side (solver.friction_stopping, issue 16).

For each friction scene, runs `pd simulate --mode direct` twice in one go, with "contacts" (the
default: friction contacts' tangential steps below 0.1 eps_v, the rest at the scene's tolerance)
and "uniform" (every vertex below min(tolerance x diagonal, 0.1 eps_v)), and prints per rule the
Newton iterations and solve seconds per step, and between the two runs the largest vertex distance
over all frames (m). Pause other processes for the seconds to mean anything.

Usage: bench/friction_stopping.py BUILD_DIR OUT_DIR [--frames N] [SCENE.json ...]
(default scenes: every scene of scenes/ and scenes/stress/ with friction)
"""
import json
import os
import sys

import numpy as np

import scene_variants

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RULES = ("contacts", "uniform")


def has_friction(scene):
    contact, ground = scene.get("contact"), scene.get("ground") or {}
    if not contact:
        return False
    pairs = [p.get("friction", 0) for p in contact.get("pair_friction", [])]
    return max([contact.get("friction", 0), ground.get("friction", 0)] + pairs) > 0


def friction_scenes():
    out = []
    for folder in ("scenes", "scenes/stress"):
        for name in sorted(os.listdir(os.path.join(ROOT, folder))):
            path = os.path.join(ROOT, folder, name)
            if name.endswith(".json") and has_friction(json.load(open(path))):
                out.append(path)
    return out


def run(pd, scene_path, rule, frames, out_dir):
    args = ["--mode", "direct"] + (["--frames", str(frames)] if frames else [])
    levels = scene_variants.run(pd, scene_path, {"friction_stopping": rule}, rule, out_dir, args)
    return levels[max(levels)]


def main():
    pd, out, frames, scenes = scene_variants.parse_command_line()
    print("| scene | vertices | frames | its/step contacts | its/step uniform | ratio | s/step contacts "
          "| s/step uniform | ratio | unconverged (c/u) | max distance (m) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for path in scenes or friction_scenes():
        r = {rule: run(pd, path, rule, frames, out) for rule in RULES}
        c, u = r["contacts"], r["uniform"]
        dist = float(np.max(np.linalg.norm(c["positions"] - u["positions"], axis=2)))
        ic, iu = float(np.mean(c["iterations"])), float(np.mean(u["iterations"]))
        sc, su = float(np.mean(c["seconds"])), float(np.mean(u["seconds"]))
        name = os.path.relpath(path, ROOT)
        print(f"| {name} | {c['vertices']} | {len(c['iterations'])} | {ic:.1f} | {iu:.1f} | {ic / iu:.2f} "
              f"| {sc:.3f} | {su:.3f} | {sc / su:.2f} | {c['unconverged']}/{u['unconverged']} | {dist:.2e} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
