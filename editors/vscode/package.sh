#!/usr/bin/env bash
# Package the VS Code extension as build/vscode/fmionnx-<version>.vsix (or into the folder given
# as the first argument). The extension is assembled in a scratch folder, so no node_modules or
# .vsix ever lands in the source tree; build/ is git-ignored. Needs Node.js (npm, npx) and the
# npm registry: it installs vscode-languageclient and runs @vscode/vsce.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="$(mkdir -p "${1:-$here/../../build/vscode}" && cd "${1:-$here/../../build/vscode}" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

cp "$here/package.json" "$here/extension.js" "$here/README.md" "$here/.vscodeignore" "$work/"
cd "$work"
npm install --omit=dev --no-audit --no-fund --loglevel=error
npx --yes @vscode/vsce@3 package --skip-license --out "$out/"
ls "$out"/*.vsix
