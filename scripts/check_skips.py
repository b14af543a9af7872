#!/usr/bin/env python3
"""Lists the tests that a run skipped, with their reasons, from JUnit files (ctest's
--output-junit, pytest's --junitxml). Under CI (CI=true or CI=1) a skip that tests/expected_skips.txt
does not list fails the run: a missing tool or data set there must not turn into a green build.

Usage: check_skips.py EXPECTED_SKIPS JUNIT.xml [JUNIT.xml...]
A JUnit file that does not exist is an error, except for pytest's (named pytest-*.xml), which
exists only in builds with the Python module. Exits 1 on unexpected skips under CI, 2 on a bad
expected-skips file or a missing ctest file, 0 otherwise.
"""
import fnmatch
import os
import re
import sys
import xml.etree.ElementTree as ET


def expected_skips(path):
    """pattern -> reason. One line each: a test name (fnmatch pattern), optionally after the build
    folder it applies to and a colon (build-asan:NAME), then spaces and the reason."""
    out = {}
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            parts = line.split(None, 1)
            if len(parts) < 2 or not parts[1].strip():
                sys.exit(f"check_skips: {path}:{number}: '{parts[0]}' has no reason")
            out[parts[0]] = parts[1].strip()
    return out


def matches(pattern, folder, name):
    """A pattern is NAME, or FOLDER:NAME for the suite built in that folder (build-asan:...)."""
    if ":" in pattern:
        where, pattern = pattern.split(":", 1)
        if not fnmatch.fnmatchcase(folder, where):
            return False
    return fnmatch.fnmatchcase(name, pattern)


def reason_of(case):
    """The skip's own message: GTEST_SKIP's text, a script's 'skipped: ...' line, pytest's message."""
    skipped = case.find("skipped")
    out = case.findtext("system-out") or ""
    lines = out.splitlines()
    for k, line in enumerate(lines):
        if line.endswith(": Skipped") and k + 1 < len(lines) and lines[k + 1].strip():
            return lines[k + 1].strip()  # GoogleTest: "file:line: Skipped", then the message
        m = re.match(r"\s*skipped:\s*(.+)", line, re.IGNORECASE)
        if m:
            return m.group(1)
    message = skipped.get("message", "") if skipped is not None else ""
    return message or case.get("status", "not run")


def skips(path, prefix):
    """(name, reason) of every test of the file that did not run to a pass or a failure."""
    found = []
    for case in ET.parse(path).getroot().iter("testcase"):
        if case.find("skipped") is None and case.get("status") not in ("notrun", "disabled"):
            continue
        name = case.get("name", "")
        if prefix:  # pytest: module.test_name
            name = prefix + case.get("classname", "").rsplit(".", 1)[-1] + "." + name
        found.append((name, reason_of(case)))
    return found


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    expected = expected_skips(sys.argv[1])
    found = []
    for path in sys.argv[2:]:
        is_pytest = os.path.basename(path).startswith("pytest-")
        if not os.path.exists(path):
            if is_pytest:
                continue
            print(f"check_skips: {path} is absent (ctest --output-junit did not run)", file=sys.stderr)
            return 2
        folder = os.path.basename(os.path.dirname(os.path.abspath(path)))
        found += [(folder, name, reason) for name, reason in skips(path, "Python.Pytest/" if is_pytest else "")]
    ci = os.environ.get("CI", "").lower() in ("true", "1")
    unexpected = []
    for folder, name, reason in found:
        listed = next((r for p, r in expected.items() if matches(p, folder, name)), None)
        tag = f"expected: {listed}" if listed is not None else "UNEXPECTED" if ci else "skipped"
        print(f"check_skips: {folder}: {name}: {reason} ({tag})")
        if listed is None:
            unexpected.append(name)
    if unexpected and ci:
        print(f"check_skips: {len(unexpected)} skipped test(s) that {sys.argv[1]} does not list as expected; under "
              "CI every other skip fails the run (install what is missing, or list the test with its reason)",
              file=sys.stderr)
        return 1
    if not found:
        print("check_skips: no test skipped")
    return 0


if __name__ == "__main__":
    sys.exit(main())
