#!/usr/bin/env bash
# Headless Chromium for the report page test (tests/report_page.rs) and for
# looking at a report page by hand:
#
#   scripts/chromium.sh      install Debian's `chromium` package when no
#                            chromium is on PATH; prints the browser's path as
#                            its last line
#
# Exit codes: 0 ready (path printed); 3 Chromium cannot be installed here (not
# root, no apt-get, or apt could not fetch the package, e.g. no network): the
# caller may skip, and the reason is on stderr; 1 anything else.
set -euo pipefail

log() { echo "chromium.sh: $*" >&2; }

find_browser() {
    command -v chromium || command -v chromium-browser || true
}

browser="$(find_browser)"
if [[ -n "$browser" ]]; then
    echo "$browser"
    exit 0
fi
if [[ "$(id -u)" != 0 ]]; then
    log "cannot install chromium: not root (install Debian's chromium package yourself)"
    exit 3
fi
if ! command -v apt-get >/dev/null; then
    log "cannot install chromium: no apt-get on this machine"
    exit 3
fi
log "installing chromium (Debian package)"
export DEBIAN_FRONTEND=noninteractive
if ! apt-get update -qq >&2; then
    log "cannot install chromium: apt-get update failed (no network?)"
    exit 3
fi
if ! apt-get install -y -qq --no-install-recommends chromium >&2; then
    log "cannot install chromium: apt-get install chromium failed (no network, or no such package)"
    exit 3
fi
browser="$(find_browser)"
if [[ -z "$browser" ]]; then
    log "chromium installed but not on PATH"
    exit 1
fi
echo "$browser"
