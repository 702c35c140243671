#!/usr/bin/python3
"""Our direct step against Codim-IPC's on its FEMShell cloth-on-sphere scene (issue 16).

Codim-IPC (the C-IPC paper's code, GitHub ipc-sim/Codim-IPC) is not built here: build it apart and
point this script at its meshes (Projects/FEMShell/input/). The scene is its test 6
(6_cloth_on_rotating_sphere.py) with the 3 249-vertex cloth square57.obj: a 1 m cotton square 8.2 mm
above the fixed 1 239-vertex sphere1K_0.3.obj (centred at the origin, y up), a fixed 21 x 21 floor
square21.obj 0.16 m below the centre, dhat 1e-3 m, contact offset 0, friction 0.4 against the sphere
and the floor and 0.1 cloth on cloth, eps_v 1e-3 m/s, strain limit 1.0608, 20 steps. The sphere's
spin starts at t = 1 s, after the 20 steps, so it is a fixed obstacle here.

Material, matched term by term (Codim-IPC's MEMBRANE.h and its hinge):
  membrane: the same compressible neo-Hookean energy of the first fundamental form, E = 8 210 Pa
    (0.821 MPa x membEMult 0.01), nu = 0.243, t = 0.318 mm, rho = 472.64 kg/m^3;
  bending: Codim-IPC's hinge energy is 3 k |e|^2 / (A1 + A2) (theta - theta_bar)^2 with
    k = E_b t^3 / (24 (1 - nu^2)), E_b = 82 100 Pa; ours is (D / 2) |e|^2 / (A1 + A2) (...)^2 with
    D = E_b' t^3 / (12 (1 - nu^2)), so the same energy needs E_b' = 3 E_b = 246 300 Pa;
  strain limit: C-IPC's barrier on both principal stretches, limit 1.0608, acting from stretch 1 (its
    s_hat) with kappa_s = 1e3 weighted by h^2 * area * thickness in its h^2-scaled potential, i.e.
    1e3 * t = 0.318 J/m^2 per rest area here (physics/strain_limit.h). --our-strain-band keeps our
    defaults instead (band from 1.0547, kappa_s = E t = 2.61 J/m^2): a different material.

Prints per run (with and without friction, and per solver tolerance if given): Newton iterations per
step and solve seconds per step (frame statistics), on one thread. Pause other processes for the
seconds to mean anything. With --reference-tolerance, also the accuracy of each run: the largest and
the RMS distance of the cloth's vertices to a run at that (tight) tolerance, at the middle and the
last step (speed against error for the stopping rule; the same measure of Codim-IPC's runs against
its own tight run is what "equal accuracy" compares).

Usage: bench/codim_cloth_sphere.py BUILD_DIR OUT_DIR CODIM_MESH_DIR [--steps N] [--time-step H]
       [--friction MU ...] [--our-strain-band] [--tolerances TOL ...] [--reference-tolerance TOL]
"""
import argparse
import json
import os
import subprocess

import numpy as np

import scene_variants

MESHES = {"cloth": "square57.obj", "sphere": "sphere1K_0.3.obj", "floor": "square21.obj"}


THICKNESS = 0.318e-3  # m


def scene(steps, h, friction, codim_strain_band=True, tolerance=None):
    strain_limit = {"limit": 1.0608}
    if codim_strain_band:
        strain_limit.update({"barrier_start": 1.0, "stiffness": 1e3 * THICKNESS})
    pairs = [{"objects": ["cloth", "sphere"], "friction": friction},
             {"objects": ["cloth", "floor"], "friction": friction},
             {"objects": ["cloth", "cloth"], "friction": 0.25 * friction}]
    d = {
        "format_version": 1,
        "name": "codim-cloth-sphere",
        "description": "Codim-IPC's FEMShell cloth on sphere (test 6, square57), see bench/codim_cloth_sphere.py",
        "time_step": h,
        "frames": steps,
        "contact": {"dhat": 1e-3, "offset": 0.0, "eps_v": 1e-3, "friction": 0.0, "pair_friction": pairs},
        "objects": [
            {"name": "cloth", "mesh": {"type": "obj", "path": MESHES["cloth"]},
             "transform": {"translation": [0, 0.16, 0]},
             "material": {"density": 472.641509, "youngs_modulus": 8210.0, "poisson_ratio": 0.243,
                          "thickness": THICKNESS, "bending_youngs_modulus": 246300.0},
             "self_contact": True, "strain_limit": strain_limit},
            {"name": "sphere", "mesh": {"type": "obj", "path": MESHES["sphere"]}, "obstacle": True},
            {"name": "floor", "mesh": {"type": "obj", "path": MESHES["floor"]},
             "transform": {"translation": [0, -0.16, 0]}, "obstacle": True},
        ],
    }
    if tolerance is not None:
        d["solver"] = {"tolerance": tolerance}
    return d


def run(pd, out_dir, a, friction, tolerance):
    """One direct run; returns its finest level's read_levels() record."""
    tag = f"mu{friction}" + ("" if tolerance is None else f"-tol{tolerance:g}")
    path = os.path.join(out_dir, f"codim-cloth-sphere-{tag}.json")
    with open(path, "w") as f:
        json.dump(scene(a.steps, a.time_step, friction, not a.our_strain_band, tolerance), f, indent=1)
    out = os.path.join(out_dir, f"codim-cloth-sphere-{tag}.h5")
    subprocess.run([pd, "simulate", path, "--mode", "direct", "--threads", "1", "--out", out, "--force",
                    "--quiet", "--allow-unconverged"], check=True)
    r = scene_variants.read_levels(out)
    return r[max(r)]


def obj_vertex_count(path):
    with open(path) as f:
        return sum(1 for line in f if line.startswith("v "))


def cloth_distances(positions, reference, steps, cloth_vertices):
    """Largest and RMS distance (m) of the cloth's vertices (the scene's first object, so its rows
    come first) to the reference's at each of `steps`."""
    cloth = slice(0, cloth_vertices)
    out = []
    for t in steps:
        d = np.linalg.norm(positions[t, cloth] - reference[t, cloth], axis=1)
        out.append((float(d.max()), float(np.sqrt(np.mean(d * d)))))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("out")
    ap.add_argument("meshes", help="Codim-IPC's Projects/FEMShell/input (or a copy of its three OBJ files)")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--time-step", type=float, default=0.01)
    ap.add_argument("--our-strain-band", action="store_true",
                    help="our default strain-limit band and stiffness instead of Codim-IPC's")
    ap.add_argument("--friction", type=float, nargs="+", default=[0.4, 0.0],
                    help="friction coefficients to run (cloth-cloth gets a quarter)")
    ap.add_argument("--tolerances", type=float, nargs="+", default=None,
                    help="solver.tolerance values to run (1/s, times the bounding-box diagonal); default: the scene's")
    ap.add_argument("--reference-tolerance", type=float, default=None,
                    help="also run this tolerance and print each run's cloth distance to it at the middle and last step")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    for name in MESHES.values():  # the scene's paths are relative to its folder
        link = os.path.join(a.out, name)
        if os.path.lexists(link):
            os.remove(link)
        os.symlink(os.path.abspath(os.path.join(a.meshes, name)), link)
    pd = os.path.join(a.build, "client", "pd")
    checked = [a.steps // 2, a.steps]
    cloth_vertices = obj_vertex_count(os.path.join(a.meshes, MESHES["cloth"]))
    header = "| friction | tolerance | steps | h (s) | Newton its/step | solve s/step | s per iteration | unconverged |"
    if a.reference_tolerance is not None:
        header += "".join(f" max / RMS distance step {t} (m) |" for t in checked)
    print(header)
    print("|" + " ---: |" * (header.count("|") - 1))
    for friction in a.friction:
        reference = run(pd, a.out, a, friction, a.reference_tolerance) if a.reference_tolerance is not None else None
        for tolerance in a.tolerances or [None]:
            r = run(pd, a.out, a, friction, tolerance)
            its, secs = float(np.mean(r["iterations"])), float(np.mean(r["seconds"]))
            row = (f"| {friction} | {'default' if tolerance is None else f'{tolerance:g}'} | {len(r['iterations'])} "
                   f"| {a.time_step} | {its:.1f} | {secs:.3f} | {secs / its:.3f} | {r['unconverged']} |")
            if reference is not None:
                row += "".join(f" {m:.2e} / {q:.2e} |"
                               for m, q in cloth_distances(r["positions"], reference["positions"], checked,
                                                              cloth_vertices))
            print(row, flush=True)


if __name__ == "__main__":
    main()
