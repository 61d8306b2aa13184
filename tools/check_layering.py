#!/usr/bin/env python3
"""Checks that no #include of the library runs up a floor (docs/architecture.md, "Floors").

src/layers.txt says which folders each src/ folder may include, which folder each public
header (include/weft/) counts as, and the known exceptions. Every quoted #include of every
file under src/ is checked against it, and so is every public header it reaches through the
public headers it includes (include/weft/..., followed to the end): a src/ file that includes
weft/garment/placement.hpp, which includes weft/body.hpp, reaches body/. So are the table
itself (every src/ folder named, no folder named that is not there, no circle of folders)
and, first, the check (a tree with an include that runs up, directly or through a public
header, must fail naming the file, the include and the header it runs up through).

Usage: tools/check_layering.py [ROOT]   (ctest runs it as the test `layering`)
Exit status 0 when every include keeps to the table, 1 otherwise (each problem on a line of
its own: FILE:LINE: the include and why it runs up).
"""
import os
import re
import sys
import tempfile

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def read_table(path):
    """The table of src/layers.txt: allowed[folder] = set, owners[header] = folder,
    exceptions = {(file, include)}; a file include/weft/... there is a public header whose
    include is not followed."""
    allowed, owners, exceptions = {}, {}, set()
    section = "folder"
    with open(path) as f:
        for number, line in enumerate(f, 1):
            words = line.split("#", 1)[0].split()
            if not words:
                continue
            if words[0] in ("folder", "header", "exception") and len(words) >= 2 and words[1] in ("may", "folder", "include"):
                section = words[0]  # a table's heading row
                continue
            where = "%s:%d" % (path, number)
            if section == "folder":
                if len(words) < 2:
                    raise SystemExit("%s: expected FOLDER and the folders it may include (- for none)" % where)
                allowed[words[0]] = set() if words[1:] == ["-"] else set(words[1:])
            elif section == "header":
                if len(words) != 2:
                    raise SystemExit("%s: expected HEADER FOLDER" % where)
                owners[words[0]] = words[1]
            else:
                if len(words) < 3:
                    raise SystemExit("%s: expected FILE INCLUDE WHY" % where)
                exceptions.add((words[0], words[1]))
    return allowed, owners, exceptions


def folder_of_include(include, owners):
    """The folder an include counts as (None: vocabulary or a file of the same folder)."""
    if include.startswith("weft/"):
        if include in owners:
            return owners[include]
        for name, folder in owners.items():
            if name.endswith("/") and include.startswith(name):
                return folder
        return None
    if "/" in include:
        return include.split("/", 1)[0]
    return None


def public_includes(root):
    """graph[header] = the public headers it includes, for every header under include/
    (names as included: weft/...)."""
    graph = {}
    base = os.path.join(root, "include")
    for folder, _, files in os.walk(base):
        for name in sorted(files):
            path = os.path.join(folder, name)
            with open(path, errors="replace") as f:
                graph[os.path.relpath(path, base)] = [m.group(1) for m in map(INCLUDE.match, f) if m]
    return graph


def reached(include, graph, exceptions, used):
    """{header: the chain of includes from `include` to it} for every public header that
    `include` reaches (itself included), not following the includes that `exceptions` lists
    for a public header (those it meets are added to `used`)."""
    chains = {include: [include]}
    todo = [include]
    while todo:
        header = todo.pop()
        for other in graph.get(header, ()):
            if ("include/" + header, other) in exceptions:
                used.add(("include/" + header, other))
                continue
            if other in graph and other not in chains:
                chains[other] = chains[header] + [other]
                todo.append(other)
    return chains


def find_circle(allowed):
    """A circle of folders in the table (a list), or None."""
    state = {}

    def visit(folder, path):
        state[folder] = 1
        for other in sorted(allowed.get(folder, ())):
            if state.get(other) == 1:
                return path[path.index(other):] + [other] if other in path else [folder, other]
            if other not in state:
                circle = visit(other, path + [other])
                if circle:
                    return circle
        state[folder] = 2
        return None

    for folder in sorted(allowed):
        if folder not in state:
            circle = visit(folder, [folder])
            if circle:
                return circle
    return None


def check(root):
    """The problems (lines of text) of the tree at root."""
    table = os.path.join(root, "src", "layers.txt")
    allowed, owners, exceptions = read_table(table)
    problems = []
    src = os.path.join(root, "src")
    folders = sorted(d for d in os.listdir(src) if os.path.isdir(os.path.join(src, d)))
    for folder in folders:
        if folder not in allowed:
            problems.append("%s: src/%s/ is not in the table; say which folders it may include" % (table, folder))
    for folder in sorted(allowed):
        if folder not in folders:
            problems.append("%s: %s is in the table but src/%s/ does not exist" % (table, folder, folder))
        for other in sorted(allowed[folder]):
            if other not in allowed:
                problems.append("%s: %s may include %s, which is not a folder of the table" % (table, folder, other))
    circle = find_circle(allowed)
    if circle:
        problems.append("%s: the folders include each other in a circle: %s" % (table, " -> ".join(circle)))
    graph = public_includes(root)
    used = set()
    for folder in folders:
        for base, _, files in os.walk(os.path.join(src, folder)):
            for name in sorted(files):
                if not name.endswith((".cpp", ".hpp", ".h", ".cc")):
                    continue
                path = os.path.join(base, name)
                rel = os.path.relpath(path, root)
                with open(path, errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        include = m.group(1)
                        chains = reached(include, graph, exceptions, used) if include in graph else {include: [include]}
                        runs_up = {}  # folder -> the shortest chain that reaches it
                        for header, chain in sorted(chains.items(), key=lambda hc: (len(hc[1]), hc[0])):
                            target = folder_of_include(header, owners)
                            if target is None or target == folder or target in allowed.get(folder, ()):
                                continue
                            runs_up.setdefault(target, chain)
                        if not runs_up:
                            continue
                        if (rel, include) in exceptions:
                            used.add((rel, include))
                            continue
                        may = " ".join(sorted(allowed.get(folder, ()))) or "nothing"
                        for target, chain in sorted(runs_up.items()):
                            through = "" if len(chain) == 1 else " through %s (%s)" % (chain[-1], " -> ".join(chain))
                            problems.append('%s:%d: #include "%s" reaches %s/%s, a floor above %s/ (src/layers.txt: '
                                            "%s/ may include %s)" % (rel, number, include, target, through, folder,
                                                                     folder, may))
    for rel, include in sorted(exceptions - used):
        if rel.startswith("include/") and include in graph.get(rel[len("include/"):], ()):
            continue  # a public header's include that no src/ file reaches today: still true
        problems.append('%s: the exception for %s includes "%s", which it no longer does: take it off the list'
                        % (table, rel, include))
    return problems


def self_test():
    """The check fails on a tree with an include that runs up, naming the file and the include."""
    with tempfile.TemporaryDirectory() as root:
        for folder in ("util", "mesh"):
            os.makedirs(os.path.join(root, "src", folder))
        with open(os.path.join(root, "src", "layers.txt"), "w") as f:
            f.write("folder may\nutil -\nmesh util\nheader folder\nweft/threads.hpp util\n")
        with open(os.path.join(root, "src", "mesh", "mesh.cpp"), "w") as f:
            f.write('#include "util/threads.hpp"\n#include "weft/threads.hpp"\n#include "weft/types.hpp"\n')
        with open(os.path.join(root, "src", "util", "threads.cpp"), "w") as f:
            f.write('#include "util/threads.hpp"\n\n#include "mesh/mesh.hpp"\n')
        problems = check(root)
        expected = 'src/util/threads.cpp:3: #include "mesh/mesh.hpp" reaches mesh/'
        if len(problems) != 1 or not problems[0].startswith(expected):
            return ["self-test: expected one problem starting %r, got %r" % (expected, problems)]
        # Through public headers: util/ includes a vocabulary header that includes one of mesh/'s.
        os.makedirs(os.path.join(root, "include", "weft"))
        for name, text in (("types.hpp", '#include "weft/vocabulary.hpp"\n'),
                           ("vocabulary.hpp", '#include <vector>\n#include "weft/mesh.hpp"\n'),
                           ("mesh.hpp", '#include "weft/types.hpp"\n')):
            with open(os.path.join(root, "include", "weft", name), "w") as f:
                f.write(text)
        with open(os.path.join(root, "src", "layers.txt"), "a") as f:
            f.write("weft/mesh.hpp mesh\n")
        with open(os.path.join(root, "src", "util", "threads.cpp"), "w") as f:
            f.write('#include "util/threads.hpp"\n#include "weft/types.hpp"\n')
        problems = check(root)
        expected = ('src/util/threads.cpp:2: #include "weft/types.hpp" reaches mesh/ through weft/mesh.hpp '
                    "(weft/types.hpp -> weft/vocabulary.hpp -> weft/mesh.hpp), a floor above util/")
        if len(problems) != 1 or not problems[0].startswith(expected):
            return ["self-test: expected one problem starting %r, got %r" % (expected, problems)]
        # A known exception for the public header's include: not followed, so nothing runs up.
        with open(os.path.join(root, "src", "layers.txt"), "a") as f:
            f.write("exception include why\ninclude/weft/vocabulary.hpp weft/mesh.hpp the test's\n")
        problems = check(root)
        if problems:
            return ["self-test: expected no problem past a public header's known exception, got %r" % problems]
    return []


def main():
    if len(sys.argv) > 2:
        print(__doc__, file=sys.stderr)
        return 2
    root = sys.argv[1] if len(sys.argv) == 2 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    problems = self_test() + check(root)
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
