#!/usr/bin/python3
"""Checks a report page (bench/report/plots.py's README.md) against the runs that made it:
every image it links exists and is a valid, non-empty PNG, and its runs table has exactly one row
per run of runs.tsv, every run ok, all four run kinds present.
    check_page.py PAGE RUNS_TSV        exit 0: all good; 1: problems, each printed as FAIL: ...
"""
import csv
import os
import re
import struct
import sys
import zlib

page, manifest = sys.argv[1], sys.argv[2]
text = open(page).read()
bad = 0
def fail(msg):
    global bad
    print("FAIL:", msg); bad += 1

def png_ok(path):
    """Signature, an IHDR of non-zero size first, every chunk's CRC right, IEND last."""
    data = open(path, "rb").read()
    if len(data) < 8 + 25 + 12 or data[:8] != b"\x89PNG\r\n\x1a\n":
        return "no PNG signature or too short"
    pos, first, last = 8, None, None
    while pos + 12 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        if pos + 12 + length > len(data):
            return f"truncated in chunk {kind!r}"
        body = data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if zlib.crc32(kind + body) != crc:
            return f"bad CRC in chunk {kind!r}"
        if first is None:
            first = (kind, body)
        last = kind
        pos += 12 + length
    if first is None or first[0] != b"IHDR":
        return "first chunk is not IHDR"
    w, h = struct.unpack(">II", first[1][:8])
    if w == 0 or h == 0:
        return f"empty image {w}x{h}"
    return None if last == b"IEND" and pos == len(data) else "does not end with IEND"

links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
if not links:
    fail("the page links no image")
for link in links:
    path = os.path.join(os.path.dirname(page), link)
    if not os.path.isfile(path):
        fail(f"linked image {link} does not exist")
        continue
    problem = png_ok(path)
    if problem:
        fail(f"{link}: {problem}")
print(f"ok: checked {len(links)} linked PNGs" if not bad else f"{bad} image problems")

runs = list(csv.DictReader(open(manifest), delimiter="\t"))
if not runs:
    fail("runs.tsv lists no run")
rows = [line for line in text.splitlines() if line.startswith("| `")]
for r in runs:
    n = sum(1 for line in rows if line.startswith(f"| `{r['id']}` |"))
    if n != 1:
        fail(f"run {r['id']}: {n} rows in the runs table, expected 1")
    if r["status"] != "ok":
        fail(f"run {r['id']}: status {r['status']}")
if len(rows) != len(runs):
    fail(f"the runs table has {len(rows)} rows for {len(runs)} runs")
kinds = {r["kind"] for r in runs}
for k in ("reference", "progressive", "direct", "farm"):
    if k not in kinds:
        fail(f"no {k} run in runs.tsv")
if not bad:
    print(f"ok: {len(runs)} runs, one row each")
sys.exit(1 if bad else 0)
