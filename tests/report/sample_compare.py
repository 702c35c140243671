#!/usr/bin/python3
"""A stand-in for `pd compare FILE [OTHER] --json [--seams T,...]` while the real one is being
written: prints JSON of the agreed shape (see bench/report/make_report.sh's callers) computed
roughly from the frame files, so that the report's scripts can be tested end to end. Its numbers
are NOT pd compare's: centre-of-mass deviation = sum over objects of |c - c_ref|; vertex distance
only between levels of equal vertex count; "Hausdorff" = the symmetric Hausdorff distance between
the two vertex sets (not the surfaces); seam d(t) = mean over vertices of the difference of the two
files' second differences x(t+1) - 2 x(t) + x(t-1), at T and T + 1 of each --seams T. Only for tests (tests/report/pd_sample_compare.sh).
"""
import argparse
import json
import sys

import h5py
import numpy as np


def levels(path):
    with h5py.File(path, "r") as f:
        h = float(json.loads(f.attrs["scene"])["time_step"])
        for name, g in f["levels"].items():
            done = np.flatnonzero(g["done"][:])
            if done.size:
                ke = g["stats/kinetic_energy"][:] if "kinetic_energy" in g["stats"] else np.full(g["done"].shape, np.nan)
                yield {"file": path, "level": int(name), "h": h, "frames": done, "x": g["positions"][:],
                       "com": g["stats/center_of_mass"][:], "ke": ke}


def hausdorff(a, b):
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1))
    return max(d.min(1).max(), d.min(0).max())


def stats3(values, frames):
    v = np.array(values, dtype=float)
    ok = np.isfinite(v)
    if not ok.any():
        return None
    i = int(np.nanargmax(v))
    return {"mean": float(np.nanmean(v)), "max": float(v[i]), "max_frame": int(frames[i])}


def entry(s, ref):
    frames = [int(t) for t in s["frames"] if t in set(ref["frames"].tolist())]
    com = [float(np.linalg.norm(s["com"][t] - ref["com"][t], axis=1).sum()) for t in frames]
    same = s["x"].shape[1] == ref["x"].shape[1]
    vd = [np.linalg.norm(s["x"][t] - ref["x"][t], axis=1) for t in frames] if same else None
    hd = [float(hausdorff(s["x"][t], ref["x"][t])) for t in frames]
    ke = [float(s["ke"][t]) for t in frames]
    e = {"file": s["file"], "level": s["level"], "vertices": int(s["x"].shape[1]), "frames": len(frames),
         "time_step_s": s["h"], "com_deviation_m": stats3(com, frames),
         "vertex_distance_m": None, "hausdorff_m": stats3(hd, frames),
         "kinetic_energy_J": {"first": ke[0], "max": float(np.nanmax(ke)), "last": ke[-1]},
         "per_frame": {"frame": frames, "com_deviation_m": com, "vertex_distance_mean_m": [None] * len(frames),
                       "vertex_distance_p95_m": [None] * len(frames), "vertex_distance_max_m": [None] * len(frames),
                       "hausdorff_m": hd, "kinetic_energy_J": ke}}
    if same:
        all_d = np.concatenate(vd)
        e["vertex_distance_m"] = {"mean": float(all_d.mean()), "p95": float(np.percentile(all_d, 95)),
                                  "max": float(all_d.max())}
        e["per_frame"]["vertex_distance_mean_m"] = [float(d.mean()) for d in vd]
        e["per_frame"]["vertex_distance_p95_m"] = [float(np.percentile(d, 95)) for d in vd]
        e["per_frame"]["vertex_distance_max_m"] = [float(d.max()) for d in vd]
    else:
        e["vertex_distance_note"] = "sample: vertex counts differ"
    return e


def main():
    p = argparse.ArgumentParser()
    p.add_argument("file")
    p.add_argument("other", nargs="?")
    p.add_argument("--json", action="store_true")
    p.add_argument("--csv")
    p.add_argument("--seams")
    a = p.parse_args()
    first = list(levels(a.file))
    if not first:
        sys.exit(f"{a.file}: no level holds a frame")
    ref = max(first, key=lambda s: s["level"])
    series = [ref] + [s for s in first if s is not ref] + (list(levels(a.other)) if a.other else [])
    out = {"reference": {"file": a.file, "level": ref["level"], "vertices": int(ref["x"].shape[1])},
           "levels": [entry(s, ref) for s in series], "seam_jitter": None}
    if a.seams and a.other:
        starts = [int(t) for t in a.seams.split(",")]
        seams = sorted({u for t in starts for u in (t, t + 1)})
        out["seam_jitter"] = []
        for s in levels(a.other):
            base = next((b for b in first if b["level"] == s["level"]), None)
            if base is None or base["x"].shape != s["x"].shape:
                continue
            # d(t): mean over vertices of |a(t) - a_1(t)|, a the second difference of positions.
            acc = lambda x, t: x[t + 1] - 2 * x[t] + x[t - 1]
            n = s["x"].shape[0]
            d = {t: float(np.linalg.norm(acc(s["x"], t) - acc(base["x"], t), axis=1).mean()) for t in range(1, n - 1)}
            other = [v for t, v in d.items() if t not in seams]
            med = float(np.median(other)) if other else None
            seam_d = [d.get(t) for t in seams]
            top = max((v for v in seam_d if v is not None), default=None)
            ratio = top / med if med and top is not None else None
            e = {"level": s["level"], "seams": seams, "seam_d_m": seam_d, "max_seam_d_m": top,
                 "median_other_d_m": med, "ratio": ratio, "units": "m per frame^2 (no division by h^2)"}
            if ratio is None:
                e["ratio_note"] = "sample: undefined"
            out["seam_jitter"].append(e)
    json.dump(out, sys.stdout, indent=1, allow_nan=False)


if __name__ == "__main__":
    main()
