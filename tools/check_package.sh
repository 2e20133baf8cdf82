#!/usr/bin/env bash
# Checks built Debian packages: the architecture, the files the runtime
# package must hold, no build-tree path in any file list (dpkg-deb -c), and
# no source- or build-tree path in the installed binaries (strings), and
# lintian on every .deb: no error or warning other than the tags
# packaging/lintian.suppress lists with their reasons.
# Usage: tools/check_package.sh --arch ARCH --forbid DIR [--forbid DIR]... DEB...
#   DIR: a path that must not appear (the source tree the packages were built from)
set -euo pipefail
arch=""
forbid=()
while [[ ${1:-} == --* ]]; do
  case $1 in
    --arch) arch=$2; shift 2 ;;
    --forbid) forbid+=("$2"); shift 2 ;;
    *) echo "check_package.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
(($#)) || { echo "usage: tools/check_package.sh --arch ARCH --forbid DIR... DEB..." >&2; exit 2; }
fail=0
bad() { echo "check_package: FAIL: $*" >&2; fail=1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
runtime="" dkms_deb="" dev_deb=""
for deb in "$@"; do
  name=$(dpkg-deb -f "$deb" Package)
  # contego-dkms holds sources: architecture all.
  want=$arch
  [[ $name == contego-dkms ]] && want=all
  [[ -z $want || $(dpkg-deb -f "$deb" Architecture) == "$want" ]] ||
    bad "$deb: architecture $(dpkg-deb -f "$deb" Architecture), expected $want"
  dpkg-deb -c "$deb" > "$tmp/$name.list"
  for dir in "${forbid[@]}"; do
    if grep -F -e "$dir" "$tmp/$name.list"; then bad "$deb lists a path under $dir"; fi
  done
  if grep -E '(^|/)(build|CMakeFiles|_CPack_Packages)/' "$tmp/$name.list"; then bad "$deb lists a build-tree path"; fi
  [[ $name == contego ]] && runtime=$deb
  [[ $name == contego-dkms ]] && dkms_deb=$deb
  [[ $name == contego-dev ]] && dev_deb=$deb
  echo "check_package: $deb: $(wc -l < "$tmp/$name.list") entries, $(dpkg-deb -f "$deb" Architecture)"
done
[[ -n $runtime ]] || bad "no contego runtime package among $*"
if [[ -n $runtime ]]; then
  dpkg-deb -x "$runtime" "$tmp/root"
  for f in usr/bin/contego usr/bin/contego-monitor usr/share/man/man1/contego.1 usr/share/man/man1/contego-monitor.1 \
    usr/share/bash-completion/completions/contego usr/lib/systemd/system/contego-monitor.service \
    usr/lib/systemd/system/contego-run@.service usr/lib/systemd/system/contego-kmod-audit.service \
    usr/lib/systemd/system/contego-kmod-load.service \
    usr/lib/sysusers.d/contego.conf usr/lib/systemd/catalog/contego.catalog \
    usr/lib/tmpfiles.d/contego.conf usr/lib/udev/rules.d/99-contego-i2c.rules \
    etc/logrotate.d/contego etc/default/contego usr/share/contego/policies/rover.policy \
    usr/share/contego/scenarios/rover_spoof.scn usr/libexec/contego/contego-bench-task; do
    [[ -e $tmp/root/$f ]] || bad "$runtime has no /$f"
  done
  ls "$tmp"/root/usr/lib/*/libcontego_preload.so >/dev/null 2>&1 || bad "$runtime has no preload library"
  # The documentation the README and the man pages point at is on the robot.
  for doc in policy-language.md deployment.md kernel-client.md threat-model.md; do
    [[ -f $tmp/root/usr/share/doc/contego/$doc ]] || bad "$runtime has no /usr/share/doc/contego/$doc"
  done
  # Every ELF file: stripped, and no path of the tree it was built from.
  while IFS= read -r -d '' f; do
    head -c 4 "$f" | grep -q $'\x7fELF' || continue
    rel=${f#"$tmp/root"}
    if file "$f" | grep -q 'not stripped'; then bad "$rel is not stripped"; fi
    for dir in "${forbid[@]}"; do
      if strings -a "$f" | grep -F -e "$dir"; then bad "$rel names $dir"; fi
    done
  done < <(find "$tmp/root" -type f -print0)
  # Hardened as dpkg-buildflags (hardening=+all) would build them: PIE, full
  # RELRO (BIND_NOW), stack protector and fortified libc calls. (Each readelf
  # output is taken whole before grep: `grep -q` in a pipe under pipefail
  # would fail the check with readelf's SIGPIPE.)
  for f in usr/bin/contego usr/bin/contego-monitor usr/libexec/contego/contego-bench-task "$(cd "$tmp/root" && ls usr/lib/*/libcontego_preload.so | head -n1)"; do
    elf=$tmp/root/$f
    [[ -f $elf ]] || continue
    dynamic=$(readelf -d -W "$elf") program=$(readelf -l -W "$elf") header=$(readelf -h "$elf")
    grep -Eq 'BIND_NOW|FLAGS_1.*NOW' <<<"$dynamic" || bad "/$f: not linked with -z now"
    grep -q GNU_RELRO <<<"$program" || bad "/$f: no RELRO segment"
    [[ $f == *.so ]] || grep -q 'DYN (' <<<"$header" || bad "/$f: not a PIE"
  done
  # The small helpers may have no function that needs a canary: the daemon's
  # symbols say whether the flags reached the compiler.
  symbols=$(readelf --dyn-syms -W "$tmp/root/usr/bin/contego")
  grep -q '__stack_chk_fail' <<<"$symbols" || bad "/usr/bin/contego: no stack protector"
  grep -Eq '__[a-z_]+_chk@' <<<"$symbols" ||
    bad "/usr/bin/contego: no fortified libc call (_FORTIFY_SOURCE)"
  echo "check_package: hardening: PIE, -z relro -z now, stack protector, _FORTIFY_SOURCE"
  # Debian's own tool (devscripts), on every ELF file, its report printed;
  # it fails on any protection missing ("unknown" is not a failure: stack
  # clash probes exist only where a large frame needed one).
  if command -v hardening-check >/dev/null; then
    while IFS= read -r -d '' f; do
      head -c 4 "$f" | grep -q $'\x7fELF' || continue
      # Control flow integrity is not asked of anything: the note is CET's
      # (x86 only), and on Debian 12 no binary can carry it, as glibc's
      # start files (Scrt1.o, crti.o, crtn.o) lack the IBT/SHSTK property
      # and the linker drops it from the whole output (ld -z
      # cet-report=warning says so; hardening-check /usr/bin/ls says "no"
      # too). The code is compiled with -fcf-protection all the same.
      cf=(--nocfprotection)
      hc=0
      report=$(hardening-check "${cf[@]}" "$f" 2>&1) || hc=$?
      sed "s|$tmp/root||" <<<"$report"
      ((hc == 0)) || bad "${f#"$tmp/root"}: hardening-check reports a missing protection"
    done < <(find "$tmp/root" -type f -print0)
  else
    bad "hardening-check (devscripts) is not installed: tools/bootstrap.sh installs it"
  fi
  grep -q "ExecStart=/usr/bin/contego monitor" "$tmp/root/usr/lib/systemd/system/contego-monitor.service" ||
    bad "the monitor unit does not run /usr/bin/contego"
fi
# contego-dev: a static core that any compiler links. GCC's link-time
# bytecode (the package build's CONTEGO_CORE_LTO copy) belongs to `contego`
# only: in the archive, an -flto link by another GCC version would fail.
if [[ -n $dev_deb ]]; then
  dpkg-deb -x "$dev_deb" "$tmp/dev"
  archive=$(find "$tmp/dev" -name libcontego_core.a | head -n1)
  [[ -n $archive ]] || bad "$dev_deb has no libcontego_core.a"
  if [[ -n $archive ]] && readelf -S -W "$archive" | grep -q '\.gnu\.lto_'; then
    bad "$dev_deb: libcontego_core.a carries GCC LTO bytecode"
  fi
  if grep -rqs --include='*.cmake' --include='*.pc' -e '-flto' "$tmp/dev/usr/lib"; then bad "$dev_deb: its CMake or pkg-config files ask for -flto"; fi
  # The core stays freestanding in the hardened build: no canary, no
  # fortified call for a kernel or TEE to provide.
  if [[ -n $archive ]]; then
    undefined=$(nm -u "$archive" 2>/dev/null)
    if grep -Eq '__stack_chk_fail|_chk$' <<<"$undefined"; then bad "$dev_deb: libcontego_core.a needs the stack protector's or _FORTIFY_SOURCE's libc calls"; fi
  fi
fi
# contego-dkms: dkms.conf, the module's sources and the core's, and the
# maintainer scripts that hand them to DKMS.
if [[ -n $dkms_deb ]]; then
  dpkg-deb -x "$dkms_deb" "$tmp/dkms"
  dpkg-deb -e "$dkms_deb" "$tmp/dkms-control"
  src=$(ls -d "$tmp"/dkms/usr/src/contego-* 2>/dev/null | head -n1)
  [[ -n $src ]] || bad "$dkms_deb has no /usr/src/contego-VERSION"
  for f in dkms.conf Kbuild contego_main.c contego_xfer.c contego.h include/uapi/linux/contego_kmod.h shim/stdint.h include/contego/core_c.h \
    src/core/checker.cc src/core/interpreter.cc src/core/verifier.cc src/core/state.h \
    src/i2cdev/job_budget.cc src/i2cdev/plan.cc src/i2cdev/session_room.cc src/i2cdev/smbus_call.cc src/i2cdev/timing.cc src/i2cdev/transactions.cc \
    include/contego/i2c_plan.h include/contego/job_budget.h include/contego/session_room.h; do
    [[ -n $src && -e $src/$f ]] || bad "$dkms_deb has no /usr/src/contego-VERSION/$f"
  done
  if [[ -n $src ]] && find "$src" -name '*test*' | grep .; then bad "$dkms_deb holds test sources"; fi
  grep -q 'common.postinst contego' "$tmp/dkms-control/postinst" || bad "$dkms_deb's postinst does not build with DKMS"
  grep -q 'dkms remove -m contego' "$tmp/dkms-control/prerm" || bad "$dkms_deb's prerm does not remove it from DKMS"
fi
# lintian (bootstrap.sh installs it) on the .deb files; the .ddeb debug
# packages are CPack's and not lintian's business.
if command -v lintian >/dev/null; then
  suppress=$(cd "$(dirname "$0")/.." && pwd)/packaging/lintian.suppress
  for deb in "$@"; do
    [[ $deb == *.deb ]] || continue
    # Debian's lintian checks a foreign-architecture package as well.
    rc=0
    lintian --fail-on error,warning --suppress-tags-from-file "$suppress" --tag-display-limit 0 \
      "$deb" >"$tmp/lintian.out" 2>&1 || rc=$?
    grep -v 'running with root privileges' "$tmp/lintian.out" || true
    if ((rc == 0)); then
      echo "check_package: lintian $(basename "$deb"): clean (tolerated: the $(grep -c '^[a-z]' "$suppress") tags of packaging/lintian.suppress)"
    else
      bad "lintian $(basename "$deb") exit $rc (see above)"
    fi
  done
else
  bad "lintian not installed (bash tools/bootstrap.sh)"
fi
((fail == 0)) || exit 1
echo "check_package: ok"
