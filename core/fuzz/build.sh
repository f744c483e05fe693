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
# compiled as the library is (-ffp-contract=off). --lenient-aux and --control-tamper: see
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
flags=(-std=c99 -g -O1 -fno-omit-frame-pointer -ffp-contract=off -Wall -Wextra -Werror
       -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all "-I$core/include")
targets="${TARGETS:-exact patent nd cc rr filter filter_cycle}"
for target in $targets; do
    case "$target" in
        exact | patent) src=("$core/src/velfence_core.c") ;;
        nd) src=("$core/src/velfence_nd.c" "$core/src/velfence_core.c") ;;
        cc) src=("$core/src/velfence_cc.c" "$core/src/velfence_core.c") ;;
        rr) src=("$core/src/velfence_rr.c" "$core/src/velfence_nd.c") ;;
        filter) src=("$core/src/velfence_nd.c" "$core/src/velfence_core.c") ;;
        filter_cycle) src=("$core/src/velfence_filter.c" "$core/src/velfence_nd.c") ;;
        *) echo "build.sh: unknown target $target" >&2; exit 2 ;;
    esac
    "$cc" "${flags[@]}" ${extra[@]+"${extra[@]}"} "$here/fuzz_$target.c" "${src[@]}" \
        -lm -o "$out/fuzz_$target"
done
echo "built in $out: $targets"
