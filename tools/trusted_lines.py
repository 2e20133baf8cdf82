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
    """The source file of each compile unit, absolute: a relative DW_AT_name
    (a compiler cache's base directory makes them so) is resolved against
    the unit's DW_AT_comp_dir."""
    out = subprocess.run(["readelf", "--debug-dump=info", "--dwarf-depth=1", binary],
                         capture_output=True, text=True, check=True).stdout
    units, cu = [], None
    for line in out.splitlines():
        if "DW_TAG_compile_unit" in line:
            cu = {}
            units.append(cu)
            continue
        if cu is None:
            continue
        m = re.search(r"DW_AT_(name|comp_dir)\s*:.*?([^\s)]+)\s*$", line)
        if m:
            cu.setdefault(m.group(1), m.group(2))
        elif "DW_TAG_" in line or line.strip() == "":
            cu = None
    return [(u["name"], u.get("comp_dir", "")) for u in units if "name" in u]


def source_file(name, comp_dir, source):
    """The project file a compile unit names, relative to `source`, or None.
    A relative name is relative to the unit's build directory; a cached
    object (ccache, its base directory and no hashed directory) may carry
    another clone's comp_dir, so the name's own path below its leading
    `../` is tried against `source` too."""
    candidates = [name] if os.path.isabs(name) else [os.path.join(comp_dir, name)]
    if not os.path.isabs(name):
        candidates.append(os.path.join(source, re.sub(r"^(\.\./)+", "", name)))
    for c in candidates:
        path = os.path.realpath(c)
        rel = os.path.relpath(path, source)
        if not rel.startswith("..") and rel.endswith(".cc") and os.path.exists(path):
            return rel
    return None


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
        for name, comp_dir in compile_units(binary):
            rel = source_file(name, comp_dir, source)
            if rel:
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
