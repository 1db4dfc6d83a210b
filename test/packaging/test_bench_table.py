"""scripts/bench_table.py, the `make bench` table, on run folders written here.

`make bench` itself takes many minutes and is not part of `make test`; this checks
that the table reads what scripts/bench.sh and scripts/bench_places.sh write
(stages-<round>.json, places.json, train.time, summary.json) and judges each figure
against the issue-28 target, with known figures in and known rows out.
"""
import json
import os
import pathlib
import subprocess
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TABLE = ROOT / "scripts" / "bench_table.py"


def write_run(run, total_ms_by_round, places_ms, train_seconds, within_5cm):
    run.mkdir(parents=True)
    for index, total_ms in enumerate(total_ms_by_round, start=1):
        stages = {"1": {"total": {"median_ms": total_ms, "p95_ms": total_ms + 2}},
                  "2": {"total": {"median_ms": total_ms / 2, "p95_ms": total_ms}}}
        (run / f"stages-{index}.json").write_text(
            json.dumps({"cpu": "test cpu", "frames": 200, "threads": stages}))
    (run / "places.json").write_text(json.dumps(
        {"latency": [{"places": count, "median_ms": ms, "p95_ms": ms + 1,
                      "within_5cm_5deg": 0.84, "wrong_place": 0}
                     for count, ms in places_ms.items()]}))
    (run / "train.time").write_text(f"{train_seconds} 700000\n")
    (run / "evaluation").mkdir()
    (run / "evaluation" / "summary.json").write_text(json.dumps(
        {"within_5cm_5deg": within_5cm, "within_2cm_2deg": 0.565,
         "median_translation_cm": 1.72}))


def table(runs, *versions):
    return subprocess.run(["/usr/bin/python3", str(TABLE), str(runs), "2", *versions],
                          check=True, capture_output=True, text=True).stdout


def row(text, label):
    lines = [line for line in text.splitlines() if line.startswith(label)]
    if not lines:
        raise AssertionError(f"no row '{label}' in:\n{text}")
    return lines[0]


class BenchTableTest(unittest.TestCase):
    def setUp(self):
        self.scratch = tempfile.TemporaryDirectory()
        self.runs = pathlib.Path(self.scratch.name)

    def tearDown(self):
        self.scratch.cleanup()

    def test_places_latency_rows_come_from_places_json(self):
        write_run(self.runs / "now", [11.0, 13.0, 12.0], {1: 11.5, 2: 12.25, 10: 15.75}, 29.0, 0.84)
        text = table(self.runs, "now")
        self.assertIn("11.5 ms", row(text, "one thread, 1 place"))
        self.assertIn("12.2 ms", row(text, "one thread, 2 places"))
        self.assertIn("15.8 ms", row(text, "one thread, 10 places"))
        # The median of the three rounds' medians, not their mean or the last one.
        self.assertIn("12.0 ms", row(text, "WHOLE relocalize call, 1 thread(s)"))

    def test_targets_are_judged_against_the_now_column(self):
        write_run(self.runs / "previous", [20.0, 20.0, 20.0], {}, 80.0, 0.84)
        write_run(self.runs / "now", [11.0, 11.4, 12.5], {1: 11.0, 2: 12.0, 10: 14.0}, 31.0, 0.825)
        text = table(self.runs, "previous", "now")
        self.assertIn("<= 12 ms: met", row(text, "WHOLE relocalize call, 1 thread(s)"))
        self.assertIn("<= 8 ms: met", row(text, "WHOLE relocalize call, 2 thread(s)"))
        self.assertIn("<= 30 s: MISSED", row(text, "TRAINING"))
        self.assertIn(">= 83.0 %: MISSED", row(text, "ACCURACY within 5 cm"))
        self.assertIn("0.57", row(text, "WHOLE relocalize call, 1 thread(s)"))

    def test_a_run_without_places_shows_a_dash(self):
        write_run(self.runs / "now", [12.0], {}, 30.0, 0.84)
        os.remove(self.runs / "now" / "places.json")
        self.assertRegex(row(table(self.runs, "now"), "one thread, 10 places"), r"\s-$")


if __name__ == "__main__":
    unittest.main()
