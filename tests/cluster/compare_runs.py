#!/usr/bin/env python3
"""Compares two fragsim output directories (a one-process `fragsim run` and a merged sharded run).

    compare_runs.py REFERENCE_DIR CANDIDATE_DIR

Equal means:
  * the same files (summary.json, results.h5, ...; hidden files and *.fsp partials aside);
  * summary.json identical but for the "timing" object: every number bit for bit (the doubles'
    bit patterns, so 0.0 and -0.0 differ), every string, key and list length;
  * results.h5 identical to h5diff (exact: no tolerance) but for the root group's attributes
    (created_utc, wall_s, threads and the stored scenario's "threads" differ between any two
    runs; the figures among them are in summary.json); skipped with a note if h5diff is missing.
Exit 0 equal, 1 different (each difference printed, up to 40), 2 usage or unreadable input.
"""
import json
import os
import shutil
import struct
import subprocess
import sys

IGNORED_TOP_LEVEL = {"timing"}


def leaves(node, path, out):
    if isinstance(node, dict):
        out[path + "{}"] = sorted(node.keys())
        for k, v in node.items():
            leaves(v, f"{path}.{k}", out)
    elif isinstance(node, list):
        out[path + "[]"] = len(node)
        for i, v in enumerate(node):
            leaves(v, f"{path}[{i}]", out)
    elif isinstance(node, float):
        out[path] = ("float", struct.pack("<d", node).hex(), repr(node))
    elif isinstance(node, bool) or node is None or isinstance(node, (int, str)):
        out[path] = (type(node).__name__, node, repr(node))
    else:
        out[path] = ("?", repr(node), repr(node))


def load_summary(d):
    with open(os.path.join(d, "summary.json"), encoding="utf-8") as f:
        s = json.load(f)
    for k in IGNORED_TOP_LEVEL:
        s.pop(k, None)
    flat = {}
    leaves(s, "", flat)
    return flat


def visible_files(d):
    return sorted(
        f for f in os.listdir(d) if not f.startswith(".") and not f.endswith(".fsp")
    )


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    ref, cand = argv[1], argv[2]
    problems = []
    try:
        fr, fc = visible_files(ref), visible_files(cand)
        if fr != fc:
            problems.append(f"files differ: {ref}: {fr}; {cand}: {fc}")
        a, b = load_summary(ref), load_summary(cand)
    except (OSError, ValueError) as e:
        print(f"compare_runs: {e}", file=sys.stderr)
        return 2
    for path in sorted(set(a) | set(b)):
        if path not in a:
            problems.append(f"summary.json{path}: only in {cand}: {b[path][-1] if isinstance(b[path], tuple) else b[path]}")
        elif path not in b:
            problems.append(f"summary.json{path}: only in {ref}")
        elif a[path] != b[path]:
            ra = a[path][-1] if isinstance(a[path], tuple) else a[path]
            rb = b[path][-1] if isinstance(b[path], tuple) else b[path]
            problems.append(f"summary.json{path}: {ra} != {rb}")
    h5 = "results.h5"
    if os.path.exists(os.path.join(ref, h5)) or os.path.exists(os.path.join(cand, h5)):
        h5diff = shutil.which("h5diff")
        if h5diff is None:
            print("compare_runs: note: h5diff not found (hdf5-tools): results.h5 not compared")
        else:
            r = subprocess.run(
                [h5diff, "--exclude-attribute", "/", os.path.join(ref, h5), os.path.join(cand, h5)],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            if r.returncode != 0:
                tail = "\n    ".join(r.stdout.strip().splitlines()[-12:])
                problems.append(f"results.h5 differs (h5diff exit {r.returncode}):\n    {tail}")
    if problems:
        print(f"compare_runs: {ref} and {cand} differ in {len(problems)} place(s):")
        for p in problems[:40]:
            print("  " + p)
        return 1
    n = len(a)
    print(f"compare_runs: identical ({n} summary.json values bit for bit, timing aside; "
          f"files {', '.join(fr)})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
