#!/usr/bin/env bash
# The Python package works from where `cmake --install` puts it, with nothing
# of the build tree: installs the python component of this build to a
# temporary prefix under the build tree, checks that the installed
# _simplexdb names no build-tree path (RPATH/RUNPATH; the SimplexDB
# libraries are static, linked in), then imports the package with Debian's
# python3 from PREFIX/SITE only, opens a store and extracts a mesh that is
# the one `simplexdb extract` gives.
#
#   python_install_test.sh BUILD_DIR SITE CLI
#     SITE: the package's folder under the prefix, lib/python3.<minor>/dist-packages
set -euo pipefail
build=$1 site=$2 cli=$3
work=$(mktemp -d "$build/python-install.XXXXXX")
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --component python --prefix "$work/prefix" > "$work/install.log"
package="$work/prefix/$site/simplexdb"
ls "$package"/__init__.py "$package"/_simplexdb*.so > /dev/null
module=$(ls "$package"/_simplexdb*.so)
if readelf -d "$module" | grep -E 'R(UN)?PATH' | grep -F "$(cd "$build" && pwd -P)"; then
  echo "$module: its RPATH names the build tree" >&2
  exit 1
fi
if ldd "$module" | grep -E 'not found|'"$(cd "$build" && pwd -P)"; then
  echo "$module: a library it needs is missing or in the build tree" >&2
  exit 1
fi
"$cli" generate --field perlin --dims 21,17,13 --type uint8 -q -o "$work/p.nrrd"
"$cli" import "$work/p.nrrd" -o "$work/p.sdb" -q
want=$("$cli" extract "$work/p.sdb" --error 3% --format json |
       /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["simplices"])')
# Run from an empty folder, with only the prefix on the path: the build
# tree's package cannot be picked up by accident.
cd "$work"
env -u PYTHONHOME PYTHONPATH="$work/prefix/$site" PYTHONNOUSERSITE=1 /usr/bin/python3 - "$work/p.sdb" "$package" "$want" <<'PY'
import os, sys
import simplexdb
store_path, package, want = sys.argv[1], sys.argv[2], int(sys.argv[3])
where = os.path.dirname(os.path.realpath(simplexdb.__file__))
assert where == os.path.realpath(package), f"imported {where}, not the installed {package}"
assert os.path.dirname(os.path.realpath(simplexdb._simplexdb.__file__)) == where
store = simplexdb.open(store_path)
assert store.dims == (21, 17, 13), store.dims
mesh = store.extract("3%")
assert len(mesh.codes) == want > 0, (len(mesh.codes), want)
assert len(mesh.cells) > 0 and mesh.points.shape[1] == 3
print(f"installed package {where}: {len(mesh.codes)} simplices, as simplexdb extract")
PY
