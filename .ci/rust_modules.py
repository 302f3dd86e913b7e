"""The lexical reader of the workspace's Rust modules that .ci/public_api.py and
.ci/two_paths.py share: which files are which modules, the top-level `pub` items each declares,
what its `pub use` statements (which may span lines) bring in, and which modules are public.

Not a Rust front end: comments are not removed, and a file is read up to its
`#[cfg(test)] mod` (the tests may reach anywhere). What the list of kinds generates where a
module asks for a part of it (`for_each_kind!(part => …)`: the kinds' `pub mod`s) and the types
a file's own macros declare are read as the compiler expands them. The GCS's and the camera
program's `main.rs` are no modules.
"""
import os
import re

CRATES = {
    "fleetmap_core": "crates/core/src",
    "fleetmap_io": "crates/io/src",
    "fleetmap_sim": "crates/sim/src",
    "fleetmap_camera": "crates/camera/src",
    "fleetmap": "src",
}
ITEM = re.compile(r"^pub (?:async |const |unsafe )*(fn|struct|enum|trait|type|const|static|mod) (\w+)", re.M)
MOD = re.compile(r"^(pub )?mod (\w+);", re.M)
USE = re.compile(r"^pub use ([^;]*);", re.S | re.M)
# Types a macro in the file declares (indented `pub struct`, `pub enum`… in its body): a file
# that defines a `macro_rules!` and invokes it declares them.
MACRO_TYPE = re.compile(r"^\s+pub (struct|enum|trait|type) (\w+)", re.M)
KIND_LIST = "crates/core/src/kinds.rs"
KIND_PART = re.compile(r"for_each_kind!\((\w+) =>")


def kind_entries():
    """The list of kinds (`for_each_kind!` in KIND_LIST), in its order: (the kind's name in
    mission files, the rest of its entry's line)."""
    text = open(KIND_LIST, encoding="utf-8").read()
    m = re.search(r"macro_rules! for_each_kind \{(.*?)\n\}", text, re.S)
    if m is None:
        raise SystemExit(f"no for_each_kind! in {KIND_LIST}")
    return re.findall(r'^\s*\w+ = "([a-z-]+)" \{(.*)\}\s*$', m.group(1), re.M)


def kind_modules():
    """The modules each part of the list of kinds declares in the module that asks for it
    (`pub mod` each, generated): part -> [module]."""
    parts = {"file": [], "vision": [], "onboard": [], "run": [], "study": []}
    for _, entry in kind_entries():
        parts["file"].append(re.search(r"file: (\w+)::", entry).group(1))
        vision = re.search(r"vision: (\w+)", entry)
        if vision:
            parts["vision"].append(vision.group(1))
        parts["onboard"].append(re.search(r"\) in (\w+)", entry).group(1))
        parts["run"].append(re.search(r"run: (\w+)::", entry).group(1))
        parts["study"].append(re.search(r"study: (\w+)", entry).group(1))
    return parts


def module_path(root, path):
    """The module a file is, as a tuple of names (`src/a/b.rs` and `src/a/b/mod.rs`: ("a", "b"))."""
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
    """Every module of every crate: (crate, module path) -> its top-level public items as
    (kind, name), its `pub use` paths as (segments, name), and its child modules with whether
    each is declared `pub`."""
    mods = {}
    generated = kind_modules()
    for crate, root in CRATES.items():
        for dirpath, _, files in os.walk(root):
            for f in files:
                if not f.endswith(".rs"):
                    continue
                path = os.path.join(dirpath, f)
                if crate in ("fleetmap", "fleetmap_camera") and path == os.path.join(root, "main.rs"):
                    continue
                here = module_path(root, path)
                text = before_tests(open(path, encoding="utf-8").read())
                m = mods.setdefault((crate, here), {"items": [], "uses": [], "children": {}})
                m["items"].extend(ITEM.findall(text))
                m["uses"] = [u for s in USE.findall(text) for u in expand(s)]
                for d in MOD.finditer(text):
                    m["children"][d.group(2)] = bool(d.group(1))
                if "macro_rules!" in text:
                    m["items"].extend(MACRO_TYPE.findall(text))
                for part in KIND_PART.findall(text):
                    for module in generated.get(part, []):
                        m["children"][module] = True
    return mods


def is_public(mods, crate, path):
    """Whether the module is reachable from its crate's root: every ancestor declares it `pub`."""
    for i in range(len(path)):
        parent = mods.get((crate, path[:i]))
        if not parent or not parent["children"].get(path[i]):
            return False
    return True
