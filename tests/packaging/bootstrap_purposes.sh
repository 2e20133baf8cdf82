#!/usr/bin/env bash
# tools/bootstrap.sh by purpose: each set holds the one before it (demo in
# package in test), the demo's needs no test bed, fuzzer or kernel tooling,
# a purpose it does not know is refused, and every package named exists in
# Debian's archive as this machine's apt sees it (skipped without apt's lists).
# Usage: bootstrap_purposes.sh SOURCE_DIR
set -euo pipefail
src="$1"
fail() { echo "FAIL: $*"; exit 1; }
list() { bash "$src/tools/bootstrap.sh" "$@" --print | sort; }
demo=$(list demo) package=$(list package) test=$(list test)
[ -n "$demo" ] || fail "the demo's set is empty"
[ -z "$(comm -23 <(echo "$demo") <(echo "$package"))" ] || fail "package lacks demo's $(comm -23 <(echo "$demo") <(echo "$package"))"
[ -z "$(comm -23 <(echo "$package") <(echo "$test"))" ] || fail "test lacks package's $(comm -23 <(echo "$package") <(echo "$test"))"
[ "$(list)" = "$test" ] || fail "the default is not the test set"
for heavy in qemu-system-x86 qemu-user clang llvm mmdebstrap valgrind dkms g++-aarch64-linux-gnu lintian; do
  ! echo "$demo" | grep -qx "$heavy" || fail "the demo's set installs $heavy"
done
echo "$demo" | grep -qx cmake && echo "$demo" | grep -qx libfmt-dev || fail "the demo's set cannot build contego"
echo "$package" | grep -qx lintian || fail "the package set cannot check the package (lintian)"
echo "$test" | grep -qx mmdebstrap && echo "$test" | grep -qx qemu-system-x86 || fail "the test set has no test bed"
if bash "$src/tools/bootstrap.sh" everything --print >/dev/null 2>&1; then fail "an unknown purpose was taken"; fi
if command -v apt-cache >/dev/null && [ -n "$(ls /var/lib/apt/lists/*_Packages 2>/dev/null)" ]; then
  for p in $test; do
    apt-cache show "$p" >/dev/null 2>&1 || dpkg-query -W "$p" >/dev/null 2>&1 || fail "no package $p in the archive"
  done
fi
echo "bootstrap_purposes: ok (demo $(echo "$demo" | wc -l), package $(echo "$package" | wc -l), test $(echo "$test" | wc -l) packages)"
