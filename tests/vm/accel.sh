# Chooses how QEMU runs a guest of the test bed; sourced by run.sh and
# booted.sh. Sets `machine` (QEMU's machine and CPU), `accel` (QEMU's
# options) and `accel_name` (KVM or TCG).
#
# An arm64 guest (accel_arch=arm64) is the paper's Raspberry Pi 3 core,
# `-M virt -cpu cortex-a53`, under TCG: no KVM for a foreign architecture.
#
# KVM only where the guest's own kernel boots under it: a writable /dev/kvm
# is not enough. Under some hypervisors (nested virtualisation) QEMU's
# `-cpu host` aborts at the first vCPU reset ("failed to set MSR 0x10a":
# IA32_ARCH_CAPABILITIES), and without that MSR the kernel can still hang
# right after it is decompressed. So the kernel is booted once without a
# root file system: it must reach its panic ("VFS: Unable to mount root")
# within the probe's time. Otherwise TCG, saying why.
#
# Needs: $qemu (qemu-system-x86_64), $accel_kernel (the vmlinuz to boot);
#        $accel_arch (amd64 when unset, or arm64).
# Env:   CONTEGO_VM_ACCEL=tcg forces TCG (to time the bed as on a machine
#        without KVM), =kvm skips the probe.
machine=()
accel=(-accel tcg)
accel_name=TCG
accel_probe() {
  local cpu out
  if [[ ${accel_arch:-amd64} == arm64 ]]; then
    machine=(-M virt -cpu cortex-a53)
    echo "accel: TCG (an arm64 guest: no KVM for a foreign architecture)" >&2
    return
  fi
  case "${CONTEGO_VM_ACCEL:-}" in
    tcg)
      echo "accel: TCG (CONTEGO_VM_ACCEL=tcg)" >&2
      return
      ;;
    kvm)
      accel=(-enable-kvm -cpu host) accel_name=KVM
      echo "accel: KVM (CONTEGO_VM_ACCEL=kvm, not probed)" >&2
      return
      ;;
  esac
  if [[ ! -w /dev/kvm ]]; then
    echo "accel: TCG (/dev/kvm is missing or not writable)" >&2
    return
  fi
  for cpu in host host,-arch-capabilities; do
    # The braces keep the shell's "Aborted" notice of a QEMU that aborts
    # off the terminal.
    out=$({ timeout 20 "$qemu" -enable-kvm -cpu "$cpu" -m 256 -nographic -no-reboot -nic none \
      -kernel "$accel_kernel" -append "console=ttyS0 panic=-1 loglevel=4" </dev/null 2>&1 ||
      true; } 2>/dev/null | tr -d '\r')
    if grep -q 'Kernel panic' <<<"$out"; then
      accel=(-enable-kvm -cpu "$cpu") accel_name=KVM
      echo "accel: KVM (-cpu $cpu)" >&2
      return
    fi
  done
  echo "accel: TCG (/dev/kvm is there, but the kernel did not boot under KVM within 20 s)" >&2
}
accel_probe
