#!/usr/bin/env python3
"""Count the places outside a mission kind's folders that name the kind (goal and ceiling: 1).

    .ci/kind_mentions.py            # print every place, grouped by kind and file; exit 1 above the ceiling
    .ci/kind_mentions.py --quiet    # only the counts

A mission kind is its folders plus one entry in the list of kinds (`for_each_kind!` in
crates/core/src/kinds.rs, one line per kind), from which every layer generates what names the
kinds. Every other line that names the kind is a place a new kind must touch too. The goal is
1 per kind (the list's line), and CI holds it: CEILING is the goal, and CI fails when a count
rises above it.

The rules:

- **Which kinds**: the entries of `for_each_kind!` (`Variant = "name" {`), by their names in
  mission files; each must have an entry in KINDS below (CI fails on a listed kind that has
  none).
- **A kind's folders** (KINDS[…]["folders"]; a path ending in `/` is a folder, otherwise a file):
  where the code that exists only for that kind lives — its runner and `RunKind` in
  src/kinds/<kind>/, its study in src/experiment/<kind>/, its pure state machine and algorithms
  in the core (the runway: `explore` and `vision::runway`; spatial
  classification: `planner`), and its section of the mission file
  (crates/core/src/mission/definition/<kind>.rs).
- **What names a kind** (KINDS[…]["names"]): the words the code uses for it — its name, its
  type and its modules — matched case-insensitively anywhere in an identifier, a path or a
  string literal (`runway` in `RunwayView`, `onboard_runway` and "runway-mapping"; `bandit`,
  `classification` and `sortie` for spatial classification, which the code calls all three).
- **Where**: the product code, src/ and crates/*/src, without comments (doc comments included)
  and without `#[cfg(test)]` code (tests, integration tests and benchmarks may name any kind).
- **A place** is one line; a line naming a kind twice counts once (a line naming both kinds
  counts for each).
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from layers import code_files  # noqa: E402
from module_cycles import strip  # noqa: E402
from rust_modules import KIND_LIST as REGISTRY, kind_entries  # noqa: E402

ROOTS = ["src", "crates/core/src", "crates/io/src", "crates/sim/src", "crates/camera/src"]
KINDS = {
    "runway-mapping": {
        "name": "runway-mapping",
        "folders": [
            "src/kinds/runway/",
            "src/experiment/runway/",
            "crates/core/src/explore/",
            "crates/core/src/vision/runway/",
            "crates/camera/src/camera/onboard/runway.rs",
            "crates/core/src/mission/definition/runway.rs",
        ],
        "names": ["runway"],
    },
    "spatial-classification": {
        "name": "spatial-classification",
        "folders": [
            "src/kinds/bandit/",
            "src/experiment/bandit/",
            "crates/core/src/planner/",
            "crates/core/src/mission/definition/classification.rs",
            "crates/camera/src/camera/onboard/green.rs",
        ],
        "names": ["bandit", "classification", "sortie"],
    },
}
# Today's counts (lines outside the kind's folders): the goal, 1, the kind's entry in the list.
CEILING = {"runway-mapping": 1, "spatial-classification": 1}
GOAL = 1


def registered():
    """The kinds' names in mission files, in the list's order."""
    names = [name for name, _ in kind_entries()]
    if not names:
        sys.exit(f"kind_mentions: for_each_kind! in {REGISTRY} lists no kind")
    return names


def inside(path, folders):
    return any(path.startswith(f) if f.endswith("/") else path == f for f in folders)


def test_lines(raw):
    """The line numbers of `#[cfg(test)] mod … { … }` (with their bodies), found on the text
    with every comment and literal blanked in place, so that a line a multi-line string
    fills (a test's TOML fixture) is a test line too."""
    blanked = strip(raw, blank=True)
    lines = set()
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{", blanked):
        depth, j = 1, m.end()
        while j < len(blanked) and depth:
            depth += {"{": 1, "}": -1}.get(blanked[j], 0)
            j += 1
        first = blanked.count("\n", 0, m.end()) + 1
        last = blanked.count("\n", 0, j) + 1
        lines.update(range(first, last + 1))
    return lines


def places(kind):
    """[(file, line, text)] outside the kind's folders that name it."""
    words = re.compile("|".join(kind["names"]), re.I)
    found = []
    for root in ROOTS:
        for f, _, _ in code_files(root):
            if inside(f, kind["folders"]):
                continue
            raw = open(f, encoding="utf-8").read()
            tests = test_lines(raw)
            for no, line in enumerate(strip(raw, keep_strings=True).split("\n"), 1):
                if no not in tests and words.search(line):
                    found.append((f, no, line.strip()))
    return found


def main():
    quiet = "--quiet" in sys.argv
    kinds = registered()
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        sys.exit(f"kind_mentions: {', '.join(unknown)} listed in {REGISTRY} but not described in "
                 ".ci/kind_mentions.py's KINDS (its folders and the words that name it)")
    failed = False
    summary = []
    for k in kinds:
        kind = KINDS[k]
        found = places(kind)
        name = kind["name"]
        if not quiet:
            files = {}
            for f, no, line in found:
                files.setdefault(f, []).append((no, line))
            print(f"== {name}: {len(found)} lines outside {', '.join(kind['folders'])} name it "
                  f"({'/'.join(kind['names'])}), in {len(files)} files")
            for f in sorted(files, key=lambda f: (-len(files[f]), f)):
                print(f"  {f} ({len(files[f])})")
                for no, line in files[f]:
                    print(f"    {no}: {line[:110]}")
        ceiling = CEILING[name]
        summary.append(f"{name} {len(found)} (ceiling {ceiling}, goal {GOAL})")
        if len(found) > ceiling:
            failed = True
            print(f"kind_mentions: {name} is named in {len(found)} places outside its folders, "
                  f"more than the ceiling {ceiling}: fold the new ones into the kind's folders")
        elif len(found) < ceiling:
            print(f"kind_mentions: {name} fell to {len(found)}: lower its CEILING in .ci/kind_mentions.py")
    print("kind_mentions: " + "; ".join(summary))
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
