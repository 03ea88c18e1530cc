#!/usr/bin/env bash
# Install everything unseeable needs on a fresh Debian machine: system packages
# (apt, when run as root) and the package itself with its test tools.
set -euo pipefail
cd "$(dirname "$0")/.."

# System packages, each optional: a failure to install one is a warning, not fatal.
# - libllvm19: Mitsuba's fast `llvm_ad_rgb` variant needs Debian's libLLVM; without it
#   the renderer falls back to the slower `scalar_rgb`.
# - chromium: headless Chromium, in which the tests check the estimate page
#   (`unseeable view`) draws without script errors; without it those tests are skipped.
APT_PACKAGES="libllvm19 chromium"
apt_note() {
    case "$1" in
        libllvm19) echo "rendering will use scalar_rgb" ;;
        chromium) echo "the browser tests of the estimate page will be skipped" ;;
    esac
}
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = "0" ]; then
    missing=""
    for pkg in $APT_PACKAGES; do
        dpkg -s "$pkg" >/dev/null 2>&1 || missing="$missing $pkg"
    done
    if [ -n "$missing" ]; then
        echo "setup: installing system packages:$missing"
        apt-get update -qq || echo "setup: warning: apt-get update failed"
        for pkg in $missing; do
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$pkg" \
                || echo "setup: warning: could not install $pkg; $(apt_note "$pkg")"
        done
    fi
else
    echo "setup: not root or no apt-get; skipping system packages ($APT_PACKAGES)"
fi

python -m pip install --quiet --disable-pip-version-check -e ".[dev]"
# An editable install leaves the package's modules uncompiled; where
# PYTHONDONTWRITEBYTECODE is set (as in many containers) every command would compile
# them again on start (about 0.06 s of each `unseeable` run here, 2026-12-07).
python -m compileall -q src/unseeable >/dev/null || echo "setup: warning: could not precompile src/unseeable"
command -v pyenv >/dev/null 2>&1 && pyenv rehash || true
echo "setup: done ($(python -c 'import unseeable; print("unseeable", unseeable.__version__)'))"
