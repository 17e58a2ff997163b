#!/usr/bin/env bash
# supermat.h's MSVC branch: the x86-64 kernels without GCC target attributes, the CPU read with __cpuidex and
# _xgetbv (<intrin.h>), run-time dispatch as on Linux. No cl.exe and no Windows SDK here, so two stand-ins:
#
# 1. Compiled (needs clang-cl, Debian's clang-cl-14, and MinGW-w64's headers; else exit 77): tests/msvc/msvc_impl.c
#    (supermat.h's and supermat_uv.h's implementations) by clang-cl --target=x86_64-pc-windows-msvc, /W4 /WX
#    /O2, as C (/TC) and as C++ (/TP), to an object file (no link). clang-cl defines _MSC_VER but also
#    __clang__, which would take the GCC / clang branch (target attributes, <cpuid.h>), so the test-only macro
#    SUPERMAT__FORCE_MSVC_PATHS takes MSVC's; the -m flags below give clang what MSVC has without any flag (every
#    intrinsic usable in any function). msvc_impl.c #errors unless the preprocessor took that branch with every
#    kernel (AVX2, AVX-512 F / BF16 / VNNI, AVX-VNNI), AMX off and the Win32 pool, and the object must hold
#    their instructions (vdpbf16ps, vpdpbusd, vcvtne2ps2bf16, cpuid, xgetbv). Headers: MinGW-w64's C and
#    Windows headers, read through tests/msvc/mingw_as_msvc.h (/FI; see there), and clang's own intrinsic
#    headers. Checked: the MSVC spellings (__forceinline, __declspec(noinline), no __m512bh casts, __cpuidex,
#    _xgetbv) and warning-free /W4 in both languages. Also compiled (C, /W4 /WX): tests/supermat_impl.c by
#    plain clang-cl, no -m flags and no forcing, as a clang-cl user builds it (the clang branch). NOT checked:
#    Microsoft's own headers (their intrinsic prototypes and types: __m512bh as a typedef of __m512i there is
#    assumed; clang-cl converts the integer vectors implicitly), cl.exe's front end and code generation, a
#    link against the Windows SDK.
#
# 2. Run (when WINE is "ON", x86_64-w64-mingw32-gcc and wine64 are there and the CPU has AVX2; else said and
#    skipped): the same branch compiled by MinGW-w64 gcc with SUPERMAT__FORCE_MSVC_PATHS and the -m flags of
#    the ISAs this CPU has (SUPERMAT_NO_AVX512 / SUPERMAT_NO_AVXVNNI for the rest), -Wall -Wextra -pedantic
#    -Werror, linked static, run under wine: test_kernels (every kernel the CPU has against float64, the
#    AVX-512 = AVX2 bits, bf16 and int8 compute, AVX-VNNI = AVX512_VNNI bits), test_win32 (supermat_cpu()
#    through __cpuidex / _xgetbv equals the Linux build's <cpuid.h> answer, the AVX-512 or AVX2 kernel
#    picked, the Win32 pool, 1 thread = 3 threads bit for bit) and the tiny single-view goldens (auto kernel,
#    2 threads, Linux bounds). So the attribute-free kernel sources are numerically right, not only
#    compilable. Unlike MSVC, gcc then may use those ISAs in the scalar code too (MSVC keeps it SSE2 without
#    /arch), and with -mavx512vl the AVX-VNNI kernel's vpdpbusd may be EVEX-encoded: a CPU without AVX-512
#    could not run this build, which is why the flags follow this CPU.
# usage: test_msvc.sh WORKDIR SRC WINE(ON|OFF) DATA TINY   (exit 77 = skipped: no clang-cl or MinGW headers)
set -euo pipefail
work=$1 src=$2 wine_on=$3 data=$4 tiny=$5
mkdir -p "$work"
cl=$(command -v clang-cl-14 || command -v clang-cl || true)
inc=""
for d in /usr/x86_64-w64-mingw32/include /usr/share/mingw-w64/include; do [ -f "$d/windows.h" ] && { inc=$d; break; }; done
if [ -z "$cl" ] || [ -z "$inc" ]; then
  echo "SKIP: needs clang-cl and MinGW-w64's headers (Debian: clang-14, mingw-w64-x86-64-dev)"
  exit 77
fi
isa=(-mavx2 -mfma -mf16c -mavx512f -mavx512bw -mavx512vl -mavx512vnni -mavx512bf16 -mavxvnni)
# USE_NO_MINGW_SETJMP_TWO_ARGS: MinGW's setjmp.h would declare _setjmp unlike clang's intrin.h
cflags=(--target=x86_64-pc-windows-msvc /nologo /W4 /WX /O2 /c "${isa[@]}" /DSUPERMAT__FORCE_MSVC_PATHS
        /DUSE_NO_MINGW_SETJMP_TWO_ARGS /imsvc "$inc" "/FI$src/tests/msvc/mingw_as_msvc.h")
for lang in TC TP; do
  echo "== $cl /$lang /W4 /WX: tests/msvc/msvc_impl.c"
  "$cl" "${cflags[@]}" "/$lang" "/Fo$work/msvc_impl_$lang.obj" -- "$src/tests/msvc/msvc_impl.c"
done
objdump=$(command -v llvm-objdump-14 || command -v llvm-objdump || command -v objdump || true)
if [ -n "$objdump" ]; then
  dis=$("$objdump" -d "$work/msvc_impl_TC.obj")
  for insn in vdpbf16ps vpdpbusd vcvtne2ps2bf16 vfmadd231ps cpuid xgetbv; do
    n=$(grep -cE "[[:space:]]$insn([[:space:]]|$)" <<<"$dis" || true)
    [ "$n" -gt 0 ] || { echo "FAIL: no $insn in the MSVC-branch object"; exit 1; }
    echo "  $insn: $n"
  done
else
  echo "note: no objdump: the object's instructions not checked"
fi
# clang-cl as users build with it (no -m flags, no forcing): the clang branch, target attributes, <cpuid.h>
echo "== $cl /TC /W4 /WX, no -m flags: tests/supermat_impl.c (the clang branch)"
"$cl" --target=x86_64-pc-windows-msvc /nologo /W4 /WX /O2 /c /TC /DUSE_NO_MINGW_SETJMP_TWO_ARGS /imsvc "$inc" \
  "/FI$src/tests/msvc/mingw_as_msvc.h" "/Fo$work/clang_cl_impl.obj" -- "$src/tests/supermat_impl.c"
echo "msvc: the MSVC branch compiles warning-free (/W4 /WX) as C and C++ (clang-cl, MSVC mode); plain clang-cl too"

# Windows on ARM64 (clang's MinGW target, MinGW-w64's headers, which build for ARM64 only in GNU mode here):
# tests/msvc/woa_impl.c, both implementations, #errors unless the NEON passes and the Win32 pool were taken; the
# object must hold NEON arithmetic (fmla on .4s) and call the Win32 threads. Compiled, not run (no ARM64 wine here).
clang=$(command -v clang-14 || command -v clang || true)
clang_inc=$("${clang:-false}" -print-resource-dir 2>/dev/null || true)/include
if [ -n "$clang" ] && [ -f "$clang_inc/arm_neon.h" ]; then
  for lang in "c -std=c99" "c++ -std=c++11"; do
    echo "== $clang --target=aarch64-w64-mingw32 -x $lang -Wall -Wextra -pedantic -Werror: tests/msvc/woa_impl.c"
    # shellcheck disable=SC2086
    "$clang" --target=aarch64-w64-mingw32 -x $lang -O2 -Wall -Wextra -pedantic -Werror -nostdinc -isystem "$clang_inc" \
      -isystem "$inc" -c "$src/tests/msvc/woa_impl.c" -o "$work/woa_impl.o"
  done
  llvm_objdump=$(command -v llvm-objdump-14 || command -v llvm-objdump || true)
  if [ -n "$llvm_objdump" ]; then
    n=$("$llvm_objdump" -d "$work/woa_impl.o" | grep -cE 'fmla[[:space:]]+v[0-9]+\.4s' || true)
    [ "$n" -gt 0 ] || { echo "FAIL: no NEON fmla in the Windows-on-ARM object"; exit 1; }
    syms=$("$llvm_objdump" -t "$work/woa_impl.o")   # (not piped into grep -q: under pipefail its early exit fails the pipe)
    for f in CreateThread SleepConditionVariableSRW; do
      grep -q "__imp_$f" <<<"$syms" || { echo "FAIL: the Windows-on-ARM object does not call $f"; exit 1; }
    done
    echo "  fmla .4s: $n; CreateThread, SleepConditionVariableSRW imported"
  fi
  echo "msvc: Windows on ARM64 (clang, MinGW target) compiles warning-free as C and C++ with NEON and the Win32 pool"
else
  echo "note: no clang with arm_neon.h: Windows on ARM64 not compiled"
fi

# 2. the same branch run (MinGW-w64 gcc, wine)
mcc=$(command -v x86_64-w64-mingw32-gcc || true)
wine=$(command -v wine64 || true)
[ -z "$wine" ] && [ -x /usr/lib/wine/wine64 ] && wine=/usr/lib/wine/wine64
if [ "$wine_on" != ON ] || [ -z "$mcc" ] || [ -z "$wine" ]; then
  echo "note: the MSVC branch was not run (needs SUPERMAT_MINGW_TESTS=ON, x86_64-w64-mingw32-gcc and wine64)"
  exit 0
fi
"${CC:-cc}" -std=c99 -O2 -I"$src/tests" -o "$work/test_win32_linux" "$src/tests/test_win32.c" -lm -lpthread
expect=$("$work/test_win32_linux")
has() { case ",$expect," in *,"$1",*) return 0 ;; esac; return 1; }
if ! has avx2; then echo "note: this CPU has no AVX2: the MSVC branch was not run"; exit 0; fi
mflags=(-mavx2 -mfma -mf16c -mxsave -DSUPERMAT__FORCE_MSVC_PATHS)
if has avx512 && has avx512_bf16 && has avx512_vnni; then
  mflags+=(-mavx512f -mavx512bw -mavx512vl -mavx512vnni -mavx512bf16)
  if has avx_vnni; then mflags+=(-mavxvnni); else mflags+=(-DSUPERMAT_NO_AVXVNNI); fi
else
  mflags+=(-DSUPERMAT_NO_AVX512)
fi
echo "== MinGW-w64 gcc, the MSVC branch: ${mflags[*]}"
export WINEPREFIX="$work/wineprefix" WINEDEBUG=-all
for t in test_kernels test_win32 test_golden; do
  "$mcc" -std=c99 -O2 -Wall -Wextra -pedantic -Werror -static "${mflags[@]}" -I"$src/tests" -o "$work/msvc_$t.exe" "$src/tests/$t.c" -lm
done
out=$("$wine" "$work/msvc_test_kernels.exe" 2>&1) || { echo "$out"; exit 1; }
echo "$out" | grep -E "^(kernel |int8 compute|bf16 compute|AVX-512 = )"
echo "$out" | tail -n 1
echo "$out" | grep -q "kernel avx2:" || { echo "FAIL: the AVX2 kernel did not run"; exit 1; }
if has avx512 && has avx512_bf16 && has avx512_vnni; then
  echo "$out" | grep -q "kernel avx512:" || { echo "FAIL: the AVX-512 kernel did not run"; exit 1; }
  echo "$out" | grep -q "^bf16 compute (vdpbf16ps)" || { echo "FAIL: bf16 compute did not run"; exit 1; }
  echo "$out" | grep -q "^int8 compute (vpdpbusd, AVX512_VNNI)" || { echo "FAIL: int8 compute did not run"; exit 1; }
fi
"$wine" "$work/msvc_test_win32.exe" "$tiny" "$expect" | grep -E "^(cpu:|win32:)"
"$wine" "$work/msvc_test_golden.exe" "$tiny" auto 2 "$data/golden/single_sphere_64" "$data/golden/single_box_40" "$data/golden/single_ring_48x72" | tail -n 1
echo "msvc: the MSVC branch's kernels, CPU detection and dispatch pass as a Windows program (MinGW gcc, wine)"
