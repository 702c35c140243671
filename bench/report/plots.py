#!/usr/bin/python3
"""The speed-against-error report's plots and page, from make_report.sh's work folder.

    /usr/bin/python3 bench/report/plots.py --work WORK [--work WORK2 ...] --out DIR

Writes into DIR, per scene S: ke_S.png (kinetic energy of every level against time, PD fig. 18),
com_S.png (centre-of-mass height of every level and its deviation from the reference, PD fig. 19),
cost_S.png (cost against each error measure, one marker per run kind); and farm_K.png (wall time
and seam jitter against the number of time subsets K); then DIR/README.md (report_page.py).
Debian's python3-matplotlib and python3-h5py (run with /usr/bin/python3, not a pyenv python).
"""
import argparse
import math
import os
import sys

import matplotlib
matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import report_data as rd  # noqa: E402
import report_page  # noqa: E402

# One colour per level, shared by every plot of a scene (level 0 = the preview).
LEVEL_COLOURS = ["tab:orange", "tab:green", "tab:blue", "tab:purple", "tab:brown", "tab:pink"]
MARKERS = {"preview": "*", "progressive": "o", "direct": "s", "reference": "D"}
ERROR_MEASURES = [  # (compare JSON key, statistic, axis label)
    ("com_deviation_m", "mean", "centre-of-mass deviation, mean (m)"),
    ("hausdorff_m", "mean", "Hausdorff distance, mean (m)"),
    ("vertex_distance_m", "p95", "vertex distance, p95 (m)"),
]


def colour(level: int) -> str:
    return LEVEL_COLOURS[level % len(LEVEL_COLOURS)]


def moving_object(runs) -> int:
    """The first object whose centre of mass moves in the reference (obstacles without motion do
    not), so that the centre-of-mass plot shows the cloth, not the fixed sphere."""
    ref = rd.find(runs, "reference") or next((r for r in runs if r.ok), None)
    if not ref or not ref.ok:
        return 0
    com = ref.levels[max(ref.levels)].com
    for k in range(com.shape[1]):
        if np.nanmax(np.ptp(com[:, k, :], axis=0)) > 1e-9:
            return k
    return 0


def level_curves(runs):
    """(label, style, level, LevelData) of the progressive levels, the direct runs, the reference."""
    curves = []
    prog = rd.find(runs, "progressive")
    if prog and prog.ok:
        curves += [(f"progressive {l}", "-", l, d) for l, d in sorted(prog.levels.items())]
    for r in runs:
        if r.kind == "direct" and r.ok:
            l = int(r.level)
            curves.append((f"direct {l}", "--", l, r.levels[l]))
    ref = rd.find(runs, "reference")
    if ref and ref.ok:
        l = max(ref.levels)
        curves.append(("reference (direct finest, tolerance / 100)", ":", -1, ref.levels[l]))
    return curves


def plot_ke(scene, runs, out_dir):
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, style, level, d in level_curves(runs):
        ax.plot(d.time_s, d.kinetic_energy, style, color="black" if level < 0 else colour(level), label=label, lw=1.2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("kinetic energy (J)")
    ax.set_title(f"{scene}: kinetic energy per level")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return save(fig, out_dir, f"ke_{scene}.png")


def deviation_series(run, level):
    """(time s, COM deviation m) of one level of a run from its compare JSON's per_frame arrays."""
    entry = run.compared_level(level) if run else None
    if not entry or not entry.get("per_frame"):
        return None
    pf = entry["per_frame"]
    h = entry.get("time_step_s") or run.time_step
    t = np.array(pf.get("frame", []), dtype=float) * h
    dev = np.array([np.nan if v is None else v for v in pf.get("com_deviation_m", [])], dtype=float)
    return (t, dev) if t.size and t.size == dev.size else None


def plot_com(scene, runs, out_dir):
    k = moving_object(runs)
    names = next((d.object_names for _, _, _, d in level_curves(runs) if len(d.object_names) > k), [])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    for label, style, level, d in level_curves(runs):
        top.plot(d.time_s, d.com[:, k, 1], style, color="black" if level < 0 else colour(level), label=label, lw=1.2)
    top.set_ylabel(f"centre of mass y of {names[k] if names else f'object {k}'} (m)")
    top.set_title(f"{scene}: centre of mass per level")
    top.legend(fontsize=7)
    top.grid(alpha=0.3)
    drawn = False
    prog = rd.find(runs, "progressive")
    for r in [prog] + [r for r in runs if r.kind == "direct"]:
        if not r or not r.ok:
            continue
        for level in sorted(r.levels):
            series = deviation_series(r, level)
            if series:
                bottom.plot(*series, "-" if r.kind == "progressive" else "--", color=colour(level),
                            label=f"{r.kind} {level}", lw=1.2)
                drawn = True
    bottom.set_xlabel("time (s)")
    bottom.set_ylabel("deviation from reference (m)")
    if drawn:
        bottom.legend(fontsize=7)
    else:
        bottom.text(0.5, 0.5, "no pd compare --json output", ha="center", va="center", transform=bottom.transAxes)
    bottom.grid(alpha=0.3)
    return save(fig, out_dir, f"com_{scene}.png")


def plot_cost(scene, runs, out_dir):
    points = rd.scatter_points(runs)
    fig, axes = plt.subplots(1, len(ERROR_MEASURES), figsize=(4.2 * len(ERROR_MEASURES), 4))
    ref = next((p for p in points if p.marker_kind == "reference"), None)
    for ax, (measure, key, ylabel) in zip(axes, ERROR_MEASURES):
        drawn = 0
        for p in points:
            if p.marker_kind == "reference":
                continue
            y = rd.stat_of(p.entry, measure, key)
            if not (math.isfinite(y) and y > 0 and p.cost > 0):
                continue
            ax.scatter([p.cost], [y], marker=MARKERS[p.marker_kind], s=90 if p.marker_kind == "preview" else 45,
                       color=colour(p.level), edgecolors="black", linewidths=0.5, zorder=3)
            ax.annotate(f"{p.label} ({p.vertices} v)", (p.cost, y), fontsize=6, xytext=(4, 3),
                        textcoords="offset points")
            drawn += 1
        if ref and ref.cost > 0:
            ax.axvline(ref.cost, color="black", ls=":", lw=1)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # a narrow range labels every minor tick
        if drawn:
            ax.set_yscale("log")
        else:
            ax.text(0.5, 0.5, "no values (pd compare --json\nmissing, or null here)", ha="center", va="center",
                    transform=ax.transAxes, fontsize=8)
        ax.set_xlabel("cost (solve s per simulated s, one core)")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3, which="both")
    # A legend of the run kinds (markers), whatever the level colours.
    handles = [plt.Line2D([], [], marker=m, ls="", color="grey", markeredgecolor="black", label=k)
               for k, m in MARKERS.items() if k != "reference"]
    handles.append(plt.Line2D([], [], ls=":", color="black", label="reference cost"))
    axes[0].legend(handles=handles, fontsize=7)
    fig.suptitle(f"{scene}: cost against error (reference: direct finest, tolerance / 100)")
    return save(fig, out_dir, f"cost_{scene}.png")


def plot_farm(runs, out_dir):
    series = rd.farm_series(runs)
    if not series:
        return None
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    any_seam = False
    for i, (scene, rows) in enumerate(series.items()):
        c = LEVEL_COLOURS[i % len(LEVEL_COLOURS)]
        left.plot([r.k for r in rows], [r.wall_s for r in rows], "o-", color=c, label=scene)
        seam = [r for r in rows if math.isfinite(r.max_seam_d) and r.max_seam_d > 0]
        if seam:
            right.plot([r.k for r in seam], [r.max_seam_d for r in seam], "s-", color=c, label=f"{scene}: at seams")
            other = [r for r in seam if math.isfinite(r.median_other) and r.median_other > 0]
            if other:
                right.plot([r.k for r in other], [r.median_other for r in other], "s:", color=c, mfc="none",
                           label=f"{scene}: median elsewhere")
            any_seam = True
    left.set_xlabel("time subsets K per refinement level")
    left.set_ylabel("wall time of pd run --workers 2 (s)")
    left.legend(fontsize=8)
    right.set_xlabel("time subsets K")
    right.set_ylabel("acceleration difference to K = 1 (m/frame²)")
    all_k = sorted({r.k for rows in series.values() for r in rows})
    for ax in (left, right):  # K = 1, 2, 4, 8 as plain numbers
        ax.set_xscale("log", base=2)
        ax.set_xticks(all_k)
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.grid(alpha=0.3)
    if any_seam:
        right.set_yscale("log")  # from round-off to visible kinks
        right.legend(fontsize=7)
    else:
        right.text(0.5, 0.5, "no seam jitter (pd compare --json\n--seams missing, or K = 1 only)", ha="center",
                   va="center", transform=right.transAxes, fontsize=8)
    fig.suptitle("farm: wall time and seam jitter against K (the level with the largest seam d)")
    return save(fig, out_dir, "farm_K.png")


def save(fig, out_dir, name):
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, name), dpi=110)
    plt.close(fig)
    return name


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", required=True, action="append",
                        help="make_report.sh's work folder (runs.tsv, frame files); repeat to join several runs")
    parser.add_argument("--out", required=True, help="folder for the PNGs and README.md")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    runs = [r for work in args.work for r in rd.load_runs(work)]
    images = {}  # scene -> [png names]; "" -> the farm plot
    for scene, scene_runs in rd.by_scene(runs).items():
        if not any(r.ok and r.kind != "farm" for r in scene_runs):
            continue
        images[scene] = [plot_ke(scene, scene_runs, args.out), plot_com(scene, scene_runs, args.out),
                         plot_cost(scene, scene_runs, args.out)]
    farm = plot_farm(runs, args.out)
    page = report_page.write_page(args.out, args.work, runs, images, farm, rd.farm_series(runs))
    print(f"plots.py: wrote {page} and {sum(len(v) for v in images.values()) + (1 if farm else 0)} PNGs")


if __name__ == "__main__":
    main()
