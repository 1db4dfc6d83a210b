#!/usr/bin/python3
"""Counts passed, failed and skipped test cases in a folder of JUnit XML files.

catkin_test_results on Debian bookworm adds a gtest file's <testsuites> totals
to the sum of its <testsuite> children, so it reports every gtest case twice,
and it misses gtest's per-case skips. This counts <testcase> elements instead.
Prints `N passed, N failed[, N skipped]`; exits 1 when anything failed or no
result was found.
"""
import pathlib
import sys
import xml.etree.ElementTree as ET


def count(folder):
    passed = failed = skipped = 0
    failures = []
    for path in sorted(pathlib.Path(folder).rglob("*.xml")):
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as error:
            failed += 1
            failures.append(f"{path}: unreadable result file ({error})")
            continue
        cases = list(root.iter("testcase"))
        if not cases:
            # A suite without cases but with a failure count is a crash marker.
            n = int(root.get("failures", 0)) + int(root.get("errors", 0))
            failed += n
            if n:
                failures.append(f"{path}: {n} failure(s) without test cases")
            continue
        for case in cases:
            name = f"{path.name}: {case.get('classname', '')}.{case.get('name', '')}"
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                failures.append(name)
            elif case.find("skipped") is not None or case.get("result") == "skipped" \
                    or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
    return passed, failed, skipped, failures


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "build/test_results"
    passed, failed, skipped, failures = count(folder)
    if passed + failed + skipped == 0:
        print(f"no test results found under {folder}", file=sys.stderr)
        failed = 1
    for name in failures:
        print(f"FAILED: {name}")
    line = f"{passed} passed, {failed} failed"
    if skipped:
        line += f", {skipped} skipped"
    print(line)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
