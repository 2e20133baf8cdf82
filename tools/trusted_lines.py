#!/usr/bin/env python3
"""Lines of the project's own code linked into each binary, and its size.

Usage: trusted_lines.py SOURCE_DIR [--max-lines N] BINARY [BINARY...]

Which translation units a binary holds is read from its DWARF compile units
(a static library's object is linked only if something uses it), so the
count is what was linked, not what a CMake list names. The count is lines
of the project's .cc files (the headers they include are not counted); the
size is the file's, and that of its loaded segments (`size`: text + data +
bss). With --max-lines, the first binary must stay within N lines: the
trusted daemon has a budget (issue 37)."""
import os
import re
import subprocess
import sys


def compile_units(binary):
    out = subprocess.run(["readelf", "--debug-dump=info", "--dwarf-depth=1", binary],
                         capture_output=True, text=True, check=True).stdout
    names, in_cu, comp_dir = [], False, None
    for line in out.splitlines():
        if "DW_TAG_compile_unit" in line:
            in_cu, name, comp_dir = True, None, None
            continue
        if not in_cu:
            continue
        m = re.search(r"DW_AT_(name|comp_dir)\s*:.*?([^\s)]+)\s*$", line)
        if m and m.group(1) == "name":
            names.append(m.group(2))
        elif "DW_TAG_" in line or line.strip() == "":
            in_cu = False
    return names


def main():
    args = sys.argv[1:]
    source = os.path.realpath(args.pop(0))
    limit = None
    if args and args[0] == "--max-lines":
        limit = int(args[1])
        args = args[2:]
    if not args:
        sys.exit(__doc__)
    first = None
    for binary in args:
        files = set()
        for name in compile_units(binary):
            path = os.path.realpath(name if os.path.isabs(name) else os.path.join(source, name))
            rel = os.path.relpath(path, source)
            if rel.startswith("..") or not rel.endswith(".cc") or not os.path.exists(path):
                continue
            files.add(rel)
        if not files:
            # A build without debug information cannot say what it linked.
            print(f"skipped: {binary} has no compile units of {source} (built without -g)")
            sys.exit(77)
        lines = {f: sum(1 for _ in open(os.path.join(source, f), encoding="utf-8")) for f in files}
        total = sum(lines.values())
        layers = {}
        for f, n in lines.items():
            parts = f.split("/")
            layer = "/".join(parts[:2]) if parts[0] == "src" else parts[0]
            layers[layer] = layers.get(layer, 0) + n
        seg = subprocess.run(["size", binary], capture_output=True, text=True, check=True)
        loaded = int(seg.stdout.splitlines()[1].split()[3])
        print(f"{os.path.basename(binary)}: {total} lines of .cc in {len(files)} files linked; "
              f"file {os.path.getsize(binary)} bytes, loaded {loaded} bytes (text+data+bss)")
        print("  by layer: " + ", ".join(f"{k} {v}" for k, v in sorted(layers.items())))
        if first is None:
            first = total
    if limit is not None:
        if first > limit:
            sys.exit(f"trusted_lines: {args[0]} links {first} lines of .cc, over its budget of {limit}")
        print(f"within the budget of {limit} lines")


if __name__ == "__main__":
    main()
