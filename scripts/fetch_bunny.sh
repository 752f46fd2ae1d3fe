#!/usr/bin/env bash
# Fetches the Stanford bunny (npm package "bunny": 1,839 vertices, 3,674 triangles) and writes
# it as OUT_DIR/bunny.ply, binary little-endian. Does nothing if that file already exists.
# Usage: scripts/fetch_bunny.sh OUT_DIR      (needs npm and node)
set -euo pipefail

if [[ $# -ne 1 ]]; then
    echo "usage: $0 OUT_DIR" >&2
    exit 2
fi
out_dir=$1
out=$out_dir/bunny.ply
if [[ -e $out ]]; then
    exit 0
fi
for tool in npm node tar; do
    command -v "$tool" >/dev/null || { echo "$0: '$tool' is needed but not installed" >&2; exit 1; }
done
mkdir -p "$out_dir"

work=$(mktemp -d)
tmp_out=""
cleanup() {
    rm -rf "$work"
    if [[ -n $tmp_out ]]; then rm -f "$tmp_out"; fi
}
trap cleanup EXIT

# Download and unpack the package (pinned: its data has not changed since 2013).
(cd "$work" && npm pack bunny@1.0.1 --silent >/dev/null)
tar -xzf "$work"/bunny-1.0.1.tgz -C "$work"

# Convert positions/cells to PLY in a temporary file beside the output, then move it in place.
tmp_out=$(mktemp "$out_dir/.bunny.ply.XXXXXX")
node - "$work/package/index.js" "$tmp_out" <<'EOF'
const fs = require('fs');
const [source, target] = process.argv.slice(2);
const { positions, cells } = require(source);
if (positions.length !== 1839 || cells.length !== 3674) {
    throw new Error(`unexpected bunny: ${positions.length} vertices, ${cells.length} cells`);
}
const header = [
    'ply',
    'format binary_little_endian 1.0',
    'comment Stanford Bunny, Stanford 3D Scanning Repository',
    'comment (graphics.stanford.edu/data/3Dscanrep), via the npm package bunny 1.0.1',
    `element vertex ${positions.length}`,
    'property float x',
    'property float y',
    'property float z',
    `element face ${cells.length}`,
    'property list uchar int vertex_indices',
    'end_header',
    '',
].join('\n');
const body = Buffer.alloc(positions.length * 12 + cells.length * 13);
let at = 0;
for (const p of positions) {
    if (p.length !== 3 || !p.every(Number.isFinite)) throw new Error(`bad vertex ${p}`);
    for (const c of p) at = body.writeFloatLE(c, at);
}
for (const cell of cells) {
    if (cell.length !== 3) throw new Error(`cell ${cell} is not a triangle`);
    at = body.writeUInt8(3, at);
    for (const i of cell) {
        if (!Number.isInteger(i) || i < 0 || i >= positions.length) {
            throw new Error(`cell ${cell} has a bad index`);
        }
        at = body.writeInt32LE(i, at);
    }
}
fs.writeFileSync(target, Buffer.concat([Buffer.from(header, 'ascii'), body]));
EOF
chmod 644 "$tmp_out"
mv "$tmp_out" "$out"
tmp_out=""
echo "wrote $out"
