#!/usr/bin/env bash
# Install the Debian libraries that gmsh's wheel (OpenGL, X cursor/fonts) and off-screen PyVista (EGL) load,
# the SuiteSparse headers that scikit-sparse (CHOLMOD) builds against, and an optimised BLAS for CHOLMOD (and
# CalculiX) instead of Debian's reference libblas3 (7x faster supernodal factorisation here), and CalculiX (ccx),
# the FE stage's cross-check in the tests, when any is missing.
# Uses sudo where not root. Prints what it does.
set -euo pipefail
libraries=(libGLU.so.1 libGL.so.1 libXcursor.so.1 libXinerama.so.1 libXft.so.2 libEGL.so.1)
packages=(libglu1-mesa libgl1 libxcursor1 libxinerama1 libxft2 libegl1)
missing=()
for i in "${!libraries[@]}"; do
  ldconfig -p | grep -q "${libraries[$i]}" || missing+=("${packages[$i]}")
done
[ -f /usr/include/suitesparse/cholmod.h ] || missing+=(libsuitesparse-dev)
ldconfig -p | grep -q libopenblas.so.0 || missing+=(libopenblas0-serial)
command -v ccx > /dev/null || missing+=(calculix-ccx)
[ ${#missing[@]} -eq 0 ] && exit 0
echo "installing Debian packages: ${missing[*]}"
sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
$sudo apt-get update -q
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
