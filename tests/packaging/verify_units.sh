#!/usr/bin/env bash
# systemd-analyze verify on contego's units (the template as one instance),
# ExecStart pointed at the given contego binary. Any complaint fails.
# Usage: verify_units.sh CONTEGO SOURCE_DIR
set -euo pipefail
contego=$1 src=$2
command -v systemd-analyze >/dev/null || { echo "verify_units: SKIP: no systemd-analyze"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bindir=$(dirname "$contego")
for unit in contego-monitor.service contego-run@.service contego-kmod-audit.service \
  contego-kmod-load.service; do
  sed "s|@CMAKE_INSTALL_FULL_BINDIR@|$bindir|" "$src/packaging/system/$unit.in" > "$tmp/$unit"
done
cd "$tmp"
# --man=no: the man pages are not installed on the build machine.
if ! out=$(systemd-analyze verify --man=no contego-monitor.service contego-run@follower.service \
  contego-kmod-audit.service contego-kmod-load.service 2>&1) ||
  [[ -n $out ]]; then
  echo "$out"
  echo "verify_units: FAIL: systemd-analyze verify complained"
  exit 1
fi
# The hardening the package promises is in the monitor unit.
for key in Type=notify WatchdogSec= LimitNOFILE= ProtectSystem=strict NoNewPrivileges=yes \
  PrivateTmp=yes ProtectHome=yes RestrictAddressFamilies=AF_UNIX DevicePolicy=closed \
  'DeviceAllow=char-i2c rw' CapabilityBoundingSet=; do
  grep -q "^$key" contego-monitor.service || { echo "verify_units: FAIL: no $key"; exit 1; }
done
echo "verify_units: ok"
