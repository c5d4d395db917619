#!/usr/bin/env bash
# The library is embeddable: installs this build to a temporary prefix,
# builds examples/ against the installed package (find_package(SimplexDB)),
# and checks that the example's mesh is the one `simplexdb extract` gives,
# on a dense and on a sparse store.
#
#   install_example_test.sh BUILD_DIR SOURCE_DIR GENERATOR
set -euo pipefail
build=$1 source=$2 generator=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$source/examples" -B "$work/example" -G "$generator" \
      -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log"
cmake --build "$work/example" > "$work/build.log"
simplexdb="$work/prefix/bin/simplexdb"
"$simplexdb" generate --field perlin --dims 33,33,33 -q -o "$work/p.nrrd"
"$simplexdb" import "$work/p.nrrd" -o "$work/p.sdb" -q
"$simplexdb" import "$work/p.nrrd" --sparse -o "$work/p.lmdb" -q
for store in p.sdb p.lmdb; do
  got=$("$work/example/extract_mesh" "$work/$store" 2% |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["simplices"])')
  want=$("$simplexdb" extract "$work/$store" --error 2% --format json |
         python3 -c 'import json,sys; print(json.load(sys.stdin)["simplices"])')
  echo "$store: the example extracted $got simplices, simplexdb extract $want"
  [[ "$got" == "$want" && "$got" -gt 0 ]]
done
