#!/usr/bin/env python3
"""Items the workspace makes public by more than one path, and cross-crate re-exports.

    .ci/two_paths.py        # print them; exit 1 when there are any

An item has two public paths when a public module defines it (or re-exports it) and another
public module `pub use`s it too: `explore::dfs::Tree` and `explore::dfs::tree::Tree`.
A crate that `pub use`s another workspace crate's item gives it a path in a crate that does not
define it; those are listed as cross-crate whether or not the source path is public.

The parser is the one `.ci/public_api.py` relies on: `pub mod`/`mod` declarations by file,
top-level `pub` items, and top-level `pub use` statements (which may span lines), with
`crate::`, `self::`, `super::`, child-module and workspace-crate prefixes resolved.
Items in a `#[cfg(test)] mod` and the GCS's `main.rs` are ignored.
"""
import os
import re
import sys

CRATES = {
    "fleetmap_core": "crates/core/src",
    "fleetmap_io": "crates/io/src",
    "fleetmap_sim": "crates/sim/src",
    "fleetmap": "src",
}
ITEM = re.compile(r"^pub (?:async |const |unsafe )*(?:fn|struct|enum|trait|type|const|static|mod) (\w+)", re.M)
MOD = re.compile(r"^(pub )?mod (\w+);", re.M)
USE = re.compile(r"^pub use ([^;]*);", re.M)


def module_path(root, path):
    parts = os.path.relpath(path, root)[:-3].split(os.sep)
    if parts[-1] in ("lib", "main", "mod"):
        parts = parts[:-1]
    return tuple(parts)


def before_tests(text):
    """The file without its test module (a `#[cfg(test)]` on a single item keeps the rest)."""
    m = re.search(r"^#\[cfg\(test\)\]\s*mod ", text, re.M)
    return text if m is None else text[: m.start()]


def expand(stmt):
    """`a::{b, c::{d, e as f}}` -> [(["a", "b"], "b"), (["a", "c", "d"], "d"), (["a", "c", "e"], "f")]."""
    stmt = re.sub(r"\s*([{},]|::)\s*", r"\1", re.sub(r"\s+", " ", stmt.strip()))
    out = []

    def walk(prefix, s):
        depth, start, pieces = 0, 0, []
        for i, ch in enumerate(s):
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            elif ch == "," and depth == 0:
                pieces.append(s[start:i])
                start = i + 1
        pieces.append(s[start:])
        for p in filter(None, pieces):
            if "{" in p:
                head, inner = p.split("{", 1)
                walk(prefix + [x for x in head.split("::") if x], inner[:-1])
                continue
            alias = None
            if " as " in p:
                p, alias = p.split(" as ")
            segs = prefix + p.split("::")
            if segs[-1] == "self":
                segs = segs[:-1]
            out.append((segs, alias or segs[-1]))

    walk([], stmt)
    return out


def load():
    mods = {}  # (crate, modpath) -> {"pub": bool, "items": set, "uses": [(segs, name)], "children": set}
    for crate, root in CRATES.items():
        for dirpath, _, files in os.walk(root):
            for f in files:
                if not f.endswith(".rs"):
                    continue
                path = os.path.join(dirpath, f)
                if crate == "fleetmap" and path == os.path.join(root, "main.rs"):
                    continue
                here = module_path(root, path)
                text = before_tests(open(path, encoding="utf-8").read())
                m = mods.setdefault((crate, here), {"items": set(), "uses": [], "children": {}})
                m["items"].update(ITEM.findall(text))
                m["uses"] = [u for s in USE.findall(text) for u in expand(s)]
                for d in MOD.finditer(text):
                    m["children"][d.group(2)] = bool(d.group(1))
    return mods


def is_public(mods, crate, path):
    for i in range(len(path)):
        parent = mods.get((crate, path[:i]))
        if not parent or not parent["children"].get(path[i]):
            return False
    return True


def resolve(mods, crate, here, segs):
    """The (crate, module path, name) a `use` path names, or None for std and external crates."""
    segs = list(segs)
    if segs[0] == "crate":
        base, segs = (), segs[1:]
    elif segs[0] == "self":
        base, segs = here, segs[1:]
    elif segs[0] == "super":
        base = here
        while segs and segs[0] == "super":
            base, segs = base[:-1], segs[1:]
    elif segs[0] in CRATES:
        crate, base, segs = segs[0], (), segs[1:]
    elif segs[0] in mods.get((crate, here), {}).get("children", {}):
        base = here
    else:
        return None
    return crate, base + tuple(segs[:-1]), segs[-1]


def main():
    mods = load()
    # Every (crate, module, name) a public or private module offers, mapped to its definition.
    origin = {}
    for (crate, path), m in mods.items():
        for name in m["items"]:
            origin[(crate, path, name)] = (crate, path, name)
    for _ in range(10):  # re-exports of re-exports
        for (crate, path), m in mods.items():
            for segs, name in m["uses"]:
                src = resolve(mods, crate, path, segs)
                if src is None:
                    continue
                if src[2] == "*":
                    for (c, p, n), o in list(origin.items()):
                        if (c, p) == src[:2]:
                            origin[(crate, path, n)] = o
                elif src in origin:
                    origin[(crate, path, name)] = origin[src]
    paths = {}
    for (crate, path, name), o in origin.items():
        if is_public(mods, crate, path):
            paths.setdefault(o, []).append((crate, path, name))
    found = 0
    for o in sorted(paths):
        where = sorted(paths[o])
        cross = [w for w in where if w[0] != o[0]]
        if len(where) > 1 or cross:
            found += 1
            shown = ", ".join("::".join((c,) + p + (n,)) for c, p, n in where)
            print(f"{'::'.join((o[0],) + o[1] + (o[2],))}: {shown}{' (cross-crate)' if cross else ''}")
    if found:
        print(f"two_paths: {found} item(s) public by more than one path")
        sys.exit(1)
    print("two_paths: every public item has one path")


if __name__ == "__main__":
    main()
