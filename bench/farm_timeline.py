#!/usr/bin/python3
"""Per-worker timeline of one farm job, from the scheduler's log (and the job file's solve times).

Where did a job's wall time go? For each worker: the time it solved (the frames' own solve_seconds),
the time it held a task without solving (a refinement subset waiting for frames of the level below,
a vertical start, task start-up, sending frames) and the time it had no task at all.

    bench/farm_timeline.py SCHEDULER_LOG JOB_FILE.h5 [--job ID] [--png OUT.png] [--json]

SCHEDULER_LOG: pd-scheduler's stderr (one JSON event per line; `pd run --keep-farm DIR` keeps it as
DIR/scheduler.log). JOB_FILE.h5: the job's frame file (`pd fetch` or `pd run --out`), for each
frame's solve_seconds. Times are seconds from the job's `job_submitted` event.

An attempt runs from its `task_assigned` event to the event that ends it (task_done, task_released,
attempt_failed, task_continues_horizontally, task_preempted, worker_lost, or a later assignment to
the same worker). Its solve time is the sum of solve_seconds of the frames it stored (frame_stored
events of that task and worker in the interval, and guide_stored events, which carry their own solve
time: a later subset's first frames when seams are stitched); held = duration - solve.
"""
import argparse
import json
import math
import re
import sys

ENDS = {"task_done", "hierarchy_stored", "task_released", "attempt_failed", "task_continues_horizontally", "task_preempted"}
ASSIGNED = re.compile(r"attempt (?P<attempt>\d+): (?P<kind>hierarchy|level (?P<level>\d+)(?P<stitch> stitch)?) "
                      r"frames \((?P<first>\d+), (?P<last>\d+)\] to (?P<name>.*?)(?P<continuing>, continuing from frame (\d+))?$")
FRAME = re.compile(r"level (\d+) frame (\d+)$")
GUIDE = re.compile(r"level (\d+) guide frame (\d+), solve (\S+) s$")  # a later subset's first frames (seam stitches)


def read_events(path):
    events = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line.startswith("{"):
                continue
            try:
                events.append(json.loads(line))
            except json.JSONDecodeError as e:
                sys.exit(f"farm_timeline: {path}:{number}: not a JSON event: {e}")
    return events


def solve_seconds(h5_path):
    import h5py
    import numpy as np
    out = {}
    with h5py.File(h5_path, "r") as f:
        for name in f["levels"]:
            stats = f["levels"][name]["stats"]
            if "solve_seconds" not in stats:
                continue
            values = np.asarray(stats["solve_seconds"])
            for t, s in enumerate(values):
                if math.isfinite(s):
                    out[(int(name), t)] = float(s)
    return out


def pick_job(events, job):
    submitted = [e for e in events if e.get("event") == "job_submitted"]
    if job is None:
        if len(submitted) != 1:
            sys.exit(f"farm_timeline: the log has {len(submitted)} submitted jobs; name one with --job")
        job = submitted[0]["job"]
    start = next((e["time"] for e in submitted if e["job"] == job), None)
    if start is None:
        sys.exit(f"farm_timeline: no job_submitted event for job {job}")
    end = next((e["time"] for e in events if e.get("event") == "job_done" and e.get("job") == job), None)
    return job, start, end


def attempts_of(events, job, t0, solve):
    """The job's attempts in log order, each a dict with its worker, task, level, range, times and work."""
    running = {}  # worker -> attempt dict
    done = []

    def close(worker, time, how):
        a = running.pop(worker, None)
        if a is not None:
            a["end"], a["outcome"] = time - t0, how
            done.append(a)

    for e in events:
        kind, worker = e.get("event"), e.get("worker")
        if kind == "worker_lost" and worker in running:
            close(worker, e["time"], "lost")
        if e.get("job") != job:
            continue
        if kind == "task_assigned":
            m = ASSIGNED.match(e.get("message", ""))
            if not m:
                continue
            close(worker, e["time"], "reassigned")
            running[worker] = {"worker": worker, "name": m.group("name"), "task": e["task"],
                               "continuing": m.group("continuing") is not None, "stitch": m.group("stitch") is not None,
                               "level": -1 if m.group("kind") == "hierarchy" else int(m.group("level")),
                               "first": int(m.group("first")), "last": int(m.group("last")), "start": e["time"] - t0,
                               "frames": [], "solve": 0.0}
        elif kind == "frame_stored" and worker in running and running[worker]["task"] == e.get("task"):
            m = FRAME.match(e.get("message", ""))
            if m:
                key = (int(m.group(1)), int(m.group(2)))
                running[worker]["frames"].append((e["time"] - t0, key[1], solve.get(key, 0.0)))
                running[worker]["solve"] += solve.get(key, 0.0)
        elif kind == "guide_stored" and worker in running and running[worker]["task"] == e.get("task"):
            m = GUIDE.match(e.get("message", ""))
            if m:
                running[worker]["frames"].append((e["time"] - t0, int(m.group(2)), float(m.group(3))))
                running[worker]["solve"] += float(m.group(3))
        elif kind in ENDS and worker in running and running[worker]["task"] == e.get("task"):
            close(worker, e["time"], kind)
    for worker in list(running):
        close(worker, max(e["time"] for e in events), "open")
    return done


def summarise(attempts, wall):
    workers = {}
    for a in attempts:
        w = workers.setdefault(a["worker"], {"worker": a["worker"], "name": a["name"], "attempts": 0,
                                             "solve_s": 0.0, "held_s": 0.0})
        w["attempts"] += 1
        w["solve_s"] += a["solve"]
        w["held_s"] += max(0.0, a["end"] - a["start"] - a["solve"])
    for w in workers.values():
        w["idle_s"] = max(0.0, wall - w["solve_s"] - w["held_s"])
    return [workers[k] for k in sorted(workers)]


def levels_of(attempts):
    """Per level: when its first task was assigned and its last frame stored (s from submission), and
    its median step (solve_seconds)."""
    out = {}
    for a in attempts:
        if a["level"] < 0:
            continue
        lv = out.setdefault(a["level"], {"level": a["level"], "first_assigned_s": a["start"], "last_frame_s": 0.0,
                                         "steps": []})
        lv["first_assigned_s"] = min(lv["first_assigned_s"], a["start"])
        for stored, _, s in a["frames"]:
            lv["last_frame_s"] = max(lv["last_frame_s"], stored)
            if s > 0:
                lv["steps"].append(s)
    for lv in out.values():
        steps = sorted(lv.pop("steps"))
        lv["median_step_s"] = steps[len(steps) // 2] if steps else float("nan")
    return [out[k] for k in sorted(out)]


def vertical_starts(attempts, levels):
    """Each vertical start: a level >= 1 attempt from a frame > 0 that did not continue from stored
    frames (a seam's stitch task continues horizontally: not one). Its cost is the time from assignment to its first stored frame less that frame's solve
    (upsampling, set-up, and the wait for frames of the level below), also in the level's median steps."""
    median = {lv["level"]: lv["median_step_s"] for lv in levels}
    out = []
    for a in attempts:
        if a["level"] < 1 or a["first"] == 0 or a["continuing"] or a["stitch"] or not a["frames"]:
            continue
        stored, frame, s = a["frames"][0]
        if frame != a["first"] + 1:
            continue
        cost = stored - a["start"] - s
        m = median.get(a["level"], float("nan"))
        out.append({"level": a["level"], "frame": a["first"], "seconds": cost,
                    "steps": cost / m if m and m > 0 else float("nan")})
    return out


def plot(attempts, wall, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    workers = sorted({a["worker"] for a in attempts})
    row = {w: i for i, w in enumerate(workers)}
    colours = plt.get_cmap("tab10")
    fig, ax = plt.subplots(figsize=(11, 1.2 + 0.6 * len(workers)))
    for a in attempts:
        y, c = row[a["worker"]], colours((a["level"] + 1) % 10)
        ax.barh(y, a["end"] - a["start"], left=a["start"], height=0.7, color=c, alpha=0.25, edgecolor=c)
        for stored, _, s in a["frames"]:  # each frame's solve, ending when it was stored
            ax.barh(y, s, left=stored - s, height=0.5, color=c, linewidth=0)
    for level in sorted({a["level"] for a in attempts}):
        ax.barh(0, 0, color=colours((level + 1) % 10), label="hierarchy" if level < 0 else f"level {level}")
    ax.set_yticks(range(len(workers)), [f"worker {w}" for w in workers])
    ax.set_xlabel("seconds from submission (pale: task held; solid: frames solved)")
    ax.set_xlim(0, wall)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("log")
    p.add_argument("h5")
    p.add_argument("--job", type=int)
    p.add_argument("--png")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    events = read_events(args.log)
    job, t0, t_end = pick_job(events, args.job)
    attempts = attempts_of(events, job, t0, solve_seconds(args.h5))
    wall = (t_end if t_end is not None else max(e["time"] for e in events)) - t0
    workers = summarise(attempts, wall)
    levels = levels_of(attempts)
    starts = vertical_starts(attempts, levels)
    if args.png:
        plot(attempts, wall, args.png)
    if args.json:
        print(json.dumps({"job": job, "wall_s": wall, "workers": workers, "levels": levels, "vertical_starts": starts,
                          "attempts": [{k: v for k, v in a.items() if k != "frames"} for a in attempts]}))
        return
    print(f"job {job}: wall {wall:.1f} s" + ("" if t_end is not None else " (not done)"))
    print(f"{'worker':>8} {'attempts':>8} {'solve s':>9} {'held s':>9} {'idle s':>9}")
    for w in workers:
        print(f"{w['name']:>8} {w['attempts']:>8} {w['solve_s']:>9.1f} {w['held_s']:>9.1f} {w['idle_s']:>9.1f}")
    print(f"{'level':>8} {'first task':>11} {'last frame':>11} {'median step':>12}")
    for lv in levels:
        print(f"{lv['level']:>8} {lv['first_assigned_s']:>11.2f} {lv['last_frame_s']:>11.2f} {lv['median_step_s']:>12.4f}")
    for v in starts:
        print(f"vertical start: level {v['level']} frame {v['frame']}: {v['seconds']:.3f} s, {v['steps']:.1f} steps")
    print(f"{'worker':>8} {'task':>5} {'level':>5} {'frames':>13} {'start':>8} {'end':>8} {'solve':>8} {'held':>8}  outcome")
    for a in attempts:
        span = "hierarchy" if a["level"] < 0 else f"({a['first']}, {a['last']}]"
        print(f"{a['name']:>8} {a['task']:>5} {a['level']:>5} {span:>13} {a['start']:>8.2f} {a['end']:>8.2f} "
              f"{a['solve']:>8.2f} {a['end'] - a['start'] - a['solve']:>8.2f}  {a['outcome']}")


if __name__ == "__main__":
    main()
