#!/usr/bin/env python3
"""The `make bench` table: scripts/bench_table.py RUNS_DIR THREADS VERSION...

Reads what scripts/bench.sh wrote under RUNS_DIR/<version>/ (train.time,
train.log, evaluate.time, evaluation/summary.json, stages-<round>.json,
node.json, places.json, bench.model) and prints one row per figure with a column per
version and, when both `previous` and `now` are there, now / previous and the
issue-28 target (speed, memory and accuracy within a point of
today's). Per-stage latencies are the median over the benchmark rounds
of each round's median (and of its 95th percentile).
"""
import glob
import json
import os
import re
import statistics
import sys


def load_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def figures(run, threads):
    """Every figure of one version's run, by key, with None where absent."""
    f = {}
    rounds = [load_json(p) for p in sorted(glob.glob(os.path.join(run, "stages-*.json")))]
    rounds = [r for r in rounds if r]
    f["cpu"] = rounds[0]["cpu"] if rounds else "?"
    f["frames"] = rounds[0]["frames"] if rounds else 0
    f["rounds"] = len(rounds)
    for r in rounds:
        for t, stages in r["threads"].items():
            for stage, s in stages.items():
                if not isinstance(s, dict):  # e.g. within_5cm_5deg beside the stages
                    continue
                f.setdefault(f"{stage}@{t}", []).append(s["median_ms"])
                f.setdefault(f"{stage}_p95@{t}", []).append(s["p95_ms"])
    for key, values in list(f.items()):
        if isinstance(values, list):
            f[key] = statistics.median(values)
    try:
        seconds, kb = open(os.path.join(run, "train.time")).read().split()
        f["train_s"], f["train_rss"] = float(seconds), int(kb) / 1024
    except (OSError, ValueError):
        pass
    try:
        f["eval_rss"] = int(open(os.path.join(run, "evaluate.time")).read().split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        log = open(os.path.join(run, "train.log")).read()
        for kind, times in re.findall(r"^\s+(points|lines)\s.*per tree (.*)$", log, re.M):
            seconds = [float(x) for x in re.findall(r"([\d.]+) s", times)]
            if seconds:
                f[f"tree_{kind}"] = f"{min(seconds):.0f}-{max(seconds):.0f} s"
    except OSError:
        pass
    model = os.path.join(run, "bench.model")
    if os.path.exists(model):
        f["model_mb"] = os.path.getsize(model) / 1e6
    summary = load_json(os.path.join(run, "evaluation", "summary.json"))
    if summary:
        f["acc5"] = 100 * summary["within_5cm_5deg"]
        f["acc2"] = 100 * summary["within_2cm_2deg"]
        f["median_cm"] = summary.get("median_translation_cm")
    no_surface = load_json(os.path.join(run, "evaluation_surface_off", "summary.json"))
    if no_surface:
        f["acc5_off"] = 100 * no_surface["within_5cm_5deg"]
        f["acc2_off"] = 100 * no_surface["within_2cm_2deg"]
    node = load_json(os.path.join(run, "node.json"))
    if node:
        f["node_latency"] = node.get("latency_ms_median")
        f["node_answered"] = 100 * node["answered_share"] if "answered_share" in node else None
        f["node_rss"] = node.get("node_peak_rss_mb")
    places = load_json(os.path.join(run, "places.json"))
    for entry in (places or {}).get("latency", []):
        f[f"places_{entry['places']}"] = entry["median_ms"]
    old_model = load_json(os.path.join(run, "previous_model", "summary.json"))
    if old_model:
        f["v1_acc5"] = 100 * old_model["within_5cm_5deg"]
        f["v1_acc2"] = 100 * old_model["within_2cm_2deg"]
    return f


def main():
    runs, threads, versions = sys.argv[1], sys.argv[2], sys.argv[3:]
    data = {v: figures(os.path.join(runs, v), threads) for v in versions}
    now = data.get("now", {})
    t = threads
    stage_rows = [("sampling_points", "sampling, random pixels"), ("sampling_lines", "sampling, LSD lines"),
                  ("forest_points", "point forest (descriptors + prediction)"),
                  ("forest_lines", "line forest (descriptors + prediction)"),
                  ("ransac", "preemptive RANSAC"), ("refinement", "Ceres refinement"),
                  ("surface", "surface ICP and check")]
    # (key, label, unit, format, target text, target test on the "now" value)
    rows = []
    for threads_key in sorted({"1", t}, key=int):
        for key, label in stage_rows:
            rows.append((f"{key}@{threads_key}", f"{label}, {threads_key} thread(s)", "ms", "{:.1f}", None, None))
        target = (12.0 if threads_key == "1" else 8.0)
        rows.append((f"total@{threads_key}", f"WHOLE relocalize call, {threads_key} thread(s), median", "ms",
                     "{:.1f}", f"<= {target:.0f} ms", lambda x, target=target: x <= target))
        rows.append((f"total_p95@{threads_key}", f"  the same, 95th percentile", "ms", "{:.1f}", None, None))
    rows += [
        ("places_1", "one thread, 1 place (the kitchen among 10), median", "ms", "{:.1f}", None, None),
        ("places_2", "one thread, 2 places, median", "ms", "{:.1f}", None, None),
        ("places_10", "one thread, 10 places, median", "ms", "{:.1f}", None, None),
        ("train_s", f"TRAINING, 5 + 5 trees, {t} threads, wall", "s", "{:.1f}", "<= 30 s", lambda x: x <= 30),
        ("tree_points", "  per point tree", "", "{}", None, None),
        ("tree_lines", "  per line tree", "", "{}", None, None),
        ("train_rss", "TRAIN PEAK RSS", "MiB", "{:.0f}", "<= 768 MiB", lambda x: x <= 768),
        ("eval_rss", f"evaluate peak RSS ({t} threads)", "MiB", "{:.0f}", None, None),
        ("model_mb", "MODEL FILE", "MB", "{:.1f}", "<= 50 MB", lambda x: x <= 50),
        ("acc5", "ACCURACY within 5 cm / 5 deg", "%", "{:.1f}", ">= 83.0 %", lambda x: x >= 83.0),
        ("acc2", "ACCURACY within 2 cm / 2 deg", "%", "{:.1f}", ">= 55.5 %", lambda x: x >= 55.5),
        ("median_cm", "median translation error", "cm", "{:.2f}", None, None),
        ("acc5_off", "  5 cm / 5 deg without the surface stage", "%", "{:.1f}", ">= 79.0 %", lambda x: x >= 79.0),
        ("acc2_off", "  2 cm / 2 deg without the surface stage", "%", "{:.1f}", ">= 62.0 %", lambda x: x >= 62.0),
        ("node_latency", "node, 30 Hz replay, publish to ~result, median", "ms", "{:.1f}", None, None),
        ("node_answered", "node, frames answered", "%", "{:.1f}", None, None),
        ("node_rss", "node peak RSS", "MiB", "{:.0f}", None, None),
    ]
    cpu = now.get("cpu") or next(iter(data.values())).get("cpu", "?")
    print()
    print(f"CPU: {cpu}; {os.cpu_count()} cores; {now.get('frames', 0)} test frames; "
          f"latency = median over {now.get('rounds', 0)} alternating rounds of each round's median")
    header = f"{'figure':52s}" + "".join(f"{v:>12s}" for v in versions)
    compare = "previous" in data and "now" in data
    if compare:
        header += f"{'now/prev':>10s}  target"
    print(header)
    for key, label, unit, fmt, target, met in rows:
        cells = []
        for v in versions:
            value = data[v].get(key)
            cells.append("-" if value is None else fmt.format(value) + (f" {unit}" if unit else ""))
        line = f"{label:52s}" + "".join(f"{c:>12s}" for c in cells)
        if compare:
            a, b = data["previous"].get(key), data["now"].get(key)
            ratio = f"{b / a:.2f}" if isinstance(a, float) and isinstance(b, float) and a > 0 else ""
            line += f"{ratio:>10s}"
            if target and isinstance(b, float):
                line += f"  {target}: {'met' if met(b) else 'MISSED'}"
        print(line)
    if "v1_acc5" in now:
        print(f"{'this build on the previous model (format version 1)':52s}"
              f"  {now['v1_acc5']:.1f} % within 5 cm / 5 deg, {now['v1_acc2']:.1f} % within 2 cm / 2 deg")


if __name__ == "__main__":
    main()
