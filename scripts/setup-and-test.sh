#!/usr/bin/env bash
# Installs everything the test suite needs on a fresh Debian/Ubuntu machine and runs it:
#   the ODE C library (Debian package libode8, used through ctypes),
#   vrcal with its test, engine, video, audio and excel extras (pytest, pytest-xdist, hypothesis, Sybil,
#   MuJoCo, PyBullet, OpenCV for 'vrcal track' on videos, PyAV for compressed sound files, openpyxl and
#   xlrd for phyphox's Excel exports),
#   then the whole test suite, on every core (pytest-xdist; a file's tests in one process, since a
#   document's console examples follow one another): about 5 minutes on 2 cores, 9 on one.
# Run it inside a virtual environment (see README.md).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ldconfig -p 2>/dev/null | grep -q 'libode\.so'; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libode8
fi
python -m pip install --quiet --upgrade pip
python -m pip install --quiet ".[test,engines,video,audio,excel]"
python -m pytest -q -n auto --dist loadfile "$@"
