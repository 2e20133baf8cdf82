#!/usr/bin/env python3
"""Man pages and bash completion for contego, generated from the CLI's --help.

The CLI (CLI11) is the one description of every subcommand and option, so
the man pages and the completion are made from it at build time and cannot
drift from it. One page per subcommand (contego-SUB.1, nested subcommands
such as `sched experiment` as sections of their parent's page) and
contego.1 for the program, with the hand-written sections below.

Usage: cli_docs.py OUTDIR VERSION -- CONTEGO [EMULATOR ARGS...]
  (the command after -- runs contego; a cross build puts qemu in front)
Writes OUTDIR/man1/*.1 and OUTDIR/bash-completion/contego.
"""
import os
import re
import subprocess
import sys

DATE = os.environ.get("CONTEGO_MAN_DATE", "")  # empty: no date (reproducible)

FILES = """\
.TP
.I /etc/contego/robot.policy
the policy the packaged monitor unit (contego\\-monitor.service) serves
.TP
.I /etc/default/contego
extra options of the monitor unit (CONTEGO_MONITOR_OPTS, e.g. \\-\\-client\\-uid)
.TP
.I /etc/contego/run/TASK.conf
the control program of contego\\-run@TASK.service (CONTEGO_PROGRAM)
.TP
.I /run/contego/monitor.sock
the monitor's socket
.TP
.I /var/log/contego/audit.jsonl
the monitor's hash-chained audit log (see contego\\-audit(1))
.TP
.I /usr/share/contego
example policies and scenarios
"""


def roff(text):
    text = text.replace("\\", "\\e").replace("-", "\\-")
    return "\n".join(("\\&" + l) if l.startswith((".", "'")) else l for l in text.split("\n"))


def run_help(cmd, words):
    r = subprocess.run(cmd + words + ["--help"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"cli_docs: `contego {' '.join(words)} --help` failed: {r.stderr}")
    return r.stdout


def parse(text):
    """description, usage, {section: [(term, description)]}"""
    lines = text.rstrip("\n").split("\n")
    description = lines[0].strip()
    usage = ""
    sections, current = {}, None
    for line in lines[1:]:
        if line.startswith("Usage:"):
            usage = re.sub(r"^Usage: \S*contego", "contego", line).strip()
            continue
        m = re.match(r"^(\w[\w ]*):$", line)
        if m:
            current = m.group(1)
            sections[current] = []
            continue
        if current is None or not line.strip():
            continue
        if line.startswith("  ") and not line.startswith(" " * 30):
            term, _, desc = line.strip().partition("  ")
            sections[current].append([term.strip(), desc.strip()])
        elif sections[current]:  # continuation: the description on its own line
            entry = sections[current][-1]
            entry[1] = (entry[1] + " " + line.strip()).strip()
    return description, usage, sections


def entries(items):
    out = []
    for term, desc in items:
        out += [".TP", f".B {roff(term)}", roff(desc) if desc else ""]
    return out


def page(name, title, description, body):
    head = f'.TH {name.upper()} 1 "{DATE}" "contego {title}" "User Commands"'
    return "\n".join([head, ".SH NAME", f"{roff(name)} \\- {roff(description)}"] + body) + "\n"


def subcommand_body(cmd, words, parsed, level=".SH"):
    description, usage, sections = parsed
    body = [f"{level} SYNOPSIS" if level == ".SH" else f"{level} contego {' '.join(words)}",
            f".B {roff(usage)}" if usage else ""]
    if level != ".SH":
        body.append(roff(description))
    for section in ("Positionals", "Options"):
        if sections.get(section):
            body += [f"{level} {'ARGUMENTS' if section == 'Positionals' else 'OPTIONS'}"
                     if level == ".SH" else f".SS {section}"] + entries(sections[section])
    for sub, _ in sections.get("Subcommands", []):
        sub_words = words + [sub]
        body += subcommand_body(cmd, sub_words, parse(run_help(cmd, sub_words)), ".SS")
    return body


def completion(subs):
    cases = []
    for name, opts in subs.items():
        cases.append(f"    {name}) opts=\"{' '.join(opts)}\" ;;")
    return f"""# bash completion for contego (generated from its --help by tools/cli_docs.py)
_contego() {{
  local cur=${{COMP_WORDS[COMP_CWORD]}} sub="" i opts
  for ((i = 1; i < COMP_CWORD; i++)); do
    case ${{COMP_WORDS[i]}} in
      -*) ;;
      *) sub=${{COMP_WORDS[i]}}; break ;;
    esac
  done
  if [[ -z $sub ]]; then
    COMPREPLY=($(compgen -W "{' '.join(subs)} --help --version" -- "$cur"))
    return
  fi
  case $sub in
{chr(10).join(cases)}
    *) opts="" ;;
  esac
  if [[ $cur == -* ]]; then
    COMPREPLY=($(compgen -W "$opts --help" -- "$cur"))
  else
    COMPREPLY=($(compgen -f -- "$cur"))
  fi
}}
complete -o filenames -F _contego contego
"""


def main():
    if len(sys.argv) < 5 or sys.argv[3] != "--":
        sys.exit(__doc__)
    outdir, version, cmd = sys.argv[1], sys.argv[2], sys.argv[4:]
    os.makedirs(os.path.join(outdir, "man1"), exist_ok=True)
    os.makedirs(os.path.join(outdir, "bash-completion"), exist_ok=True)
    description, _, sections = parse(run_help(cmd, []))
    subs = {}
    see_also = []
    for sub, sub_desc in sections.get("Subcommands", []):
        parsed = parse(run_help(cmd, [sub]))
        name = f"contego-{sub}"
        body = subcommand_body(cmd, [sub], parsed)
        body += [".SH SEE ALSO", "contego(1)"]
        with open(os.path.join(outdir, "man1", name + ".1"), "w", encoding="utf-8") as f:
            f.write(page(name, version, sub_desc, body))
        options = []
        for term, _ in parsed[2].get("Options", []):
            options += [w.rstrip(",") for w in re.findall(r"--[\w-]+", term)]
        subs[sub] = [o for o in options if o != "--help"]
        see_also.append(f"{name}(1)")
    body = [".SH SYNOPSIS", ".B contego", "[\\-\\-help] [\\-\\-version]", ".I SUBCOMMAND",
            "[OPTIONS]", ".SH DESCRIPTION", roff(description) + ".",
            "Every command a real-time task sends to an actuator passes a small trusted "
            "checker that enforces a policy (access matrix, per-job rate limits, state "
            "invariants) and answers a violation with IGNORE or FAIL-SAFE.",
            "Each subcommand has its own page.", ".SH SUBCOMMANDS"]
    body += entries([(f"{s} ", d + f" (contego-{s}(1))") for s, d in sections["Subcommands"]])
    body += [".SH OPTIONS", ".TP", ".B \\-\\-help", "print the help and exit", ".TP",
             ".B \\-\\-version", "print the version and the policy image format version",
             ".SH FILES", FILES.rstrip("\n"), ".SH SEE ALSO", ", ".join(see_also)]
    with open(os.path.join(outdir, "man1", "contego.1"), "w", encoding="utf-8") as f:
        f.write(page("contego", version, description, body))
    with open(os.path.join(outdir, "bash-completion", "contego"), "w", encoding="utf-8") as f:
        f.write(completion(subs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
