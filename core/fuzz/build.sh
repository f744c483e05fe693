#!/usr/bin/env bash
# Builds the libFuzzer targets of the compiled core (fuzz_exact, fuzz_patent: the 2-D laws;
# fuzz_nd: the n-D law and projection; fuzz_cc: configuration control; fuzz_rr: the resolved-rate
# SR step; fuzz_filter: the safety filter's row helpers; fuzz_filter_cycle: its whole cycle).
#
#   core/fuzz/build.sh [OUT_DIR] [--lenient-aux] [--control-tamper]   (default OUT_DIR: core/fuzz/build)
#
# TARGETS="exact" builds only that one (default: "exact patent nd cc rr filter filter_cycle").
# clang with libFuzzer, AddressSanitizer and UBSan (Debian: clang, libclang-rt-14-dev); CC
# overrides the compiler. Every sanitizer finding aborts (-fno-sanitize-recover=all). The core is
# compiled as the library is (-ffp-contract=off), once per build (OBJ_DIR, below). --lenient-aux and --control-tamper: see
# VF_FUZZ_STRICT_AUX_DISTANCES and VF_FUZZ_CONTROL_TAMPER in fuzz_common.h (fuzz_nd.c, fuzz_cc.c,
# fuzz_rr.c and fuzz_filter.c: their own VF_FUZZ_CONTROL_TAMPER; they ignore --lenient-aux).
# Run one:  OUT_DIR/fuzz_exact -seed=1 -max_total_time=60 OUT_DIR/corpus-exact core/fuzz/corpus/exact
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
core="$(dirname "$here")"
out="${1:-$here/build}"
extra=()
for arg in "${@:2}"; do
    case "$arg" in
        --strict-aux) extra+=(-DVF_FUZZ_STRICT_AUX_DISTANCES=1) ;;
        --lenient-aux) extra+=(-DVF_FUZZ_STRICT_AUX_DISTANCES=0) ;;
        --control-tamper) extra+=(-DVF_FUZZ_CONTROL_TAMPER=1) ;;
        *) echo "build.sh: unknown option $arg" >&2; exit 2 ;;
    esac
done
cc="${CC:-clang}"
mkdir -p "$out"
warn=(-std=c99 -g -O1 -fno-omit-frame-pointer -ffp-contract=off -Wall -Wextra -Werror
      -fno-sanitize-recover=all "-I$core/include")
# The core's sources are compiled once per build (instrumented for the fuzzer, not linked with
# its main), then linked into each target: five objects instead of fourteen compilations. The
# options only change the targets' own sources (VF_FUZZ_* in fuzz_common.h and the fuzz_*.c).
# OBJ_DIR (default OUT_DIR/obj) may be shared by several builds: an object is rebuilt only when
# its source or a header is newer.
obj="${OBJ_DIR:-$out/obj}"
mkdir -p "$obj"
core_obj() {
    local name="$1" src="$core/src/$1.c" o="$obj/$1.o"
    if [[ ! -f "$o" || "$src" -nt "$o" || -n "$(find "$core/include" -newer "$o" -print -quit)" ]]; then
        "$cc" "${warn[@]}" -fsanitize=fuzzer-no-link,address,undefined -c "$src" -o "$o.tmp.$$"
        mv "$o.tmp.$$" "$o"
    fi
    echo "$o"
}
targets="${TARGETS:-exact patent nd cc rr filter filter_cycle}"
for target in $targets; do
    case "$target" in
        exact | patent) srcs=(velfence_core) ;;
        nd | filter) srcs=(velfence_nd velfence_core) ;;
        cc) srcs=(velfence_cc velfence_core) ;;
        rr) srcs=(velfence_rr velfence_nd) ;;
        filter_cycle) srcs=(velfence_filter velfence_nd) ;;
        *) echo "build.sh: unknown target $target" >&2; exit 2 ;;
    esac
    objs=()
    for s in "${srcs[@]}"; do objs+=("$(core_obj "$s")"); done
    "$cc" "${warn[@]}" -fsanitize=fuzzer,address,undefined ${extra[@]+"${extra[@]}"} \
        "$here/fuzz_$target.c" "${objs[@]}" -lm -o "$out/fuzz_$target"
done
echo "built in $out: $targets"
