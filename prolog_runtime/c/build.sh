#!/usr/bin/env bash
# Build the runtime's C helpers into prolog_runtime/foreign/ (run by setup.sh). They are
# optional: when one is missing, the runtime does the same work in Prolog, more slowly.
set -euo pipefail
cd "$(dirname "$0")/.."
eval "$(swipl --dump-runtime-variables)"
mkdir -p foreign
for src in c/*.c; do
    lib="foreign/$(basename "${src%.c}").${PLSOEXT}"
    if [ ! -f "$lib" ] || [ "$src" -nt "$lib" ]; then
        ${CC:-gcc} -O2 -Wall -shared -fPIC -I"$PLBASE/include" -o "$lib" "$src"
        echo "setup: built prolog_runtime/$lib" >&2
    fi
done
