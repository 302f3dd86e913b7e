#!/usr/bin/env python3
"""Fail when a Rust source file holds more than LIMIT lines before its tests.

    .ci/file_lengths.py [--limit N] [DIR ...]        # default: 800 lines, src and crates

A file's own code is what comes before its first line that opens a test module
(`#[cfg(test)]` at the start of a line, the convention this repository follows): unit tests
may make a file long, its responsibility may not. Every file over the limit is printed with
its length, longest first, and the exit status is 1.
"""
import argparse
import os
import sys


def code_lines(path):
    """Lines before the first `#[cfg(test)]` at the start of a line (all, if none)."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    for i, line in enumerate(lines):
        if line.startswith("#[cfg(test)]"):
            return i
    return len(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", type=int, default=800)
    ap.add_argument("dirs", nargs="*", default=["src", "crates"])
    args = ap.parse_args()
    over = []
    for top in args.dirs:
        for root, _, files in os.walk(top):
            for name in files:
                if name.endswith(".rs"):
                    path = os.path.join(root, name)
                    n = code_lines(path)
                    if n > args.limit:
                        over.append((n, path))
    for n, path in sorted(over, reverse=True):
        print(f"{path}: {n} lines before its tests (limit {args.limit})")
    print(f"file_lengths: {len(over)} file(s) over {args.limit} lines")
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
