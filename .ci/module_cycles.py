#!/usr/bin/env python3
"""Fail when modules of a Rust crate import each other in a cycle.

    .ci/module_cycles.py [SRC_DIR ...]        # default: src and crates/*/src

A crate's modules form a tree (src/a/b.rs is `a::b`). Every path a file names —
`use crate::x::y`, `crate::x::y::f()`, `super::z`, `self::w` — is an edge from the file's
module to the deepest module the path reaches. An edge between two modules counts among the
children of the deepest module that contains both (`a::b::c` -> `a::d` is the edge
`a::b` -> `a::d` among `a`'s children); a parent naming its own child, or a child naming
its parent, is not a layer crossing and counts nowhere. Each parent's children must form an
acyclic graph: otherwise every cycle is printed with one file:line per edge, and the exit
status is 1.

Code under `#[cfg(test)]` modules is skipped (tests may reach anywhere). The parser is
lexical, not a Rust front end: it drops comments and string literals, then reads paths; a
macro that builds a path from pieces is not seen.
"""
import os
import re
import sys
from collections import defaultdict

PATH = re.compile(r"\b(crate|super|self)((?:::\w+)+)")
USE = re.compile(r"\buse\s+([^;]*);", re.S)


CHAR = r"'(\\.|[^\\'])'|'\\u\{[0-9a-fA-F]+\}'"


def strip(text, keep_strings=False, blank=False):
    """Comments out, and string and char literals too unless `keep_strings`; newlines kept so
    line numbers hold. With `blank`, every comment and literal becomes as many spaces (its
    newlines kept), so that every offset into the result is the same offset into `text`."""
    out, i, n = [], 0, len(text)
    spaces = lambda s: re.sub(r"[^\n]", " ", s)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            kind = "comment"
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            kind = "comment"
        elif c == "r" and re.match(r'r#*"', text[i:i + 10]) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = text.find('"' + hashes, i + 2 + len(hashes))
            j = n if end < 0 else end + 1 + len(hashes)
            kind = "string"
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            kind = "string"
        elif c == "'" and re.match(CHAR, text[i:i + 12]):
            j = i + re.match(CHAR, text[i:i + 12]).end()
            kind = "char"
        else:
            out.append(c)
            i += 1
            continue
        span = text[i:j]
        if blank:
            out.append(spaces(span))
        elif kind == "comment":
            out.append("\n" * span.count("\n") if span.startswith("/*") else "")
        elif keep_strings:
            out.append(span)
        else:
            out.append('""' + "\n" * span.count("\n") if kind == "string" else "' '")
        i = j
    return "".join(out)


def drop_test_modules(text):
    """Blank the bodies of `#[cfg(test)] mod x { ... }` (lines kept)."""
    for m in list(re.finditer(r"#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{", text)):
        start = m.end()
        depth, j = 1, start
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        body = text[start:j]
        text = text[:start] + re.sub(r"[^\n]", " ", body) + text[j:]
    return text


def expand_use(tree):
    """`a::{b, c::{d, e}}` -> ["a::b", "a::c::d", "a::c::e"] (`self` in a group is the prefix)."""
    tree = re.sub(r"\s+as\s+\w+", "", tree)
    tree = re.sub(r"\s+", "", tree)

    def split_top(s):
        parts, depth, cur = [], 0, ""
        for ch in s:
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
                continue
            depth += {"{": 1, "}": -1}.get(ch, 0)
            cur += ch
        if cur:
            parts.append(cur)
        return parts

    def rec(prefix, s):
        if "{" not in s:
            if s == "self":
                return [prefix]
            return [prefix + "::" + s if prefix else s]
        k = s.index("{")
        head = s[:k].rstrip(":")
        inner = s[k + 1:s.rindex("}")]
        base = (prefix + "::" + head if prefix else head) if head else prefix
        out = []
        for p in split_top(inner):
            out.extend(rec(base, p))
        return out

    return rec("", tree)


def module_of(root, path):
    rel = os.path.relpath(path, root)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)


def resolve(here, path, modules):
    """The deepest known module that `crate::…`, `super::…` or `self::…` names from `here`."""
    parts = path.split("::")
    head, rest = parts[0], parts[1:]
    if head == "crate":
        base = ()
    elif head == "self":
        base = here
    else:
        base = here
        while rest and head == "super":
            base = base[:-1]
            head, rest = (rest[0], rest[1:]) if rest[0] == "super" else ("", rest)
            if head == "":
                break
    target = base
    for p in rest:
        if target + (p,) in modules:
            target = target + (p,)
        else:
            break
    return target


def edges_of(root):
    files = []
    for d, _, fs in os.walk(root):
        files += [os.path.join(d, f) for f in fs if f.endswith(".rs")]
    modules = {module_of(root, f) for f in files}
    # Every prefix of a file's module is a module too (a folder with mod.rs or a foo.rs).
    for m in list(modules):
        for k in range(len(m)):
            modules.add(m[:k])
    texts = {}
    test_only = set()
    for f in files:
        with open(f, encoding="utf-8") as fh:
            texts[f] = strip(fh.read())
        # `#[cfg(test)] mod tests;`: the file it names is test code too.
        for m in re.finditer(r"#\[cfg\(test\)\]\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", texts[f]):
            test_only.add(module_of(root, f) + (m.group(1),))
    edges = []
    for f in sorted(files):
        here = module_of(root, f)
        if any(here[:len(t)] == t for t in test_only):
            continue
        text = drop_test_modules(texts[f])
        seen = []
        for m in USE.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            for p in expand_use(m.group(1)):
                p = p.lstrip(":")
                if p.split("::")[0] in ("crate", "super", "self"):
                    seen.append((line, p))
        body = USE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
        for m in PATH.finditer(body):
            seen.append((body.count("\n", 0, m.start()) + 1, m.group(1) + m.group(2)))
        for line, p in seen:
            target = resolve(here, p, modules)
            if target != here:
                edges.append((here, target, f, line))
    return edges


def layer_edge(a, b):
    """(parent, child_a, child_b) where the edge a -> b crosses between siblings, or None."""
    k = 0
    while k < min(len(a), len(b)) and a[k] == b[k]:
        k += 1
    if k == len(a) or k == len(b):
        return None  # one contains the other
    return a[:k], a[k], b[k]


def cycles(graph):
    """Tarjan's strongly connected components of size > 1 (or a self loop)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def check(root):
    by_parent = defaultdict(lambda: defaultdict(set))
    where = {}
    for a, b, f, line in edges_of(root):
        e = layer_edge(a, b)
        if e is None:
            continue
        parent, x, y = e
        by_parent[parent][x].add(y)
        by_parent[parent].setdefault(y, set())
        where.setdefault((parent, x, y), f"{f}:{line}")
    found = 0
    for parent in sorted(by_parent):
        graph = by_parent[parent]
        for comp in cycles(graph):
            found += 1
            name = "::".join(parent) or "crate"
            print(f"{root}: import cycle among the children of {name}: {', '.join(comp)}")
            members = set(comp)
            for x in comp:
                for y in sorted(graph[x] & members):
                    print(f"    {x} -> {y}  ({where[(parent, x, y)]})")
    return found


def default_roots():
    """The workspace's crates: the package at the root (src) and every crates/*/src."""
    crates = sorted(os.path.join("crates", c, "src") for c in os.listdir("crates")) if os.path.isdir("crates") else []
    return ["src"] + [c for c in crates if os.path.isdir(c)]


def main():
    roots = sys.argv[1:] or default_roots()
    found = sum(check(r) for r in roots)
    if found:
        print(f"module_cycles: {found} cycle(s)")
        sys.exit(1)
    print(f"module_cycles: no import cycle in {', '.join(roots)}")


if __name__ == "__main__":
    main()
