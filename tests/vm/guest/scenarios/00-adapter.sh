# The guest itself, before contego is involved: Debian's kernel has seccomp
# user notification, i2c-stub is an SMBus-only adapter at /dev/i2c-0 with one
# chip per policy address, and the host's i2c-tools reach it.
. /vm/lib.sh
echo "  kernel $(uname -r), $(nproc) cpus"

grep -q user_notif /proc/sys/kernel/seccomp/actions_avail &&
  ok "seccomp user notification available" || bad "no seccomp user_notif in this kernel"

run_logged funcs i2cdetect -F 0
grep -q "I2C  *no" "$OUT" && grep -q "SMBus Write Byte  *yes" "$OUT" &&
  ok "i2cdetect -F: i2c-stub is SMBus-only (no plain I2C)" || bad "i2cdetect -F 0 unexpected"

run_logged detect i2cdetect -y -a 0
for a in 40 08 06 48 20 3c; do
  grep -q "[ :]$a\( \|$\)" "$OUT" && ok "i2cdetect sees chip 0x$a" || bad "i2cdetect misses chip 0x$a"
done

stub_set 0x40 0xfe 0x1e
expect_reg 0x40 0xfe 0x1e "i2cset/i2cget round trip on the plain adapter"

# The bus node is the monitor user's alone: the task user cannot open it.
run_logged direct as_task i2cget -y 0 0x40 0xfe
[ $RC != 0 ] && grep -q "/dev/i2c-0.*Permission denied" "$OUT" &&
  ok "uid $TASK_UID cannot open $ADAPTER itself" || bad "uid $TASK_UID opened $ADAPTER"
# `contego doctor` where an adapter exists: the kernel, i2c-dev, the node
# and its owner (the monitor user's alone in the test bed), no problem.
run_logged doctor contego doctor
[ $RC = 0 ] && grep -q '^\[ ok \] i2c-dev is loaded' "$OUT" && grep -q '^\[ ok \] /dev/i2c-0 (SMBus stub driver)' "$OUT" &&
  ok "contego doctor: kernel, i2c-dev and /dev/i2c-0 (i2c-stub, the monitor user's alone) reported, exit 0" || bad "contego doctor (exit $RC)"
# A node that reaches the bus without i2c-dev, open to the task's group: a
# Raspberry Pi's /dev/gpiomem for group gpio (here a stand-in node in the
# task user's own group). The doctor names who can bypass contego by it.
mknod /dev/gpiomem c 1 3 && chown 0:1000 /dev/gpiomem && chmod 0660 /dev/gpiomem
run_logged doctor-gpio contego doctor
rm -f /dev/gpiomem
grep -q '^\[warn\] /dev/gpiomem (group task, mode 0660): task can drive the bus.s pins themselves' "$OUT" &&
  grep -q 'fix: keep the robot.s task users out of group task' "$OUT" &&
  ok "contego doctor: a GPIO node the task's group can open is named as a way around contego" ||
  bad "contego doctor did not name /dev/gpiomem (exit $RC)"
grep -q '^\[ ok \] .*/dev/mem.*: only root opens them' "$OUT" &&
  ok "contego doctor: /dev/mem is root's alone" || bad "contego doctor said nothing right of /dev/mem"
finish
