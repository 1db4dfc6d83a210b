#!/usr/bin/env python3
"""The `make bench-changes` table: scripts/bench_changes_table.py RUNS_TSV [JSON_OUT]

RUNS_TSV has one line per evaluation: scene, change, output folder (with the
summary.json evaluate wrote). Prints per scene and change the share within
5 cm / 5 deg and 2 cm / 2 deg, frames without a pose, answers off by more than
10 cm or 10 deg, and the 5 cm share against the scene's first (unchanged) row
(for "SCENE: a change of the world", against SCENE's first row),
as a Markdown table; JSON_OUT gets the same rows.
"""
import json
import os
import sys


def rows(manifest):
    reference = {}
    for line in open(manifest):
        scene, change, folder = line.rstrip("\n").split("\t")
        with open(os.path.join(folder, "summary.json")) as f:
            s = json.load(f)
        row = {
            "scene": scene,
            "change": change,
            "frames": s["frames"],
            "within_5cm_5deg": 100 * s["within_5cm_5deg"],
            "within_2cm_2deg": 100 * s["within_2cm_2deg"],
            "no_pose": s["frames_without_pose"],
            "wrong_answers": s["wrong_answers"],
            "median_latency_ms": s["latency"]["total"]["median_ms"],
        }
        # A changed world ("SCENE: what changed") against its scene's first row.
        base = scene.split(":")[0]
        reference.setdefault(base, row["within_5cm_5deg"])
        row["points_vs_unchanged"] = row["within_5cm_5deg"] - reference[base]
        yield row


def main():
    if len(sys.argv) not in (2, 3) or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if len(sys.argv) == 2 else 2
    table = list(rows(sys.argv[1]))
    print("| scene | change | 5 cm / 5 deg | 2 cm / 2 deg | no pose | wrong (> 10 cm / 10 deg) "
          "| 5 cm points vs unchanged | median ms |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in table:
        print("| {scene} | {change} | {within_5cm_5deg:.1f} % | {within_2cm_2deg:.1f} % | "
              "{no_pose} of {frames} | {wrong_answers} | {points_vs_unchanged:+.1f} | "
              "{median_latency_ms:.1f} |".format(**r))
    wrong = sum(r["wrong_answers"] for r in table)
    print("\nanswers off by more than 10 cm or 10 deg, all runs: %d" % wrong)
    if len(sys.argv) == 3:
        with open(sys.argv[2], "w") as f:
            json.dump(table, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
