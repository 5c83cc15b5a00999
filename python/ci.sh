#!/usr/bin/env bash
# The Python package's part of `.ci/run`, in two steps around the workspace build:
#   python/ci.sh venv   makes the virtual environment (maturin, numpy, pytest, nibabel) and
#                       prints its interpreter: .ci/run exports it as PYO3_PYTHON before
#                       `cargo build`, so the workspace build compiles pyo3 for the interpreter
#                       maturin uses afterwards and maturin finds everything built;
#   python/ci.sh test   builds and installs the package with maturin from that release build
#                       (same target/ and profile: only the extension is linked again) and runs
#                       its tests on the software adapter.
# VRSC_PYTHON_VENV names the environment's folder (default python/.venv).
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${VRSC_PYTHON_VENV:-python/.venv}"

case "${1:-}" in
venv)
    if ! command -v python3 >/dev/null 2>&1; then
        echo "python3 is required for the Python package's tests" >&2
        exit 2
    fi
    if [ ! -x "$venv/bin/python" ]; then
        python3 -m venv "$venv" >&2
    fi
    "$venv/bin/pip" install -q --disable-pip-version-check "maturin==1.16.0" numpy pytest nibabel >&2
    echo "$(cd "$venv" && pwd)/bin/python"
    ;;
test)
    echo "== Python package (python/): maturin develop --release, pytest ==" >&2
    start=$SECONDS
    VIRTUAL_ENV="$(cd "$venv" && pwd)" "$venv/bin/maturin" develop --release --manifest-path python/Cargo.toml >&2
    echo "(package built and installed in $((SECONDS - start)) s)" >&2
    VRS_ADAPTER=software "$venv/bin/python" -m pytest -q python/tests
    ;;
*)
    echo "usage: python/ci.sh venv|test" >&2
    exit 2
    ;;
esac
