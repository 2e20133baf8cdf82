#!/usr/bin/env bash
# Installs the build tree into a fresh prefix and uses it from there, away
# from the source and build trees: the data, man pages and completion are
# where they belong, `contego demo` finds its scenarios through the prefix,
# and a CMake project (find_package(contego)) and a pkg-config build link
# the installed core.
# Usage: install_tree.sh BUILD_DIR SOURCE_DIR [LINKER_FLAGS]
#   LINKER_FLAGS: the build's (e.g. -fsanitize=...), for the consumers of the core
set -euo pipefail
build=$1 src=$2 ldflags=${3:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "install_tree: FAIL: $*"; exit 1; }
prefix=$tmp/prefix
cmake --install "$build" --prefix "$prefix" --strip >"$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install"; }
contego=$prefix/bin/contego
[[ -x $contego ]] || fail "no bin/contego"
[[ ! -e $prefix/bin/contego-build-tree.paths ]] || fail "the build tree's marker file was installed"
"$contego" --version | grep -q '^contego [0-9]' || fail "contego --version"
for f in share/contego/policies/rover.policy share/contego/scenarios/rover_spoof.scn \
  share/man/man1/contego.1 share/bash-completion/completions/contego \
  lib/systemd/system/contego-monitor.service lib/systemd/system/contego-run@.service \
  lib/systemd/system/contego-kmod-audit.service lib/systemd/system/contego-kmod-load.service \
  lib/sysusers.d/contego.conf lib/tmpfiles.d/contego.conf lib/udev/rules.d/99-contego-i2c.rules \
  etc/logrotate.d/contego etc/default/contego include/contego/core_c.h libexec/contego/contego-bench-task; do
  [[ -e $prefix/$f ]] || fail "no $f in the install tree"
done
# A man page per subcommand, each rendering without a groff warning.
for sub in $("$contego" --help | sed -n '/^Subcommands:/,$p' | awk 'NR > 1 && NF {print $1}'); do
  [[ -f $prefix/share/man/man1/contego-$sub.1 ]] || fail "no man page for contego $sub"
done
if command -v groff >/dev/null; then
  warnings=$(groff -man -ww -z "$prefix"/share/man/man1/*.1 2>&1)
  [[ -z $warnings ]] || fail "groff: $warnings"
fi
bash -c "source '$prefix/share/bash-completion/completions/contego' && complete -p contego" >/dev/null ||
  fail "the bash completion does not load"
# The data through the prefix: run from a directory without scenarios/.
mkdir "$tmp/work"
(cd "$tmp/work" && "$contego" demo --out demo-out) >"$tmp/demo.log" 2>&1 || { cat "$tmp/demo.log"; fail "contego demo from the install tree"; }
grep -q "Fig. 4(a)" "$tmp/demo.log" || fail "contego demo printed no summary"
# The core as a library: CMake package config and pkg-config.
[[ -n $(find "$prefix" -path '*/cmake/contego/contegoConfig.cmake') ]] || fail "no cmake/contego package config"
cmake -S "$src/tests/packaging/consumer" -B "$tmp/consumer" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_EXE_LINKER_FLAGS="$ldflags" \
  >"$tmp/consumer.log" 2>&1 && cmake --build "$tmp/consumer" >>"$tmp/consumer.log" 2>&1 ||
  { cat "$tmp/consumer.log"; fail "find_package(contego) consumer"; }
"$tmp/consumer/consumer" | grep -q "checker" || fail "the consumer does not run"
pcdir=$(dirname "$(find "$prefix" -name contego.pc | head -1)")
# shellcheck disable=SC2046
# shellcheck disable=SC2086
cc $ldflags -o "$tmp/consumer_pc" "$src/tests/packaging/consumer/consumer.c" \
  $(PKG_CONFIG_PATH=$pcdir pkg-config --cflags --libs contego) || fail "pkg-config consumer"
"$tmp/consumer_pc" | grep -q "checker" || fail "the pkg-config consumer does not run"
echo "install_tree: ok"
