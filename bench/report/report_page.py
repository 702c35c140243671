"""The report's page (README.md): its tables and its reading, every sentence of which is made from
the measured numbers (nothing here is a hand-written claim about the results)."""
import datetime
import math
import os
import platform
import statistics
import subprocess

import report_data as rd

# A run "matches the reference" when its mean centre-of-mass deviation is below this (m): 1 cm,
# about a tenth of the smallest cloth size of scenes/ and the scale at which PD fig. 19's curves part.
MATCH_M = 0.01


def mm(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{x * 1e3:.3g}"


def num(x: float, digits: int = 3) -> str:
    """digits significant digits, without an exponent below 10^6 (a ratio of 230 reads 230, not 2.3e+02)."""
    if x is None or not math.isfinite(x):
        return "–"
    if 10 ** digits <= abs(x) < 1e6:
        return f"{x:.0f}"
    text = f"{x:.{digits}g}"
    if "e+" in text and abs(x) < 1e6:
        text = f"{round(x, -int(math.floor(math.log10(abs(x)))) + digits - 1):.0f}"
    return text


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{os.cpu_count()} CPUs ({cpu}), {platform.system()} {platform.release()}, load average {load} at the end"


def commit(repo: str) -> str:
    try:
        return subprocess.run(["git", "-C", repo, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              timeout=10).stdout.strip() or "unknown"
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"


def run_row(r: rd.Run) -> str:
    """One row of the runs table: the run's finest stored level against the reference."""
    top = max(r.levels) if r.levels else None
    d = r.levels.get(top) if top is not None else None
    entry = r.compared_level(top) if top is not None else None
    cost = r.wall_s / r.simulated_seconds if math.isfinite(r.simulated_seconds) and r.simulated_seconds > 0 else math.nan
    solve = sum(x.solve_seconds for x in r.levels.values()) if r.levels else math.nan
    levels = ",".join(str(l) for l in sorted(r.levels)) or "–"
    return (f"| `{r.id}` | {r.kind} | {r.subsets or '–'} | {levels} | {d.vertices if d else '–'} | {r.frames} | "
            f"{r.wall_s:.2f} | {num(cost)} | {num(solve)} | {num(d.newton_per_step if d else math.nan, 3)} | "
            f"{mm(rd.stat_of(entry, 'com_deviation_m', 'mean'))} / {mm(rd.stat_of(entry, 'com_deviation_m', 'max'))} | "
            f"{mm(rd.stat_of(entry, 'hausdorff_m', 'mean'))} | {mm(rd.stat_of(entry, 'vertex_distance_m', 'p95'))} | "
            f"{r.status} |")


RUNS_HEADER = ("| run | kind | K | levels stored | vertices (finest stored) | frames | wall s | wall s per simulated s | "
               "solve s (all levels) | Newton its/step | COM deviation mean / max (mm) | Hausdorff mean (mm) | "
               "vertex distance p95 (mm) | status |\n"
               "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")


def level_rows(scene: str, points) -> list:
    rows = []
    for p in points:
        e = p.entry
        rows.append(f"| {scene} | {p.label} | {p.vertices} | {num(p.solve_s)} | {num(p.cost)} | "
                    f"{mm(rd.stat_of(e, 'com_deviation_m', 'mean'))} / {mm(rd.stat_of(e, 'com_deviation_m', 'max'))} | "
                    f"{mm(rd.stat_of(e, 'hausdorff_m', 'mean'))} / {mm(rd.stat_of(e, 'hausdorff_m', 'max'))} | "
                    f"{mm(rd.stat_of(e, 'vertex_distance_m', 'mean'))} / {mm(rd.stat_of(e, 'vertex_distance_m', 'p95'))} | "
                    f"{num(rd.stat_of(e, 'kinetic_energy_J', 'last'))} |")
    return rows


def scene_reading(scene: str, points) -> list:
    """Sentences about one scene, from its scatter points; [] when it has no preview."""
    get = {p.label: p for p in points}
    pv, ref = get.get("preview"), get.get("reference")
    directs = sorted((p for p in points if p.marker_kind == "direct"), key=lambda p: p.level)
    if not pv:
        return []
    out = []
    finest = directs[-1] if directs else None
    s = f"**{scene}**: the preview (level 0, {pv.vertices} vertices) costs {num(pv.cost)} s per simulated second"
    if finest and finest.cost > 0:
        ratio = finest.cost / pv.cost
        s += (f", {num(ratio)}x less than direct simulation of the finest mesh ({finest.vertices} vertices, "
              f"{num(finest.cost)} s/s)" if ratio >= 1 else
              f", {num(1 / ratio)}x more than direct simulation of the finest mesh ({num(finest.cost)} s/s)")
    if directs and directs[0].level == 0 and directs[0].cost > 0:
        s += f" and {num(pv.cost / directs[0].cost)}x the cost of direct simulation of its own mesh"
    out.append(s + ".")
    dev_pv = rd.stat_of(pv.entry, "com_deviation_m", "mean")
    dev_d0 = rd.stat_of(directs[0].entry, "com_deviation_m", "mean") if directs and directs[0].level == 0 else math.nan
    if math.isfinite(dev_pv):
        s = (f"Its centre of mass stays on average {mm(dev_pv)} mm from the reference's "
             f"(at most {mm(rd.stat_of(pv.entry, 'com_deviation_m', 'max'))} mm)")
        if math.isfinite(dev_d0):
            s += f"; direct simulation of the same mesh: {mm(dev_d0)} mm on average"
            if dev_pv > 0:
                s += f", {num(dev_d0 / dev_pv)}x further"
        out.append(s + ".")
        matching = sorted((p for p in points if p.marker_kind != "reference"
                           and rd.stat_of(p.entry, "com_deviation_m", "mean") < MATCH_M), key=lambda p: p.cost)
        if matching:
            m = matching[0]
            out.append(f"The cheapest run within {mm(MATCH_M)} mm (mean) of the reference is {m.label} "
                       f"({m.vertices} vertices, {num(m.cost)} s/s"
                       + (f", {num(ref.cost / m.cost)}x cheaper than the reference" if ref and m.cost > 0 else "")
                       + ").")
        else:
            out.append(f"No run comes within {mm(MATCH_M)} mm (mean) of the reference.")
    else:
        out.append("Its errors are not known: pd compare --json gave no output for this scene.")
    return out


def overall_reading(per_scene) -> list:
    """Sentences over every scene: ranges of the preview's speed-up and consistency."""
    speedups, contrasts, good, bad = [], [], [], []
    for scene, points in per_scene.items():
        get = {p.label: p for p in points}
        pv, d = get.get("preview"), sorted((p for p in points if p.marker_kind == "direct"), key=lambda p: p.level)
        if not pv or not d:
            continue
        if pv.cost > 0:
            speedups.append((d[-1].cost / pv.cost, scene))
        dev_pv = rd.stat_of(pv.entry, "com_deviation_m", "mean")
        dev_d0 = rd.stat_of(d[0].entry, "com_deviation_m", "mean") if d[0].level == 0 else math.nan
        if math.isfinite(dev_pv) and math.isfinite(dev_d0) and dev_pv > 0:
            contrasts.append((dev_d0 / dev_pv, scene))
        if math.isfinite(dev_pv):
            (good if dev_pv < MATCH_M else bad).append(scene)
    out = []
    if len(speedups) > 1:
        lo, hi = min(speedups), max(speedups)
        out.append(f"Over {len(speedups)} scenes the preview costs {num(lo[0])}x ({lo[1]}) to {num(hi[0])}x "
                   f"({hi[1]}) less than direct finest simulation (median {num(statistics.median(x for x, _ in speedups))}x; "
                   "below 1x means it costs more).")
    if len(contrasts) > 1:
        lo, hi = min(contrasts), max(contrasts)
        out.append(f"Direct simulation of the preview's mesh ends up {num(lo[0])}x ({lo[1]}) to {num(hi[0])}x "
                   f"({hi[1]}) further from the reference, on mean centre-of-mass deviation, than the preview does.")
    if good or bad:
        out.append(f"The preview is within {mm(MATCH_M)} mm of the reference on {len(good)} of {len(good) + len(bad)} "
                   f"scenes" + (f"; not on {', '.join(bad)}: there, the table below shows the first level that is, "
                                "and a finer preview (fewer hierarchy levels or a smaller ratio, docs/scene-format.md "
                                "\"hierarchy\") is the choice when that level's cost is acceptable." if bad else "."))
    return out


def farm_reading(series, runs) -> list:
    out = []
    for scene, rows in series.items():
        failed = [r.subsets for r in runs if r.scene == scene and r.kind == "farm" and r.status == "failed"]
        base = next((r.wall_s for r in rows if r.k == 1), None)
        best = min(rows, key=lambda r: r.wall_s)
        walls = ", ".join(f"K = {r.k}: {r.wall_s:.1f} s" for r in rows)
        s = f"**{scene}** on the farm (2 workers; {walls}"
        s += f"; failed: K = {', '.join(map(str, failed))}): " if failed else "): "
        if best.k == 1 or not base:
            s += f"the shortest wall time is at K = {best.k}; more time subsets did not pay here"
        else:
            s += f"the shortest wall time is at K = {best.k}, {num(base / best.wall_s)}x faster than K = 1"
        popped = [r for r in rows if r.measured]
        if popped:
            s += "; visible seams (of seams and stitch junctions measured): " + ", ".join(
                f"K = {r.k}: {r.visible} of {r.measured}" for r in popped)
        seams = [r for r in rows if math.isfinite(r.max_seam_d)]
        if seams:
            worst = max(seams, key=lambda r: r.max_seam_d)
            s += (f"; the largest seam jitter is at K = {worst.k}: an acceleration difference to the K = 1 run of "
                  f"{num(worst.max_seam_d)} m/frame² at a seam frame")
            s += (f", {num(worst.ratio)}x its median at the other frames" if math.isfinite(worst.ratio) else
                  f" (ratio to the other frames: {worst.note or 'undefined'})")
        out.append(s + ".")
    return out


def commands(works) -> list:
    """The make_report.sh command lines that made the work folders (their command.txt)."""
    out = []
    for w in works:
        try:
            with open(os.path.join(w, "command.txt")) as f:
                out.append(f.read().strip())
        except OSError:
            out.append(f"(unknown: {w} has no command.txt)")
    return out


def write_page(out_dir, works, runs, images, farm_png, farm_series) -> str:
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    scenes = rd.by_scene(runs)
    per_scene = {s: rd.scatter_points(r) for s, r in scenes.items() if s in images}
    lines = ["# Speed against error: progressive and direct simulation", "",
             f"Generated by `bench/report/make_report.sh` on {datetime.datetime.now():%Y-%m-%d %H:%M}, commit "
             f"{commit(repo)}, {machine()}. Do not edit: run the command again (docs/performance.md):", ""]
    lines += ["```"] + commands(works) + ["```", "",
             "Every pd call ran alone, one after another; pd limits itself to one thread (OMP_THREAD_LIMIT=1, "
             "util/process_setup.h), so costs are those of one core; other programs on the machine were not stopped (see "
             "the load average above), so compare costs within one report. The reference of a scene is direct simulation "
             "of its finest mesh with solver.tolerance 100x smaller. Cost = seconds of Newton solves (the frame "
             "files' solve_seconds) per simulated second; a progressive level's cost includes the coarser levels it "
             "needs. Errors are pd compare's, against the reference; a farm run's (pd run --workers 2 --subsets K) "
             "against the same scene's K = 1 farm run.", ""]
    # Runs that should have a compare JSON: all but the reference and the farm's K = 1 (the others' base).
    missing = [r.id for r in runs if r.kind != "reference" and not (r.kind == "farm" and r.subsets == 1)
               and r.status != "failed" and not r.compare]
    failed = [r.id for r in runs if r.status == "failed"]
    if failed:
        lines += [f"**Failed runs** (left out): {', '.join(f'`{i}`' for i in failed)}.", ""]
    if missing:
        lines += [f"**No pd compare --json output** for {len(missing)} runs (their error columns read –).", ""]
    lines += ["## How to read this, and choosing a preview resolution", ""]
    lines += ["- " + s for s in overall_reading(per_scene)]
    for scene, points in per_scene.items():
        sentences = scene_reading(scene, points)
        if sentences:
            lines.append("- " + " ".join(sentences))
    lines += ["- " + s for s in farm_reading(farm_series, runs)]
    lines += ["", "In the plots, solid lines are progressive levels, dashed ones direct runs, the dotted black one the "
              "reference; in the scatter plots a star is the preview, circles the progressive levels, squares the "
              "direct runs and the dotted line the reference's cost.", "", "## Runs", "", RUNS_HEADER]
    lines += [run_row(r) for r in runs]
    lines += ["", "## Levels: cost against error", "",
              "| scene | run | vertices | solve s | cost (s per simulated s) | COM deviation mean / max (mm) | "
              "Hausdorff mean / max (mm) | vertex distance mean / p95 (mm) | last KE (J) |",
              "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for scene, points in per_scene.items():
        lines += level_rows(scene, points)
    if farm_png:
        lines += ["", "## Farm: wall time, seam pops and seam jitter against K", "", f"![farm](./{farm_png})", "",
                  "Seams are stitched (pd's default, 16 frames). Pops (pd compare --seams) are measured at every "
                  "seam and every stitch's junction of every level; a seam is visible when its pop is above 0.5 and "
                  "above 1.5x the K = 1 run's at the same frame. The seam d figures are those of the level with the "
                  "largest seam d (its ratio is the ratio of the two d columns).", "",
                  "| scene | K | wall s | visible / measured | largest pop (K = 1), where | level | max seam d (m/frame²) "
                  "| median other d (m/frame²) | ratio |",
                  "| --- | ---: | ---: | ---: | --- | ---: | ---: | ---: | --- |"]
        for scene, rows in farm_series.items():
            lines += [f"| {scene} | {r.k} | {r.wall_s:.2f} | {f'{r.visible} / {r.measured}' if r.measured else '–'} | "
                      f"{f'{num(r.max_pop)} ({num(r.max_pop_base)}), {r.max_pop_where}' if r.max_pop_where else '–'} | "
                      f"{r.level if r.level >= 0 else '–'} | {num(r.max_seam_d)} | "
                      f"{num(r.median_other)} | {num(r.ratio) if math.isfinite(r.ratio) else (r.note or '–')} |"
                      for r in rows]
    plans = [p for w in works for p in rd.plan_rows(w)]
    if plans:
        workers = sorted({w for p in plans for w in p.makespan})
        lines += ["", "## Benchmark shots: predicted wall time on many workers", "",
                  "pd plan replays each shot's whole task graph (seams stitched, 16 frames) from the step costs of "
                  "its first frames run progressively (bench/scenes; one core each). Speed-up against the shot at "
                  "K = 1 on one worker.", "",
                  "| shot | frames | K | " + " | ".join(f"{w} worker{'s' if w > 1 else ''}" for w in workers) + " |",
                  "| --- | ---: | ---: | " + " | ".join("---:" for _ in workers) + " |"]
        base = {p.shot: p.makespan.get(1, math.nan) for p in plans if p.k == 1}
        for p in plans:
            cells = []
            for w in workers:
                t, b = p.makespan.get(w, math.nan), base.get(p.shot, math.nan)
                cells.append(f"{t:.0f} s ({b / t:.1f}x)" if math.isfinite(t) and math.isfinite(b) and t > 0 else "–")
            lines.append(f"| {p.shot} | {p.frames} | {p.k} | " + " | ".join(cells) + " |")
    for scene, pngs in images.items():
        lines += ["", f"## {scene}", ""] + [f"![{p[:-4]}](./{p})" for p in pngs]
    path = os.path.join(out_dir, "README.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path
