#!/usr/bin/env bash
# Build the runtime's C helpers into prolog_runtime/foreign/ and its Quick Load Files
# (run by setup.sh). Both are optional: when a C helper is missing, the runtime does the
# same work in Prolog, more slowly; a module without an up-to-date .qlf file is compiled
# from source when it is loaded (rtl_load.pl).
set -euo pipefail
cd "$(dirname "$0")/.."
eval "$(swipl --dump-runtime-variables)"
mkdir -p foreign
if command -v "${CC:-gcc}" >/dev/null 2>&1; then
    for src in c/*.c; do
        lib="foreign/$(basename "${src%.c}").${PLSOEXT}"
        if [ ! -f "$lib" ] || [ "$src" -nt "$lib" ]; then
            ${CC:-gcc} -O2 -Wall -shared -fPIC -I"$PLBASE/include" -o "$lib" "$src"
            echo "setup: built prolog_runtime/$lib" >&2
        fi
    done
else
    echo "setup: no C compiler: the runtime reads event lines in Prolog (slower)" >&2
fi
# Quick Load Files of the runtime modules, next to their sources, where SWI-Prolog looks
# for them. Not for the files a program or the Python driver loads first (retalis.pl,
# rtl_aq.pl, rtl_aq_api.pl) and rtl_load.pl: they check, at each start, that the others are
# up to date.
for src in rtl_*.pl; do
    case "$src" in rtl_load.pl|rtl_aq.pl|rtl_aq_api.pl) rm -f "${src%.pl}.qlf"; continue ;; esac
    qlf="${src%.pl}.qlf"
    if [ ! -f "$qlf" ] || [ "$src" -nt "$qlf" ] || [ "$(command -v swipl)" -nt "$qlf" ]; then
        if swipl -q -g "qcompile('${src%.pl}')" -t halt >/dev/null 2>&1 </dev/null; then
            echo "setup: compiled prolog_runtime/$qlf" >&2
        else
            rm -f "$qlf"
            echo "setup: warning: cannot compile prolog_runtime/$src into a .qlf file (it is loaded from source)" >&2
        fi
    fi
done
