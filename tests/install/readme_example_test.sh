#!/usr/bin/env bash
# The README's "Using the library" code, as written, against the installed package: installs
# the build into a prefix, makes a project of its own that finds polyrad with find_package,
# puts each ```cpp block of that section into main() (its #include lines above), builds it, runs
# it where scenes/ is the source tree's, and checks the operator file it writes.
#
#   readme_example_test.sh BUILD_DIR SOURCE_DIR OUT_DIR CXX_COMPILER [BUILD_TYPE]
set -euo pipefail
build="$1" source="$2" out="$3" cxx="$4" type="${5:-Release}"
show() { echo "readme example: $1 failed:" >&2; cat "$2" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out/app" "$out/run"
cmake --install "$build" --prefix "$out/prefix" > "$out/install.log" 2>&1 || show install "$out/install.log"
/usr/bin/python3 - "$source/README.md" "$out/app/main.cpp" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
if "## Using the library" not in text:
    sys.exit("readme example: README.md has no 'Using the library' section")
section = text.split("## Using the library", 1)[1].split("\n## ", 1)[0]
blocks = re.findall(r"```cpp\n(.*?)```", section, re.S)
if not blocks:
    sys.exit("readme example: no cpp block under 'Using the library'")
includes, bodies = [], []
for block in blocks:
    lines = block.splitlines()
    includes += [l for l in lines if l.startswith("#include")]
    bodies.append("\n".join(l for l in lines if not l.startswith("#include")))
with open(sys.argv[2], "w") as f:
    f.write("\n".join(dict.fromkeys(includes)) + "\n\nint main() {\n")
    for body in bodies:  # each block in a scope of its own, as a reader would run it
        f.write("  {\n" + body + "\n  }\n")
    f.write("  return 0;\n}\n")
PY
cat > "$out/app/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.16)
project(readme_example CXX)
find_package(polyrad REQUIRED)
add_executable(readme_example main.cpp)
target_link_libraries(readme_example PRIVATE polyrad::polyrad)
CMAKE
cmake -S "$out/app" -B "$out/app/build" -DCMAKE_BUILD_TYPE="$type" -DCMAKE_CXX_COMPILER="$cxx" \
  -DCMAKE_PREFIX_PATH="$out/prefix" > "$out/configure.log" 2>&1 || show configure "$out/configure.log"
cmake --build "$out/app/build" > "$out/build.log" 2>&1 || show build "$out/build.log"
ln -s "$source/scenes" "$out/run/scenes"
(cd "$out/run" && "$out/app/build/readme_example") > "$out/run.log" 2>&1 || show run "$out/run.log"
test -s "$out/run/scene.prt" || { echo "readme example: scene.prt was not written" >&2; exit 1; }
echo "readme example: built against $out/prefix, ran, wrote scene.prt ($(stat -c %s "$out/run/scene.prt") bytes)"
