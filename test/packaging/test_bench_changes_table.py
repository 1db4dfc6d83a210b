"""scripts/bench_changes_table.py, the `make bench-changes` table, on runs written here.

`make bench-changes` trains models and takes many minutes, so it is not part of
`make test`; this checks that its table reads what evaluate writes (summary.json)
and compares each change with its scene's unchanged row, with known figures in
and known rows out.
"""
import json
import pathlib
import subprocess
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TABLE = ROOT / "scripts" / "bench_changes_table.py"


def write_run(folder, within_5cm, within_2cm, no_pose, wrong):
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps({
        "frames": 200, "within_5cm_5deg": within_5cm, "within_2cm_2deg": within_2cm,
        "frames_without_pose": no_pose, "wrong_answers": wrong,
        "latency": {"total": {"median_ms": 10.5, "p95_ms": 14.0}}}))


class BenchChangesTableTest(unittest.TestCase):
    def test_rows_compare_each_change_with_its_scenes_unchanged_frames(self):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = pathlib.Path(tmp)
            runs = [("kitchen", "unchanged", 0.85, 0.575, 0, 0),
                    ("kitchen", "warm light, 2700 K", 0.475, 0.455, 105, 1),
                    ("room", "unchanged", 1.0, 1.0, 0, 0),
                    ("room: --test-people 2 (made: 2)", "in the light of training", 0.97, 0.95, 3, 0)]
            lines = []
            for index, (scene, change, a5, a2, no_pose, wrong) in enumerate(runs):
                write_run(tmp / str(index), a5, a2, no_pose, wrong)
                lines.append(f"{scene}\t{change}\t{tmp / str(index)}\n")
            (tmp / "runs.tsv").write_text("".join(lines))
            out = subprocess.run(["python3", str(TABLE), str(tmp / "runs.tsv"),
                                  str(tmp / "changes.json")],
                                 capture_output=True, text=True, check=True).stdout
            self.assertIn("| kitchen | warm light, 2700 K | 47.5 % | 45.5 % | 105 of 200 | 1 | -37.5 |",
                          out)
            self.assertIn("| room: --test-people 2 (made: 2) | in the light of training | 97.0 % | "
                          "95.0 % | 3 of 200 | 0 | -3.0 |", out)
            self.assertIn("all runs: 1", out)
            rows = json.loads((tmp / "changes.json").read_text())
            self.assertEqual(len(rows), 4)
            self.assertAlmostEqual(rows[1]["points_vs_unchanged"], -37.5)

    def test_help_names_its_input(self):
        out = subprocess.run(["python3", str(TABLE), "--help"], capture_output=True, text=True)
        self.assertEqual(out.returncode, 0)
        self.assertIn("RUNS_TSV", out.stdout)


if __name__ == "__main__":
    unittest.main()
