#!/usr/bin/python3
"""Where the frames of a farm job's refinement levels change hands, from its task store.

    bench/farm_seams.py FARM_DIR/farm.sqlite [--job ID]

Prints one comma-separated line, sorted: every frame s where a later time subset of a refinement
level starts (moved seams and their bridges included: the store has the tasks as they ran) and the
last frame of every seam's stitch task (its junction, where the later subset takes over). These are
the frames `pd compare K1.h5 KK.h5 --seams LIST` should measure. Empty for a job without seams.
Used by bench/farm_shots.sh and bench/report/make_report.sh.
"""
import argparse
import sqlite3
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("store", help="the farm's farm.sqlite")
    parser.add_argument("--job", type=int, default=None, help="job id (default: the store's only or last job)")
    args = parser.parse_args()
    try:
        db = sqlite3.connect(f"file:{args.store}?mode=ro", uri=True)
        job = args.job if args.job is not None else db.execute("SELECT MAX(id) FROM jobs").fetchone()[0]
        starts = {r[0] for r in db.execute(
            "SELECT first FROM tasks WHERE job_id = ? AND kind = 'level' AND level >= 1 AND first > 0 AND stitch = 0",
            (job,))}
        junctions = {r[0] for r in db.execute("SELECT last FROM tasks WHERE job_id = ? AND stitch = 1", (job,))}
    except sqlite3.Error as e:
        sys.exit(f"farm_seams.py: {args.store}: {e}")
    print(",".join(str(f) for f in sorted(starts | junctions)))


if __name__ == "__main__":
    main()
