#!/usr/bin/env python3
"""Items the workspace makes public by more than one path, and cross-crate re-exports.

    .ci/two_paths.py        # print them; exit 1 when there are any

An item has two public paths when a public module defines it (or re-exports it) and another
public module `pub use`s it too: `explore::dfs::Tree` and `explore::dfs::tree::Tree`.
A crate that `pub use`s another workspace crate's item gives it a path in a crate that does not
define it; those are listed as cross-crate whether or not the source path is public.

The parser (.ci/rust_modules.py) is the one `.ci/public_api.py` uses: `pub mod`/`mod` declarations by file,
top-level `pub` items, and top-level `pub use` statements (which may span lines), with
`crate::`, `self::`, `super::`, child-module and workspace-crate prefixes resolved.
Items in a `#[cfg(test)] mod` and the GCS's `main.rs` are ignored.
"""
import sys

from rust_modules import CRATES, is_public, load

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
        for _, name in m["items"]:
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
