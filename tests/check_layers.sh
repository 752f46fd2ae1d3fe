#!/usr/bin/env bash
# Checks that the layers point one way: nothing under src/scene, src/io, src/accel or kernels/
# includes a header of src/integrators or src/apps. Prints each such include as FILE:LINE and
# fails. Arguments: the source folder, then the folders to check (the four by default).
set -euo pipefail
root=$1
shift
folders=("$@")
[ ${#folders[@]} -gt 0 ] || folders=(src/scene src/io src/accel kernels)
cd "$root"
for f in "${folders[@]}"; do
    [ -d "$f" ] || { echo "check_layers: no folder $root/$f" >&2; exit 2; }
done
# (any spelling of the path: "integrators/x.h", "src/apps/x.h", "../integrators/x.h")
pattern='^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]([^">]*/)?(integrators|apps)/'
found=$(grep -rnE --include='*.h' --include='*.cpp' "$pattern" "${folders[@]}" || true)
if [ -n "$found" ]; then
    while IFS= read -r hit; do
        file=${hit%%:*}
        rest=${hit#*:}
        echo "$file:${rest%%:*}: includes a higher layer (src/integrators, src/apps): ${rest#*:}"
    done <<<"$found"
    exit 1
fi
echo "check_layers: no include from ${folders[*]} points up"
