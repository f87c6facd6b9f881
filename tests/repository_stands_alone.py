#!/usr/bin/env python3
"""The repository stands alone (issue 51): nothing it holds reads a folder
next to the checkout, and every mesh its tests, benches, scripts and docs
name is in data/meshes.

Usage: repository_stands_alone.py SOURCE_DIR [MESH_DIR]

1. No file of the repository (git ls-files when SOURCE_DIR is a checkout,
   every file but build trees and web/node_modules otherwise) contains the
   parent-folder path or the old CMake variable named in FORBIDDEN.
2. Every repository mesh the tests use exists in data/meshes: the names
   given to the test helpers (SharedMesh("x"), Shared{"x"}, Expected{"x",
   ExpectPoseOblivious("x"), the Python tests' mesh directory), every
   mesh-file name in a brace list that also names such a mesh (the tests'
   loops over meshes), and every data/meshes/NAME written anywhere.
3. When MESH_DIR (the configured MESHGAUGE_MESH_DIR) is given, it holds the
   same files.
Exit status 1 with one line per finding when any check fails.
"""

import os
import re
import subprocess
import sys

# Spelled in pieces so that this file does not match itself.
FORBIDDEN = ["../" + "shared", "MESHGAUGE_" + "SHARED_DIR"]
MESH_EXT = r"(?:off|obj|ply|stl|STL|OFF|OBJ|PLY)"
MESH_NAME = r"[A-Za-z0-9_.-]+\." + MESH_EXT
SKIP_DIRS = {".git", "node_modules", "__pycache__"}


def tracked_files(source):
    try:
        out = subprocess.run(["git", "-C", source, "ls-files", "-z"],
                             capture_output=True, check=True).stdout
        files = [f for f in out.decode().split("\0") if f]
        if files:
            return files
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for root, dirs, names in os.walk(source):
        rel = os.path.relpath(root, source)
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not
                   (rel == "." and (d == "build" or d.startswith("build-")))]
        files += [os.path.normpath(os.path.join(rel, n)) for n in names]
    return files


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__)
        return 2
    source = os.path.abspath(sys.argv[1])
    mesh_dir = os.path.join(source, "data", "meshes")
    problems = []

    files = [f for f in tracked_files(source)
             if not f.startswith("web/node_modules/")]
    texts = {}
    for f in files:
        path = os.path.join(source, f)
        if not os.path.isfile(path):
            continue  # deleted in the work tree, not yet committed.
        with open(path, "rb") as fh:
            data = fh.read()
        for word in FORBIDDEN:
            if word.encode() in data:
                for n, line in enumerate(data.splitlines(), 1):
                    if word.encode() in line:
                        problems.append(f"{f}:{n}: names {word}: "
                                        f"{line.decode(errors='replace').strip()[:100]}")
        if b"\0" not in data:
            texts[f] = data.decode(errors="replace")

    # Meshes the tests and the rest of the repository use.
    used = {}  # name -> first place it was seen.

    def use(name, where):
        used.setdefault(name, where)

    helper = re.compile(r'(?:SharedMesh|ExpectPoseOblivious)\(\s*"(' + MESH_NAME +
                        r')"|(?:Shared|Expected)\{\s*"(' + MESH_NAME + r')"')
    python_dir = re.compile(r'os\.path\.join\(\s*(?:MESHES|os\.environ\['
                            r'"MESHGAUGE_MESH_DIR"\])\s*,\s*"(' + MESH_NAME + r')"')
    in_repo = re.compile(r'data/meshes/(' + MESH_NAME + r')')
    literal = re.compile(r'"(' + MESH_NAME + r')"')
    brace_list = re.compile(r'\{[^{};]*?\}', re.S)
    for f, text in texts.items():
        test_source = f.startswith("tests/") and f.endswith((".cc", ".h", ".py"))
        for n, line in enumerate(text.splitlines(), 1):
            for m in in_repo.finditer(line):
                use(m.group(1), f"{f}:{n}")
            if test_source:
                for m in helper.finditer(line):
                    use(m.group(1) or m.group(2), f"{f}:{n}")
        if test_source:  # the name may be on the next line.
            for m in python_dir.finditer(text):
                use(m.group(1), f"{f}:{text.count(chr(10), 0, m.start()) + 1}")
    known = set(used) | (set(os.listdir(mesh_dir)) if os.path.isdir(mesh_dir)
                         else set())
    for f, text in texts.items():
        if not (f.startswith("tests/") and f.endswith(".cc")):
            continue
        for block in re.finditer(r'for \([^;{]*:\s*', text):
            rest = text[block.end():]
            lst = brace_list.match(rest) or re.match(
                r'\{(?:[^{}]|\{[^{}]*\})*\}', rest)
            if not lst:
                continue
            names = [m.group(1) for m in literal.finditer(lst.group(0))
                     if "/" not in m.group(1)]
            if any(n in known for n in names):
                line = text.count("\n", 0, block.start()) + 1
                for n in names:
                    use(n, f"{f}:{line}")

    if not used:
        problems.append("no test names a mesh of data/meshes: the patterns "
                        "of this check no longer match the tests")
    for name, where in sorted(used.items()):
        if not os.path.isfile(os.path.join(mesh_dir, name)):
            problems.append(f"{where}: uses mesh {name}, not in data/meshes")
    if len(sys.argv) == 3:
        configured = os.path.abspath(sys.argv[2])
        for name, where in sorted(used.items()):
            if not os.path.isfile(os.path.join(configured, name)):
                problems.append(f"{where}: mesh {name} is not in the "
                                f"configured MESHGAUGE_MESH_DIR {configured}")

    for p in problems:
        print(p)
    print(f"{len(files)} files read, {len(used)} meshes used "
          f"({', '.join(sorted(used))}), {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
