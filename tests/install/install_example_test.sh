#!/usr/bin/env bash
# The library is embeddable: installs this build to a temporary prefix,
# builds examples/ against the installed package (find_package(SimplexDB)),
# and checks that the example's mesh is the one `simplexdb extract` gives,
# on a dense and on a sparse store. Checks the embedder surface too: no
# installed header includes LMDB's header or a wing's *_internal.h, and each
# installed header compiles on its own from the installed tree.
#
#   install_example_test.sh BUILD_DIR SOURCE_DIR GENERATOR
set -euo pipefail
build=$1 source=$2 generator=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"

include="$work/prefix/include/simplexdb"
leaks=$(cd "$include" && grep -rlE '#include [<"](lmdb\.h|storage/io/lmdb\.h|[^>"]*_internal\.h)' . || true)
if [[ -n "$leaks" ]]; then
  echo "installed headers that include lmdb.h or an internal header:" $leaks >&2
  exit 1
fi
if find "$include" -name '*_internal.h' -o -name lmdb.h | grep -q .; then
  echo "internal headers were installed:" $(find "$include" -name '*_internal.h' -o -name lmdb.h) >&2
  exit 1
fi
# Each header alone: what it needs, it includes. Boost, fmt and nlohmann are
# found where Debian puts them.
(cd "$include" && find . -name '*.h' | sed 's|^\./||' | sort) > "$work/headers"
echo "checking $(wc -l < "$work/headers") installed headers compile on their own"
xargs -P 2 -I{} sh -c 'echo "#include \"{}\"" |
  ${CXX:-c++} -std=c++20 -fsyntax-only -I "$1" -x c++ - 2> "$2/$(echo {} | tr / _).err" ||
  { cat "$2/$(echo {} | tr / _).err" >&2; echo "{} does not compile on its own" >&2; exit 255; }' \
  _ "$include" "$work" < "$work/headers"
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
