#!/usr/bin/env bash
# Boots the test bed's guest to an interactive shell on this terminal, to run
# one scenario by hand (sh /vm/scenarios/NAME.sh) or poke at the stub
# (i2cdump -y 0 0x40). Same kernel, initramfs and binaries as the CI run.
# Usage: tests/vm/shell.sh [run.sh options, e.g. --contego PATH]
# Leave with `poweroff -f` in the guest, or Ctrl-A X.
exec bash "$(dirname "$0")/run.sh" --shell "$@"
