#!/usr/bin/env bash
# Builds the test bed's plain-I2C adapter, i2c-plain-stub.ko
# (i2c-plain-stub.c), with Kbuild against the same Debian linux-headers as
# contego.ko (kernel/kbuild-env.sh resolves them for both).
#
# Usage: tests/vm/kmod/build.sh [--arch amd64|arm64] OUT_DIR [KDIR]
#   OUT_DIR receives i2c-plain-stub.ko (Kbuild builds in OUT_DIR/kbuild).
# Exit 77 (skip) when the headers or the cross tools are not installed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
KB_NAME=tests/vm/kmod/build.sh
. "$here/../../../kernel/kbuild-env.sh"
kbuild_args "$@"
# Kbuild builds in the module's directory: a copy, so the source tree stays clean.
cp "$here"/Kbuild "$here"/i2c-plain-stub.c "$KB_OUT/kbuild/"
make -s -C "$KB_KDIR" M="$KB_OUT/kbuild" "${KB_CROSS[@]}" modules
cp "$KB_OUT/kbuild/i2c-plain-stub.ko" "$KB_OUT/i2c-plain-stub.ko"
echo "tests/vm/kmod/build.sh: $KB_OUT/i2c-plain-stub.ko ($(basename "$KB_KDIR"))" >&2
