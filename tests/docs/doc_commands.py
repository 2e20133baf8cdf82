#!/usr/bin/env python3
"""Every `contego` command line the documentation shows must parse.

Extracts the command lines of README.md, docs/*.md and every file under packaging/: lines of
fenced code blocks that run contego (after an optional `$ ` prompt or a path
such as build/release/src/cli/contego), inline code spans that start with
`contego `, and systemd ExecStart= lines. Each is run through
`contego --parse-only ...`, which converts and validates every argument as
the real command does and then stops.

A bare `contego SUB` names a subcommand: SUB must exist. A line that only
mentions a flag (`contego run --no-channel`) is not a whole
command: it is listed in fragments.txt, and then each of its --flags must
still exist in that subcommand's --help. A fragments.txt entry that the
documentation no longer shows is an error too, so the list cannot rot.

Usage: doc_commands.py CONTEGO SOURCE_DIR [--list]
"""
import glob
import os
import re
import shlex
import subprocess
import sys

PROMPT = re.compile(r"^\s*(?:\$\s+)?((?:\S*/)?contego\s.*)$")


def logical_lines(text):
    """Joins backslash-continued lines."""
    out, cur = [], ""
    for line in text.splitlines():
        if line.rstrip().endswith("\\"):
            cur += line.rstrip()[:-1] + " "
            continue
        out.append(cur + line)
        cur = ""
    if cur:
        out.append(cur)
    return out


def from_markdown(path, text):
    found = []
    fenced = re.compile(r"^\s*```.*?^\s*```", re.S | re.M)
    for block in fenced.finditer(text):
        for line in logical_lines(block.group(0)):
            m = PROMPT.match(line)
            if m:
                found.append(m.group(1))
    rest = fenced.sub("", text)
    for span in re.finditer(r"`([^`]+)`", rest):
        code = " ".join(span.group(1).split())
        if code.startswith("contego "):
            found.append(code)
    return [(path, c) for c in found]


def from_unit(path, text):
    found = []
    for line in logical_lines(text):
        m = re.match(r"^\s*ExecStart=[-@:+!]*(\S*contego\s.*)$", line)
        if m:
            found.append(" ".join(m.group(1).split()))
    return [(path, c) for c in found]


def normalise(command):
    """The command's arguments after the contego executable (comments dropped).

    In a unit, systemd expands `$VAR` from its EnvironmentFile: such a word
    is dropped (it stands for options the administrator adds), except after
    `--`, where it stands for the program and stays as a word."""
    words = shlex.split(command, comments=True)[1:]
    if "--" in words:
        cut = words.index("--")
        return [w for w in words[:cut] if not w.startswith("$")] + words[cut:]
    return [w for w in words if not w.startswith("$")]


def main():
    contego, source = sys.argv[1], sys.argv[2]
    listing = "--list" in sys.argv[3:]
    commands = []
    docs = [os.path.join(source, "README.md")] + sorted(glob.glob(os.path.join(source, "docs", "*.md")))
    for path in docs:
        with open(path, encoding="utf-8") as f:
            commands += from_markdown(os.path.relpath(path, source), f.read())
    for path in sorted(glob.glob(os.path.join(source, "packaging", "**", "*"), recursive=True)):
        if not os.path.isfile(path):
            continue
        with open(path, encoding="utf-8") as f:
            commands += from_unit(os.path.relpath(path, source), f.read())
    with open(os.path.join(os.path.dirname(__file__), "fragments.txt"), encoding="utf-8") as f:
        fragments = [l.strip() for l in f if l.strip() and not l.startswith("#")]
    if listing:
        for path, c in commands:
            print(f"{path}: {c}")
        return 0
    failures, seen_fragments, parsed = [], set(), 0
    help_cache = {}
    for path, command in commands:
        args = normalise(command)
        if command in fragments:
            seen_fragments.add(command)
            sub = args[1] if args[0] == "--parse-only" else args[0]
            if sub not in help_cache:
                help_cache[sub] = subprocess.run([contego, sub, "--help"], capture_output=True,
                                                 text=True).stdout
            for word in args[1:]:
                flag = word.split("=")[0]
                if flag == "--parse-only":
                    continue
                if flag.startswith("--") and not re.search(re.escape(flag) + r"\b", help_cache[sub]):
                    failures.append(f"{path}: `{command}`: contego {sub} has no {flag}")
            continue
        if len(args) == 1:  # `contego sched`: a name of a subcommand, not a command line
            r = subprocess.run([contego, args[0], "--help"], capture_output=True, text=True)
            if r.returncode != 0:
                failures.append(f"{path}: `{command}`: contego has no subcommand {args[0]}")
            else:
                parsed += 1
            continue
        r = subprocess.run([contego, "--parse-only"] + args, capture_output=True, text=True)
        if r.returncode != 0 or "parse-only:" not in r.stdout:
            failures.append(f"{path}: `{command}` does not parse:\n    "
                            + (r.stderr + r.stdout).strip().replace("\n", "\n    "))
        else:
            parsed += 1
    for stale in sorted(set(fragments) - seen_fragments):
        failures.append(f"fragments.txt: `{stale}` is no longer in the documentation")
    for f in failures:
        print("FAIL", f)
    print(f"{parsed} command lines parsed, {len(seen_fragments)} fragments checked, "
          f"{len(failures)} failures")
    if failures:
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
