#!/usr/bin/env bash
# Vendor KaTeX for the model viewer's "Closed form" panel (app/static/viewer/).
#
# The viewer page loads no external URL (no CDN): katex.min.js, katex.min.css and the
# woff2 fonts its stylesheet names are copied from the `katex` package of the npm registry
# into app/static/viewer/vendor/katex/, together with the package's LICENSE, and committed.
# Run this script to update them:
#
#     scripts/vendor_katex.sh            # the version pinned below
#     scripts/vendor_katex.sh 0.19.1     # another version (then update KATEX_VERSION)
#
# Needs `npm` (Node.js). It installs into a temporary directory and touches nothing else
# than app/static/viewer/vendor/katex/. Only the woff2 fonts are copied: every browser that
# runs the viewer (ES modules, import maps) takes woff2, the first source of each @font-face.
set -euo pipefail

KATEX_VERSION="${1:-0.19.1}"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DEST="$ROOT/app/static/viewer/vendor/katex"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

cd "$TMP"
npm init -y >/dev/null
npm install --no-audit --no-fund --ignore-scripts --silent "katex@$KATEX_VERSION"
PKG="$TMP/node_modules/katex"

rm -rf "$DEST"
mkdir -p "$DEST/fonts"
cp "$PKG/dist/katex.min.js" "$PKG/dist/katex.min.css" "$DEST/"
cp "$PKG"/dist/fonts/*.woff2 "$DEST/fonts/"
cp "$PKG/LICENSE" "$DEST/LICENSE"
cat > "$DEST/README.md" <<NOTE
KaTeX $KATEX_VERSION (MIT licence, see LICENSE), copied from the npm package \`katex\`
by scripts/vendor_katex.sh (katex.min.js, katex.min.css, fonts/*.woff2). Do not edit these
files; rerun the script to update them. The viewer loads katex.min.js as a classic script
(it defines \`window.katex\`) and renders with \`katex.render\` (DOM nodes, so the page's
Content-Security-Policy needs no inline styles).
NOTE
echo "vendored katex@$KATEX_VERSION into $DEST:"
(cd "$DEST" && find . -type f | sort)
