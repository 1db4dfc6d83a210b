"""Every C++ file follows the repository's .clang-format.

A style that is only written down drifts; this fails `make test` on the first
file clang-format would change and names it, with the command that fixes it.
"""
import pathlib
import shutil
import subprocess
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
FOLDERS = ("include", "src", "test")
SUFFIXES = {".h", ".hpp", ".cpp"}


def cpp_files():
    for folder in FOLDERS:
        for path in sorted((SOURCE / folder).rglob("*")):
            if path.suffix in SUFFIXES and path.is_file() and "corpus" not in path.parts:
                yield path


class FormatTest(unittest.TestCase):
    def test_every_cpp_file_follows_clang_format(self):
        clang_format = shutil.which("clang-format")
        self.assertIsNotNone(clang_format, "clang-format not found: install it with `make deps`")
        self.assertTrue((SOURCE / ".clang-format").is_file(), f"{SOURCE}/.clang-format is missing")
        files = list(cpp_files())
        self.assertGreater(len(files), 50, f"found only {len(files)} C++ files under {FOLDERS}")
        # One run over every file; each departure is reported as "FILE:LINE:COL: error: ...".
        done = subprocess.run([clang_format, "--style=file", "--dry-run", "--Werror"] +
                              [str(path.relative_to(SOURCE)) for path in files],
                              cwd=SOURCE, capture_output=True, text=True)
        unformatted = sorted({line.split(":", 1)[0] for line in done.stderr.splitlines()
                              if ": error: " in line})
        if done.returncode != 0 and not unformatted:
            self.fail(f"clang-format failed: {done.stderr.strip()}")
        self.assertEqual(unformatted, [], "these files do not follow .clang-format; run "
                         f"`clang-format -i {' '.join(unformatted)}`")


if __name__ == "__main__":
    unittest.main()
