#!/usr/bin/env bash
# Packs the guest of the real-kernel test bed: a busybox-static initramfs
# (uncompressed newc cpio: the kernel unpacks it fastest, and building it
# costs no compression time) holding
#   /init                     tests/vm/guest/init.sh
#   /lib/modules/*.ko         i2c-stub and i2c-dev of the kernel under test;
#                             contego.ko and i2c-plain-stub.ko when built
#   /usr/bin/contego          a stripped copy of the freshly built binary
#   /usr/bin/contego-monitor  the same of the trusted daemon beside it
#   /usr/sbin/i2c*            the host's i2c-tools (the real clients)
#   /usr/bin/python3          Debian's python3 (never a pyenv shim), a pruned
#                             stdlib, python3-smbus, -smbus2 and -periphery
#   /vm/...                   scenarios, clients, policies, the bench client,
#                             test binaries run on the guest kernel (/vm/bin),
#                             attack programs (/vm/attack)
# and every shared library those programs load, with the dynamic loader.
#
# For a foreign architecture (--arch arm64 --userland DIR) busybox, the
# i2c-tools, python3 and every library come from DIR, the tree of Debian's
# arm64 packages fetch-userland.sh printed, instead of from the host, and the
# libraries are resolved from the ELF headers (the host's ldd cannot).
# --mirror PATH copies a host file or directory to the same path in the
# guest (ELF files stripped, their libraries added): the data of test
# binaries that name it at compile time. --attack PATH puts an attack
# program of tests/intercept (stripped, its libraries added) in /vm/attack.
#
# Usage: build-initramfs.sh [--arch A --userland DIR] [--mirror PATH]... [--attack PATH]...
#                           OUT.cpio CONTEGO KERNEL_DIR BENCH_CLIENT [TEST_BINARY...]
#   KERNEL_DIR is what fetch-kernel.sh printed (it holds modules/).
# Env: CONTEGO_KMOD  contego.ko built for that kernel (kernel/build.sh), put
#                    beside the two i2c modules; unset or empty: none. The
#                    KUnit modules (kunit.ko, contego-kunit.ko) or the reason
#                    they were not built (kunit-skipped), when beside it, too.
#      CONTEGO_STATIC_CLIENT  a static build of the bench client, as
#                    /usr/bin/i2c-write-loop-static; unset or empty: none.
#      CONTEGO_PLAIN_STUB  the plain-I2C test adapter built for that kernel
#                    (tests/vm/kmod/build.sh), as
#                    /lib/modules/i2c-plain-stub.ko; unset or empty: none.
set -euo pipefail

die() { echo "build-initramfs: $*" >&2; exit 1; }
arch=$(dpkg --print-architecture) userland="" mirrors=() attacks=()
while [[ "${1:-}" == --* ]]; do
  case "$1" in
    --arch) arch=$2; shift 2 ;;
    --userland) userland=$2; shift 2 ;;
    --mirror) mirrors+=("$2"); shift 2 ;;
    --attack) attacks+=("$2"); shift 2 ;;
    *) die "unknown option $1" ;;
  esac
done
(($# >= 4)) || die "usage: build-initramfs.sh [--arch A --userland DIR] [--mirror PATH]... [--attack PATH]... OUT.cpio CONTEGO KERNEL_DIR BENCH_CLIENT [TEST_BINARY...]"
out=$1 contego=$2 kdir=$3 bench_client=$4
shift 4
test_binaries=("$@")
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
strip=strip triplet=""
if [[ "$arch" != "$(dpkg --print-architecture)" ]]; then
  [[ -d "$userland" ]] || die "--arch $arch needs --userland DIR (fetch-userland.sh --arch $arch)"
  case "$arch" in
    arm64) triplet=aarch64-linux-gnu ;;
    *) die "unsupported guest architecture $arch" ;;
  esac
  strip=$triplet-strip
  command -v "$strip" >/dev/null || die "$strip missing (bash tools/bootstrap.sh --cross-arm64)"
fi

[[ -x "$contego" ]] || die "no contego binary at $contego (build it first)"
[[ -x "$bench_client" ]] || die "no bench client at $bench_client (build it first)"
[[ -f "$kdir/modules/i2c-stub.ko" ]] || die "no modules in $kdir (run fetch-kernel.sh)"
busybox=$userland/bin/busybox
if [[ -z "$userland" ]]; then
  busybox=/bin/busybox
  [[ -x "$busybox" ]] && file -L "$busybox" 2>/dev/null | grep -q 'statically linked' ||
    busybox=$(command -v busybox) || true
fi
# Debian's busybox-static installs /bin/busybox; the dynamic busybox package
# would need its libraries in the guest too, so insist on the static one.
file -L "$busybox" | grep -q 'statically linked' || die "no static busybox (apt-get install busybox-static)"
if [[ -n "$userland" ]]; then
  # The arm64 python cannot run here: its version is the stdlib's directory.
  pyver=$(cd "$userland/usr/lib" && ls -d python3.* | head -n1)
  pyver=${pyver#python}
  python=$userland/usr/bin/python$pyver
  [[ -x "$python" ]] || die "no python$pyver in $userland"
else
  # The interpreter must be Debian's: the python3-smbus* packages live in its
  # dist-packages, and a pyenv or venv python would not find them.
  python=/usr/bin/python3
  pyver=$("$python" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")') ||
    die "Debian's $python does not run (apt-get install python3)"
fi

root=$(mktemp -d)
trap 'rm -rf "$root"' EXIT
chmod 755 "$root"  # it becomes the guest's /: mktemp's 0700 would lock out every other uid
mkdir -p "$root"/{bin,sbin,usr/bin,usr/sbin,lib/modules,etc,proc,sys,dev,tmp,run,root,vm}
chmod 1777 "$root/tmp"

# Copies a file to the same path under the root, once.
put() {
  local f=$1 dst=${2:-$1}
  [[ -e "$root$dst" ]] && return 0
  mkdir -p "$root$(dirname "$dst")"
  cp -L "$f" "$root$dst"
}
# Copies the shared libraries a program or library needs (and the loader),
# as ldd resolves them on the host, to the same paths in the guest.
put_libs() {
  local lib
  if [[ -n "$userland" ]]; then
    put_foreign_libs "$1"
    return
  fi
  for lib in $(ldd "$1" 2>/dev/null | awk '/=> \// { print $3 } /^\t\/lib/ { print $1 }'); do
    put "$lib"
  done
}
# The same for a foreign ELF file: its interpreter and NEEDED entries,
# looked up in the multiarch directories of the unpacked user space,
# recursively.
put_foreign_libs() {
  local f=$1 interp lib d
  interp=$(readelf -l "$f" 2>/dev/null | sed -n 's/.*program interpreter: \(.*\)]$/\1/p')
  [[ -z "$interp" ]] || put "$userland$interp" "$interp"
  for lib in $(readelf -d "$f" 2>/dev/null | sed -n 's/.*(NEEDED).*\[\(.*\)\]$/\1/p'); do
    for d in /lib/$triplet /usr/lib/$triplet /lib /usr/lib; do
      [[ -e "$userland$d/$lib" ]] || continue
      if [[ ! -e "$root$d/$lib" ]]; then
        put "$userland$d/$lib" "$d/$lib"
        put_foreign_libs "$userland$d/$lib"
      fi
      continue 2
    done
    die "$f needs $lib, which the $arch user space in $userland lacks"
  done
}

# busybox: one link per applet, except its i2c applets: the tests must run
# the real i2c-tools, so the names may not resolve to busybox's versions.
cp "$busybox" "$root/bin/busybox"
run_busybox=("$busybox")
[[ -z "$userland" ]] || run_busybox=(qemu-"${triplet%%-*}" "$busybox")
for applet in $("${run_busybox[@]}" --list); do
  case "$applet" in i2c*|busybox) continue ;; esac
  ln -sf busybox "$root/bin/$applet"
done

cp "$kdir/modules/i2c-stub.ko" "$kdir/modules/i2c-dev.ko" "$root/lib/modules/"
cp "$kdir/version" "$root/etc/kernel-version"
if [[ -n "${CONTEGO_KMOD:-}" ]]; then
  [[ -f "$CONTEGO_KMOD" ]] || die "no contego.ko at $CONTEGO_KMOD"
  cp "$CONTEGO_KMOD" "$root/lib/modules/contego.ko"
  # The KUnit modules kernel/build.sh --kunit left beside it, or why not.
  kmod_dir=$(dirname "$CONTEGO_KMOD")
  for f in kunit.ko contego-kunit.ko kunit-skipped; do
    [[ ! -f "$kmod_dir/$f" ]] || cp "$kmod_dir/$f" "$root/lib/modules/$f"
  done
fi
if [[ -n "${CONTEGO_PLAIN_STUB:-}" ]]; then
  [[ -f "$CONTEGO_PLAIN_STUB" ]] || die "no i2c-plain-stub.ko at $CONTEGO_PLAIN_STUB"
  cp "$CONTEGO_PLAIN_STUB" "$root/lib/modules/i2c-plain-stub.ko"
fi

# contego, stripped (the debug build is tens of MB with its symbols), and the
# trusted daemon beside it (`contego monitor` executes it from there).
"$strip" -o "$root/usr/bin/contego" "$contego"
put_libs "$contego"
daemon="$(dirname "$contego")/contego-monitor"
[[ -x "$daemon" ]] || die "no contego-monitor beside $contego (build it first)"
"$strip" -o "$root/usr/bin/contego-monitor" "$daemon"
put_libs "$daemon"
cp "$bench_client" "$root/usr/bin/i2c-write-loop"
if [[ -n "${CONTEGO_STATIC_CLIENT:-}" ]]; then
  cp "$CONTEGO_STATIC_CLIENT" "$root/usr/bin/i2c-write-loop-static"
fi
put_libs "$bench_client"
# Tests whose subject is the kernel (seccomp filter, IA-32 entry): run again
# on Debian's kernel, which may offer what the host's kernel lacks.
# put_programs DIR WHAT PROGRAM...: stripped into the guest's DIR, with their libraries.
put_programs() {
  local dir=$1 what=$2 t
  shift 2
  mkdir -p "$root$dir"
  for t in "$@"; do
    [[ -x "$t" ]] || die "no $what at $t (build it first)"
    "$strip" -o "$root$dir/$(basename "$t")" "$t"
    put_libs "$t"
  done
}
put_programs /vm/bin "test binary" "${test_binaries[@]}"
# The attack programs of tests/intercept (scenario 61).
put_programs /vm/attack "attack program" "${attacks[@]}"

# Test data named at compile time, at the same paths.
for m in "${mirrors[@]}"; do
  [[ -e "$m" ]] || die "no $m to mirror into the guest"
  mkdir -p "$root$(dirname "$m")"
  cp -a "$m" "$root$m"
  while IFS= read -r -d '' f; do
    head -c4 "$f" | grep -q 'ELF' || continue
    "$strip" "$f" 2>/dev/null || true
    put_libs "$f"
  done < <(find "$root$m" -type f -print0)
done

for t in i2cdetect i2cget i2cset i2cdump i2ctransfer; do
  if [[ -n "$userland" ]]; then
    p=$userland/usr/sbin/$t
    [[ -x "$p" ]] || die "$t not in $userland"
  else
    p=$(command -v "$t" || true)
    [[ -n "$p" && "$p" != *busybox* ]] || die "$t not found (apt-get install i2c-tools)"
  fi
  put "$p" "/usr/sbin/$t"
  put_libs "$p"
done

# python3: the interpreter, its stdlib without what no client uses (tests,
# GUI, packaging, the static library under config-*), lib-dynload with the
# libraries its extension modules link, and the three I2C packages.
pybin=$(readlink -f "$python")
put "$pybin" "${pybin#"$userland"}"
ln -sf "$(basename "$pybin")" "$root/usr/bin/python3"
put_libs "$pybin"
stdlib=/usr/lib/python$pyver
mkdir -p "$root$stdlib"
tar -C "$userland$stdlib" -cf - \
  --exclude="./test" --exclude="./idlelib" --exclude="./tkinter" --exclude="./turtledemo" \
  --exclude="./lib2to3" --exclude="./ensurepip" --exclude="./distutils" --exclude="./pydoc_data" \
  --exclude="./config-*" --exclude="./venv" --exclude="./sqlite3" --exclude="./dbm" \
  --exclude="./curses" --exclude="./site-packages" --exclude="./dist-packages" \
  --exclude="./lib-dynload/_tkinter*" --exclude="./lib-dynload/_sqlite3*" \
  --exclude="./lib-dynload/_ssl*" --exclude="./lib-dynload/_hashlib*" \
  --exclude="./lib-dynload/_curses*" --exclude="./lib-dynload/_dbm*" --exclude="./lib-dynload/_gdbm*" \
  . | tar -C "$root$stdlib" -xf -
for so in "$root$stdlib"/lib-dynload/*.so; do put_libs "$so"; done
dist=/usr/lib/python3/dist-packages
python_pkgs=(python3-smbus python3-smbus2 python3-periphery)
if [[ -n "$userland" ]]; then
  # The unpacked tree holds only these three packages' dist-packages.
  mkdir -p "$root$dist"
  cp -a "$userland$dist/." "$root$dist/"
  for so in $(find "$root$dist" -name '*.so'); do put_libs "$so"; done
  python_pkgs=()
fi
for pkg in "${python_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed' ||
    die "$pkg is not installed (bash tools/bootstrap.sh)"
  while read -r f; do
    [[ "$f" == "$dist"/* && -f "$f" ]] || continue
    put "$f"
    [[ "$f" == *.so ]] && put_libs "$f"
  done < <(dpkg -L "$pkg")
done

# Users: root, the monitor's own user (sole owner of the bus node) and an
# unprivileged control-task user.
cat >"$root/etc/passwd" <<'PASSWD'
root:x:0:0:root:/root:/bin/sh
contego:x:990:990:contego monitor:/run/contego:/bin/false
task:x:1000:1000:control task:/tmp:/bin/sh
nobody:x:65534:65534:nobody:/nonexistent:/bin/false
PASSWD
cat >"$root/etc/group" <<'GROUP'
root:x:0:
contego:x:990:task
task:x:1000:
nogroup:x:65534:
GROUP

# The test material.
cp "$here/guest/init.sh" "$root/init"
chmod 755 "$root/init"
mkdir -p "$root/vm/scenarios" "$root/vm/clients" "$root/vm/policies"
cp "$here"/guest/lib.sh "$root/vm/"
cp -r "$here"/guest/inc "$root/vm/inc"
cp "$here"/guest/scenarios/*.sh "$root/vm/scenarios/"
cp "$here"/guest/clients/* "$root/vm/clients/"
# Reuse the end-to-end tests' client scripts where they fit.
cp "$src"/tests/intercept/scripts/*.py "$root/vm/clients/"
cp "$src"/policies/*.policy "$root/vm/policies/"
mkdir -p "$root/vm/policies/observe"
cp "$src"/policies/observe/*.policy "$root/vm/policies/observe/"
# The vendor-style Hand and the raw-write attacker of the learn scenario.
cp "$src"/tests/vendor/sixdof_hand.py "$src"/tests/vendor/attack_writes.py "$root/vm/clients/"
# A signed policy bundle for `contego kmod load --require-signed` (scenario
# 60): made and signed here with the host's contego (CONTEGO_HOST_TOOL) and
# the real minisign; the guest only verifies. Without either, the scenario
# says it skips those checks.
if [[ -x "${CONTEGO_HOST_TOOL:-}" ]] && command -v minisign >/dev/null; then
  keys=$(mktemp -d)
  mkdir -p "$root/vm/keys"
  minisign -G -W -p "$root/vm/keys/robot.pub" -s "$keys/robot.key" >/dev/null
  (cd "$src" && "$CONTEGO_HOST_TOOL" check policies/arm.policy \
    --emit-bundle "$root/vm/policies/arm.bundle" >/dev/null 2>&1) || die "contego check --emit-bundle"
  minisign -S -s "$keys/robot.key" -m "$root/vm/policies/arm.bundle" -t "test bed arm" >/dev/null
  sed 's/"sessions": 1/"sessions": 9/' "$root/vm/policies/arm.bundle" >"$root/vm/policies/arm-changed.bundle"
  cp "$root/vm/policies/arm.bundle.minisig" "$root/vm/policies/arm-changed.bundle.minisig"
  rm -rf "$keys"
fi

(cd "$root" && find . -print0 | LC_ALL=C sort -z | cpio --null -o -H newc --quiet -R 0:0) >"$out.tmp"
mv "$out.tmp" "$out"
echo "build-initramfs: $out ($(du -h "$out" | cut -f1))" >&2
