#!/bin/sh
# PID 1 of the test-bed guest (busybox sh). Mounts the kernel file systems,
# loads i2c-stub (one simulated chip per device address of the example
# policies) and i2c-dev, runs the scenarios named on the kernel command line
# and prints one machine-readable line per result on the serial console:
#   VM-BOOTED kernel=... uptime=...
#   VM-CHECK PASS|FAIL <scenario>: <what>        (from lib.sh)
#   VM-RESULT PASS|FAIL <scenario> <seconds>s
#   VM-DONE passed=N failed=M seconds=S
# then powers off. The host (tests/vm/run.sh) parses these lines.
#
# Kernel command line:
#   contego.scenarios=a,b,c   run only these (names without .sh); default all
#   contego.shell=1           no scenarios: an interactive shell on the console
#   contego.timeout=N         per-scenario limit in seconds (default 420)
#   contego.gtest_filter=P    GTEST_FILTER for scenario 02's test binaries
export PATH=/usr/sbin:/usr/bin:/sbin:/bin
export HOME=/root
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
# /tmp stays the initramfs's own (writable, in memory): test data mirrored
# from a build tree under the host's /tmp (a CI clone) lives there, and a
# tmpfs mounted over it would hide it.
mkdir -p /tmp && chmod 1777 /tmp
mount -t tmpfs -o mode=0755 tmpfs /run
# Loop device nodes and the like are not needed; /dev/console is the serial
# port (console=ttyS0, or ttyAMA0 on arm64), where every line below goes.
exec </dev/console >/dev/console 2>&1

scenarios=all shell=0 timeout=420
set -f  # a filter's '*' is not a file name pattern here
for arg in $(cat /proc/cmdline); do
  case "$arg" in
    contego.scenarios=*) scenarios=${arg#contego.scenarios=} ;;
    contego.shell=*) shell=${arg#contego.shell=} ;;
    contego.timeout=*) timeout=${arg#contego.timeout=} ;;
    contego.accel=*) export ACCEL=${arg#contego.accel=} ;;
    contego.gtest_filter=*) export GTEST_FILTER=${arg#contego.gtest_filter=} ;;
  esac
done
set +f

. /vm/lib.sh
if ! stub_load; then
  echo "VM-RESULT FAIL modules 0s"
  echo "VM-DONE passed=0 failed=1 seconds=0"
  poweroff -f
fi
echo  # the firmware's last line has no newline
echo "VM-BOOTED kernel=$(uname -r) uptime=$(cut -d' ' -f1 /proc/uptime)s cpus=$(nproc)"

if [ "$shell" = 1 ]; then
  echo "contego test bed: /vm/scenarios/*.sh (run one: sh /vm/scenarios/NAME.sh), /vm/clients,"
  echo "/vm/policies; the adapter is /dev/i2c-0. 'poweroff -f' leaves."
  # cttyhack gives the shell a controlling terminal, so Ctrl-C works.
  setsid cttyhack sh -l
  poweroff -f
fi

if [ "$scenarios" = all ]; then
  list=$(ls /vm/scenarios/*.sh | sed 's,.*/,,; s,\.sh$,,')
else
  list=$(echo "$scenarios" | tr ',' ' ')
fi

passed=0 failed=0 t0=$(now_ms)
for s in $list; do
  echo "VM-SCENARIO $s"
  t=$(now_ms)
  if [ ! -f "/vm/scenarios/$s.sh" ]; then
    echo "VM-CHECK FAIL $s: no such scenario"
    rc=1
  else
    # Each scenario gets a fresh stub (all registers zero) and its own
    # shell; a hung one is killed after $timeout seconds.
    stub_reload
    SCENARIO=$s timeout -s KILL "$timeout" sh "/vm/scenarios/$s.sh"
    rc=$?
    if [ $rc = 137 ]; then
      echo "VM-CHECK FAIL $s: killed after ${timeout}s"
      # run_logged shows a command's output only once it ends: show the
      # hung one's (with the test binaries' full output, the test that hung).
      last=$(ls -t "/tmp/$s"/*.out 2>/dev/null | head -n 1)
      [ -n "$last" ] && { echo "    last output ($last):"; tail -n 20 "$last" | sed 's/^/    | /'; }
    fi
    cleanup_processes
  fi
  secs=$(( ($(now_ms) - t) / 1000 ))
  if [ $rc = 0 ]; then
    passed=$((passed + 1)); echo "VM-RESULT PASS $s ${secs}s"
  else
    failed=$((failed + 1)); echo "VM-RESULT FAIL $s ${secs}s"
  fi
done
echo "VM-DONE passed=$passed failed=$failed seconds=$(( ($(now_ms) - t0) / 1000 ))"
sync
poweroff -f
