#!/usr/bin/env bash
# Vendor three.js for the model viewer (app/static/viewer/).
#
# The viewer page loads no external URL (no CDN): the few ES module files it needs are
# copied from the `three` package of the npm registry into app/static/viewer/vendor/,
# together with the package's LICENSE, and committed. Run this script to update them:
#
#     scripts/vendor_threejs.sh            # the version pinned below
#     scripts/vendor_threejs.sh 0.187.0    # another version (then update THREE_VERSION)
#
# Needs `npm` (Node.js). It installs into a temporary directory and touches nothing else
# than app/static/viewer/vendor/. The page's import map (app/static/viewer/index.html)
# maps `three` to vendor/three.module.js and `three/addons/` to vendor/addons/.
set -euo pipefail

THREE_VERSION="${1:-0.187.0}"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DEST="$ROOT/app/static/viewer/vendor"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

cd "$TMP"
npm init -y >/dev/null
npm install --no-audit --no-fund --ignore-scripts --silent "three@$THREE_VERSION"
PKG="$TMP/node_modules/three"

# only three.js's own files: vendor/katex/ belongs to scripts/vendor_katex.sh
rm -rf "$DEST/addons" "$DEST/three.module.js" "$DEST/three.core.js" "$DEST/LICENSE" "$DEST/README.md"
mkdir -p "$DEST/addons/controls"
cp "$PKG/build/three.module.js" "$DEST/"
# Since r16x three.module.js re-exports from three.core.js; copy it when present.
if [ -f "$PKG/build/three.core.js" ]; then
    cp "$PKG/build/three.core.js" "$DEST/"
fi
cp "$PKG/examples/jsm/controls/OrbitControls.js" "$DEST/addons/controls/"
# The IK target gizmo (a translate / rotate handle on the selected link).
cp "$PKG/examples/jsm/controls/TransformControls.js" "$DEST/addons/controls/"
# The mesh loaders of the robot's visuals (STL, Collada, OBJ) and what they import: the
# Collada loader's parser and composer, and the TGA loader for Collada textures.
mkdir -p "$DEST/addons/loaders/collada"
for f in STLLoader.js ColladaLoader.js OBJLoader.js TGALoader.js collada/ColladaParser.js collada/ColladaComposer.js; do
    cp "$PKG/examples/jsm/loaders/$f" "$DEST/addons/loaders/$f"
done
cp "$PKG/LICENSE" "$DEST/LICENSE"
cat > "$DEST/README.md" <<NOTE
three.js $THREE_VERSION (MIT licence, see LICENSE), copied from the npm package \`three\`
by scripts/vendor_threejs.sh. Do not edit these files; rerun the script to update them.
NOTE
# The addons import only 'three' (which the import map resolves) and each other by relative
# paths, kept as in the package: no rewriting is needed.
echo "vendored three@$THREE_VERSION into $DEST:"
(cd "$DEST" && find . -path ./katex -prune -o -type f -print | sort)
