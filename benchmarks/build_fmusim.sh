#!/usr/bin/env bash
# Build Reference-FMUs' fmusim from a source tree with Debian's libraries, out of that tree.
#
#     benchmarks/build_fmusim.sh SOURCE_DIR BUILD_DIR      ->  BUILD_DIR/fmusim
#
# SOURCE_DIR is a Reference-FMUs checkout that still has fmusim/ (it left the main branch; the
# last commit with it is the parent of 7b3fc08:
#     git --git-dir=<Reference-FMUs.git> archive 7b3fc08^ fmusim include src | tar -x -C SOURCE_DIR).
# Their CMake build downloads libxml2, zlib and CVode through ExternalProject and links them
# statically; without network we compile the same sources by hand against the system libraries.
# Nothing of their code is copied into this repository: the script only reads SOURCE_DIR.
set -euo pipefail

if [[ $# -ne 2 ]]; then
    echo "usage: $0 REFERENCE_FMUS_SOURCE_DIR BUILD_DIR" >&2
    exit 2
fi
source_dir=$(realpath "$1")
build_dir=$(realpath -m "$2")
[[ -f "$source_dir/fmusim/fmusim.c" ]] || { echo "no fmusim/fmusim.c in $source_dir" >&2; exit 2; }
case "$build_dir/" in
    "$source_dir"/*) echo "BUILD_DIR must lie outside SOURCE_DIR" >&2; exit 2 ;;
esac

# libminizip-dev provides zlib's contrib/minizip (unzip.h, ioapi.h) that their build compiles from
# the zlib source tree; libsundials-dev provides CVode (fmusim's model-exchange solver).
packages=(gcc libxml2-dev zlib1g-dev libminizip-dev libsundials-dev)
missing=()
for package in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [[ ${#missing[@]} -gt 0 ]]; then
    apt-get install -y "${missing[@]}"
fi

mkdir -p "$build_dir/obj"

sources=(
    src/FMI.c src/FMI1.c src/FMI2.c src/FMI3.c
    src/structured_variable_name.yy.c src/structured_variable_name.tab.c
    fmusim/csv.c fmusim/FMIUtil.c fmusim/FMIEuler.c fmusim/FMICVode.c
    fmusim/FMIModelDescription.c fmusim/FMIRecorder.c fmusim/FMIZip.c
    fmusim/FMISimulation.c fmusim/FMIStaticInput.c
    fmusim/FMI1CSSimulation.c fmusim/FMI1MESimulation.c
    fmusim/FMI2CSSimulation.c fmusim/FMI2MESimulation.c
    fmusim/FMI3CSSimulation.c fmusim/FMI3MESimulation.c
    fmusim/fmusim.c fmusim/miniunzip.c
)
# The last fmusim targets SUNDIALS 7 (SUN_COMM_NULL); Debian 12 ships 6.4, whose SUNContext_Create
# takes a plain void* communicator, for which NULL is the same "no MPI" value.
sundials_major=$(sed -n 's/^#define SUNDIALS_VERSION_MAJOR *\([0-9]*\).*/\1/p' /usr/include/sundials/sundials_config.h)
defines=(-DFMUSIM_VERSION='"Reference-FMUs-c8d4e6d (Debian libraries)"')
if [[ "${sundials_major:-7}" -lt 7 ]]; then
    defines+=(-DSUN_COMM_NULL=NULL)
fi
# Their sources pass T** where void** is declared (harmless, and the upstream build does the same);
# anything undeclared must still stop the build, since an implicit int return truncates pointers.
cflags=(-O2 -std=gnu11 -Wno-incompatible-pointer-types -Werror=implicit-function-declaration
        -I"$source_dir/fmusim" -I"$source_dir/include"
        -I/usr/include/libxml2 -I/usr/include/minizip
        "${defines[@]}")

objects=()
for source in "${sources[@]}"; do
    object="$build_dir/obj/$(basename "${source%.c}").o"
    gcc "${cflags[@]}" -c "$source_dir/$source" -o "$object"
    objects+=("$object")
done

# -lminizip stands in for the ioapi.c/unzip.c their build compiles from zlib's source tree.
gcc -o "$build_dir/fmusim" "${objects[@]}" \
    -lxml2 -lminizip -lz -lsundials_cvode -lsundials_nvecserial \
    -lsundials_sunmatrixdense -lsundials_sunlinsoldense -ldl -lm

"$build_dir/fmusim" --version
echo "built $build_dir/fmusim"
