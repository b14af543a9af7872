#!/usr/bin/env python3
"""Checks the size rules of docs/design.md: in extract/, stream/, encode/ and job/, no source file
over 450 lines and no function over 80 lines, unless a comment "size-exception:" at the top of
the function (or of the file, for its length) says why; in cli/, which only parses and prints
(issue 34), no file over 400 lines, without exceptions. Prints each violation; exits 1 if any."""
import pathlib
import re
import sys

MAX_FILE = 450
MAX_FUNCTION = 80
FOLDERS = ["extract", "stream", "encode", "job"]
CLI_MAX_FILE = 400
NOT_FUNCTIONS = re.compile(r"^\s*(if|for|while|switch|catch|do|else|namespace|class|struct|enum|union)\b")


def code_of(line):
    """The line without string literals and // comments."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])*'", "''", line)
    return line.split("//")[0]


def functions(lines):
    """(first line, last line, header) of each function body at namespace or class scope."""
    depth = 0
    scopes = []  # per open brace: whether it opened a function body
    header = []
    start = None
    for n, raw in enumerate(lines):
        line = code_of(raw)
        for ch in line:
            if ch == "{":
                text = " ".join(header + [line]).strip()
                in_function = any(scopes)
                is_function = (not in_function and ")" in text and not NOT_FUNCTIONS.match(text)
                               and "=" not in text.split("(")[0])
                scopes.append(is_function)
                if is_function:
                    start = (n, text)
                depth += 1
            elif ch == "}":
                depth -= 1
                if scopes and scopes.pop():
                    yield start[0], n, start[1]
        stripped = line.strip()
        if stripped.endswith((";", "{", "}")) or stripped.startswith("#") or not stripped:
            header = []
        else:
            header.append(stripped)
    return


def main():
    root = pathlib.Path(__file__).resolve().parent.parent
    bad = 0
    for folder in FOLDERS:
        for path in sorted((root / folder).glob("*.[ch]*")):
            lines = path.read_text().splitlines()
            rel = path.relative_to(root)
            head = "\n".join(lines[:30])
            if len(lines) > MAX_FILE and "size-exception:" not in head:
                print(f"check_sizes: {rel} has {len(lines)} lines (at most {MAX_FILE})")
                bad = 1
            for first, last, header in functions(lines):
                length = last - first + 1
                if length <= MAX_FUNCTION:
                    continue
                above = "\n".join(lines[max(0, first - 6):first + 3])
                if "size-exception:" in above:
                    continue
                name = header.split("(")[0].split()[-1] if "(" in header else header[:40]
                print(f"check_sizes: {rel}:{first + 1} {name} has {length} lines (at most {MAX_FUNCTION})")
                bad = 1
    for path in sorted((root / "cli").glob("*.[ch]*")):
        n = len(path.read_text().splitlines())
        if n > CLI_MAX_FILE:
            print(f"check_sizes: {path.relative_to(root)} has {n} lines (at most {CLI_MAX_FILE} in cli/)")
            bad = 1
    if not bad:
        print("check_sizes: files and functions in extract/, stream/, encode/, job/ and cli/ are within their sizes")
    return bad


if __name__ == "__main__":
    sys.exit(main())
