#!/usr/bin/python3
"""Newton's Hessian projections side by side: "clamp" (every indefinite element Hessian clamped)
against "exact_first", the default (a Newton iterate tries the exact Hessian and is reassembled
clamped when CHOLMOD finds the assembled system indefinite, or at once after a capped step),
issue 16.

For each scene, runs `pd simulate` progressively (every level) and directly on the finest mesh,
once per projection, the two projections of one configuration at the same time (one per core,
one thread each, so they see the same load). Prints per level and run: Newton iterations and solve
seconds per step for both, exact_first's fallbacks per step, unconverged steps, the largest vertex
distance between the two runs over all frames (m), and the finest refinement step's cost over the
direct finest step's under each projection (the issue's 1.3x goal).

Usage: bench/hessian_projection.py BUILD_DIR OUT_DIR [--frames N] [SCENE.json ...]
(default: the progressive scenes of scenes/)
"""
import os
import sys

import numpy as np

import scene_variants

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PROJECTIONS = ("clamp", "exact_first")
SCENES = ("cube-trampoline", "flag", "drape-gear", "basket", "ball-drop", "spin-sphere")


def pair(pd, path, mode, frames, out_dir):
    """{projection: {level: stats}} of one mode ("progressive" or "direct"), both run at once."""
    args = ["--mode", mode, "--threads", "1"] + (["--frames", str(frames)] if frames else [])
    started = {p: scene_variants.start(pd, path, {"hessian_projection": p}, f"{mode}-{p}", out_dir, args)
               for p in PROJECTIONS}
    return {p: scene_variants.finish(s) for p, s in started.items()}


def row(name, run, level, c, e):
    dist = float(np.max(np.linalg.norm(c["positions"] - e["positions"], axis=2)))
    ic, ie = np.mean(c["iterations"]), np.mean(e["iterations"])
    sc, se = np.mean(c["seconds"]), np.mean(e["seconds"])
    print(f"| {name} | {run} | {level} | {c['vertices']} | {ic:.1f} | {ie:.1f} | {sc:.4f} | {se:.4f} "
          f"| {se / sc:.2f} | {np.mean(e['fallbacks']):.2f} | {c['unconverged']}/{e['unconverged']} | {dist:.2e} |")


def main():
    pd, out, frames, scenes = scene_variants.parse_command_line()
    scenes = scenes or [os.path.join(ROOT, "scenes", s + ".json") for s in SCENES]
    print("| scene | run | level | vertices | its/step clamp | its/step exact_first | s/step clamp "
          "| s/step exact_first | time ratio | fallbacks/step | unconverged (c/e) | max distance (m) |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    summary = []
    for path in scenes:
        name = os.path.splitext(os.path.basename(path))[0]
        prog = pair(pd, path, "progressive", frames, out)
        direct = pair(pd, path, "direct", frames, out)
        for level in sorted(prog["clamp"]):
            row(name, "progressive", level, prog["clamp"][level], prog["exact_first"][level])
        finest = max(direct["clamp"])
        # A direct run stores the one mesh it simulates (the finest) as its only level.
        row(name, "direct", "finest", direct["clamp"][finest], direct["exact_first"][finest])
        ratios = []
        for p in PROJECTIONS:
            r, d = prog[p][max(prog[p])], direct[p][finest]
            ratios.append((np.mean(r["iterations"]) / np.mean(d["iterations"]),
                           np.mean(r["seconds"]) / np.mean(d["seconds"])))
        summary.append((name, ratios))
        sys.stdout.flush()
    print()
    print("| scene | finest refinement / direct finest, clamp: its, time | exact_first: its, time |")
    print("| --- | --- | --- |")
    for name, ((ic, tc), (ie, te)) in summary:
        print(f"| {name} | {ic:.2f}x, {tc:.2f}x | {ie:.2f}x, {te:.2f}x |")


if __name__ == "__main__":
    main()
