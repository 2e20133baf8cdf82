# Counts the decisions of an audit log and checks an attack-free run: every
# decision allowed, apart from those of the rules named (writes a policy drops
# by design, each said so in the policy). Exits 1, naming each other
# decision, if there is one.
# Usage: verdicts.py LOG [--by-design RULE]... [--require-dropped COMMAND]...
#   --require-dropped: at least one COMMAND was dropped, and no other command was.
import json
import sys

path, by_design, dropped_only = sys.argv[1], set(), set()
args = sys.argv[2:]
while args:
    flag, value = args[0], args[1]
    (by_design if flag == "--by-design" else dropped_only).add(value)
    args = args[2:]
counts, unexpected, dropped = {}, [], {}
with open(path) as f:
    for n, line in enumerate(f, 1):
        r = json.loads(line)
        if r.get("kind") != "decision":
            continue
        counts[r["decision"]] = counts.get(r["decision"], 0) + 1
        if r["decision"] == "allow":
            continue
        dropped[r.get("command_name", "?")] = dropped.get(r.get("command_name", "?"), 0) + 1
        if r.get("rule_name", r.get("rule_kind")) in by_design:
            continue
        if dropped_only and r.get("command_name") in dropped_only:
            continue
        unexpected.append(f"line {n}: {r.get('command_name')} {r['decision']} "
                          f"({r.get('reason_name')}, rule {r.get('rule_name', '-')})")
print(", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
      "| dropped:", ", ".join(f"{k} {v}" for k, v in sorted(dropped.items())) or "none")
for c in dropped_only:
    if not dropped.get(c):
        unexpected.append(f"no {c} was dropped")
for u in unexpected[:20]:
    print("unexpected:", u)
sys.exit(1 if unexpected else 0)
