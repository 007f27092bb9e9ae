#!/usr/bin/env bash
# Install what retalisc needs on a fresh Debian machine: SWI-Prolog (apt), a virtualenv in
# .venv, and the package with its test and benchmark extras (pip). Safe to run again.
set -euo pipefail
cd "$(dirname "$0")"

if ! command -v swipl >/dev/null 2>&1; then
    echo "setup: installing SWI-Prolog (apt-get install swi-prolog-nox)" >&2
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq swi-prolog-nox >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv" >&2
    python3 -m venv .venv
fi
.venv/bin/python -m pip install -q --disable-pip-version-check -e '.[test,bench]'
if command -v "${CC:-gcc}" >/dev/null 2>&1; then
    bash prolog_runtime/c/build.sh
else
    echo "setup: no C compiler: the runtime reads event lines in Prolog (slower)" >&2
fi
echo "setup: ready ($(swipl --version), $(.venv/bin/python --version))" >&2
