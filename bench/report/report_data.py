"""Loads what make_report.sh left in its work folder: runs.tsv (one row per pd call), the frame
files (HDF5, docs/frame-format.md) and the pd compare --json outputs (compare/<id>.json).

Units: seconds, metres, joules throughout; costs are seconds of computing per simulated second.
"""
import csv
import glob
import json
import math
import os
import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import h5py
import numpy as np


@dataclass
class LevelData:
    """One stored level of one frame file."""
    level: int
    vertices: int
    frames: np.ndarray          # stored frame numbers t (done == 1)
    time_s: np.ndarray          # t * h
    kinetic_energy: np.ndarray  # J, at the stored frames
    com: np.ndarray             # (frames, objects, 3) m, centre of mass of each object
    solve_seconds: float        # sum over the solved frames (t >= 1) of the stats' solve_seconds
    newton_per_step: float      # mean Newton iterations per solved frame
    object_names: List[str]     # scene object names, in the order of com's second axis


@dataclass
class Run:
    """One row of runs.tsv and what it produced."""
    id: str
    scene: str
    kind: str           # reference, progressive, direct, farm
    level: str          # level simulated ("all" for progressive and farm runs)
    subsets: int        # K of a farm run, 0 otherwise
    frames: int         # N
    h5: str
    wall_s: float       # wall time of the pd call
    status: str         # ok, failed, compare-failed
    compare_path: Optional[str]
    time_step: float = math.nan
    levels: Dict[int, LevelData] = field(default_factory=dict)
    compare: Optional[dict] = None

    @property
    def simulated_seconds(self) -> float:
        return self.frames * self.time_step

    @property
    def ok(self) -> bool:
        return self.status != "failed" and bool(self.levels)

    def compared_levels(self) -> List[dict]:
        """The compare JSON's entries for this run's own file (the reference's entry left out)."""
        if not self.compare:
            return []
        entries = self.compare.get("levels", [])
        return [e for e in entries if os.path.abspath(e.get("file", "")) == os.path.abspath(self.h5)] or entries[1:]

    def compared_level(self, level: int) -> Optional[dict]:
        for e in self.compared_levels():
            if e.get("level") == level:
                return e
        return None


def read_levels(path: str):
    """The time step and every level with stored frames of one frame file."""
    out: Dict[int, LevelData] = {}
    with h5py.File(path, "r") as f:
        scene = json.loads(f.attrs["scene"])
        h = float(scene["time_step"])
        for name, group in f["levels"].items():
            done = np.flatnonzero(group["done"][:])
            if done.size == 0:
                continue
            stats = group["stats"]
            level = int(name)

            def stat(key):
                return stats[key][:][done] if key in stats else np.full(done.size, np.nan)

            solved = done >= 1
            solve = stat("solve_seconds")[solved]
            newton = stat("newton_iterations")[solved]
            vertices = int(group["positions"].shape[1])
            names = [str(x) for x in f["hierarchy"][name]["object_names"].asstr()[:]] \
                if "hierarchy" in f and name in f["hierarchy"] else []
            out[level] = LevelData(level, vertices, done, done * h, stat("kinetic_energy"),
                                   stats["center_of_mass"][:][done], float(np.nansum(solve)),
                                   float(np.nanmean(newton)) if np.isfinite(newton).any() else math.nan, names)
    return h, out


def load_runs(work: str) -> List[Run]:
    runs = []
    with open(os.path.join(work, "runs.tsv"), newline="") as f:
        for row in csv.DictReader(f, delimiter="\t"):
            run = Run(row["id"], row["scene"], row["kind"], row["level"], int(row["subsets"]), int(row["frames"]),
                      row["h5"], float(row["wall_s"]), row["status"],
                      None if row["compare_json"] in ("", "-") else row["compare_json"])
            if run.status != "failed" and os.path.exists(run.h5):
                try:
                    run.time_step, run.levels = read_levels(run.h5)
                except (OSError, KeyError, ValueError) as e:
                    print(f"plots.py: {run.h5}: cannot read ({e}); the run is left out")
                    run.status = "failed"
            if run.compare_path and os.path.exists(run.compare_path):
                with open(run.compare_path) as cf:
                    run.compare = json.load(cf)
            runs.append(run)
    return runs


def by_scene(runs: List[Run]) -> Dict[str, List[Run]]:
    scenes: Dict[str, List[Run]] = {}
    for r in runs:
        scenes.setdefault(r.scene, []).append(r)
    return scenes


def find(runs: List[Run], kind: str, level: Optional[str] = None, subsets: Optional[int] = None) -> Optional[Run]:
    for r in runs:
        if r.kind == kind and (level is None or r.level == level) and (subsets is None or r.subsets == subsets):
            return r
    return None


def stat_of(entry: Optional[dict], measure: str, key: str) -> float:
    """entry[measure][key] from a compare JSON level entry; NaN when missing or null."""
    if not entry or not isinstance(entry.get(measure), dict):
        return math.nan
    v = entry[measure].get(key)
    return float(v) if isinstance(v, (int, float)) else math.nan


@dataclass
class Point:
    """One point of a cost-vs-error scatter: a level of a run."""
    run: Run
    label: str        # preview, progressive 1, direct 0, reference ...
    marker_kind: str  # preview, progressive, direct, reference
    level: int
    vertices: int
    solve_s: float    # seconds of solves needed to have this level (progressive: levels 0..l)
    cost: float       # solve_s per simulated second
    entry: Optional[dict]  # the compare JSON entry (None for the reference)


def scatter_points(scene_runs: List[Run]) -> List[Point]:
    """Every level of the progressive run (its cost including the coarser levels it needs), every
    direct run, and the reference."""
    points: List[Point] = []
    ref = find(scene_runs, "reference")
    prog = find(scene_runs, "progressive")
    if prog and prog.ok:
        cumulative = 0.0
        for level in sorted(prog.levels):
            d = prog.levels[level]
            cumulative += d.solve_seconds
            points.append(Point(prog, "preview" if level == 0 else f"progressive {level}",
                                "preview" if level == 0 else "progressive", level, d.vertices, cumulative,
                                cumulative / prog.simulated_seconds, prog.compared_level(level)))
    for r in scene_runs:
        if r.kind == "direct" and r.ok:
            level = int(r.level)
            d = r.levels[level]
            points.append(Point(r, f"direct {level}", "direct", level, d.vertices, d.solve_seconds,
                                d.solve_seconds / r.simulated_seconds, r.compared_level(level)))
    if ref and ref.ok:
        level = max(ref.levels)
        d = ref.levels[level]
        points.append(Point(ref, "reference", "reference", level, d.vertices, d.solve_seconds,
                            d.solve_seconds / ref.simulated_seconds, None))
    return points


@dataclass
class FarmRow:
    """One farm run (pd run --workers 2 --subsets K) and its seam jitter against K = 1, on the level
    with the largest seam d (every figure of the row is that level's, so the ratio is the ratio of
    the two d columns)."""
    k: int
    wall_s: float
    level: int           # the level giving max_seam_d (-1 when no level has seams)
    ratio: float         # that level's max seam d / median other d; NaN when not finite
    max_seam_d: float    # m per frame^2 (second differences, not divided by h^2)
    median_other: float  # that level's median d over the frames after the first seam that are not seams
    note: str            # pd compare's ratio_note of that level, when its ratio is null
    # Seam pops (pd compare --seams: every seam and stitch junction of every refinement level).
    measured: int = 0    # seams and junctions measured, all levels together
    visible: int = 0     # of them visible (pop > 0.5 and > 1.5x the K = 1 run's)
    max_pop: float = math.nan       # the largest pop of a level >= 1
    max_pop_base: float = math.nan  # the K = 1 run's pop at the same level and frame
    max_pop_where: str = ""         # "level l frame s"


def farm_series(runs: List[Run]) -> Dict[str, List[FarmRow]]:
    """Per scene with farm runs, its rows by K."""
    series: Dict[str, List[FarmRow]] = {}
    for scene, scene_runs in by_scene(runs).items():
        rows = []
        for r in sorted((r for r in scene_runs if r.kind == "farm" and r.status != "failed"), key=lambda r: r.subsets):
            entries = [j for j in ((r.compare or {}).get("seam_jitter") or []) if isinstance(j, dict)]
            num = lambda j, key: float(j[key]) if isinstance(j.get(key), (int, float)) else math.nan
            worst = max(entries, key=lambda j: num(j, "max_seam_d_m") if math.isfinite(num(j, "max_seam_d_m"))
                        else -1.0, default=None)
            row = FarmRow(r.subsets, r.wall_s, int(worst.get("level", -1)) if worst else -1,
                          num(worst, "ratio") if worst else math.nan,
                          num(worst, "max_seam_d_m") if worst else math.nan,
                          num(worst, "median_other_d_m") if worst else math.nan,
                          str(worst.get("ratio_note", "")) if worst and worst.get("ratio") is None else "")
            for level in (r.compare or {}).get("seam_pop") or []:
                if not isinstance(level, dict):
                    continue
                for seam in level.get("seams") or []:
                    row.measured += 1
                    row.visible += 1 if seam.get("visible") is True else 0
                    pop = num(seam, "pop")
                    if int(level.get("level", 0)) >= 1 and math.isfinite(pop) and not pop <= row.max_pop:
                        row.max_pop, row.max_pop_base = pop, num(seam, "baseline_pop")
                        row.max_pop_where = f"level {level.get('level')} frame {seam.get('seam')}"
            rows.append(row)
        if rows:
            series[scene] = rows
    return series


@dataclass
class PlanRow:
    """pd plan's prediction for a benchmark shot at K subsets (plans/SHOT-KK.json)."""
    shot: str
    frames: int
    k: int
    stitch: int
    makespan: Dict[int, float]  # workers -> predicted wall seconds


def plan_rows(work: str) -> List[PlanRow]:
    """The plan shots' predictions, by shot then K; unreadable files are skipped."""
    rows = []
    for path in sorted(glob.glob(os.path.join(work, "plans", "*-K*.json"))):
        m = re.match(r"(.+)-K(\d+)\.json$", os.path.basename(path))
        try:
            j = json.load(open(path))
            makespan = {int(p["workers"]): float(p["makespan_seconds"]) for p in j["plans"]}
        except (OSError, ValueError, KeyError, TypeError):
            continue
        rows.append(PlanRow(m.group(1), int(j.get("frames", 0)), int(m.group(2)), int(j.get("stitch", 0)), makespan))
    rows.sort(key=lambda r: (r.shot, r.k))
    return rows

