#!/usr/bin/env bash
# Fuzz lsgen with cargo-fuzz (libFuzzer) on the stable toolchain.
#
#   fuzz/run.sh TARGET [RUNS] [extra libFuzzer flags...]
#   fuzz/run.sh derive 10000000
#   fuzz/run.sh parse 10000000 -max_total_time=3600
#   fuzz/run.sh derive tmin fuzz/artifacts/derive/crash-...   # minimise
#
# TARGET is `parse`, `derive` or `cpfg` (fuzz/fuzz_targets/; cpfg derives
# the input as a cpfg `.l` file). RUNS defaults to
# 1000000 (0 = until stopped or a crash: libFuzzer's -runs=-1; its own
# -runs=0 would only replay the corpus). The script installs cargo-fuzz if
# missing, seeds fuzz/corpus/TARGET/ from examples/*.ls and runs with the
# dictionary fuzz/ls.dict. Crashes land in fuzz/artifacts/TARGET/.
#
# cargo-fuzz needs nightly-only rustc flags (-Zsanitizer=..., coverage
# options); RUSTC_BOOTSTRAP=1 lets the stable compiler accept them.
#
# The build is optimised, with debug assertions and overflow checks. By
# default it has no sanitizer: lsgen is safe Rust, and AddressSanitizer made
# the derive target about 4x slower (~2,700 vs ~11,000 exec/s here). Set
# SANITIZER=address (or another cargo-fuzz -s value) to fuzz with one. Each
# sanitizer builds in its own dir, fuzz/target/san-$SANITIZER/.
#
# FUZZ_DRY_RUN=1 prints the libFuzzer flags (one a line) instead of running
# (tests/fuzz_script.rs).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cd "$root"

target=${1:?usage: fuzz/run.sh parse|derive|cpfg [RUNS|tmin FILE] [libFuzzer flags...]}
shift
case $target in
parse | derive | cpfg) ;;
*)
    echo "fuzz/run.sh: unknown target \`$target\` (parse, derive, cpfg)" >&2
    exit 2
    ;;
esac

export RUSTC_BOOTSTRAP=1
export PATH="$HOME/.cargo/bin:$PATH"
# derive_bytes writes each generation to a temp file: keep them in memory.
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then
    export TMPDIR=/dev/shm
fi

need_cargo_fuzz() {
    if ! cargo fuzz --version >/dev/null 2>&1; then
        echo "fuzz/run.sh: installing cargo-fuzz" >&2
        cargo install --locked cargo-fuzz
    fi
}

sanitizer=${SANITIZER:-none}
build_flags=(
    --sanitizer "$sanitizer" --release --debug-assertions
    --target-dir "$here/target/san-$sanitizer"
)

if [ "${1:-}" = tmin ]; then
    file=${2:?usage: fuzz/run.sh TARGET tmin FILE}
    shift 2
    need_cargo_fuzz
    exec cargo fuzz tmin "${build_flags[@]}" "$target" "$file" -- \
        -timeout=10 -rss_limit_mb=2048 "$@"
fi

runs=${1:-1000000}
[ $# -gt 0 ] && shift
# libFuzzer: -runs=0 replays the corpus and stops; -runs=-1 runs until
# stopped.
[ "$runs" = 0 ] && runs=-1

fuzzer_flags=(
    -dict="$here/ls.dict"
    -runs="$runs"
    -max_len=4096
    -timeout=10
    -rss_limit_mb=2048
    -print_final_stats=1
    "$@"
)
if [ -n "${FUZZ_DRY_RUN:-}" ]; then
    printf '%s\n' "${fuzzer_flags[@]}"
    exit 0
fi
need_cargo_fuzz

# Seed corpus: the examples. The derive target reads its first byte as the
# run settings (steps = byte & 7 % 5, bit 3 = keep the file's seed), so its
# copies get one such byte in front: 0x0b = 3 steps, file's seed.
corpus="$here/corpus/$target"
mkdir -p "$corpus" "$here/artifacts/$target"
if [ "$target" = cpfg ]; then
    # The cpfg models (their #include files are not found from the corpus:
    # the preprocessor's error path gets fuzzed too); one byte: 3 steps.
    for f in tests/cpfg/*.l tests/cpfg/abop/*.l tests/cpfg/refused/*.l; do
        {
            printf '\x03'
            cat "$f"
        } >"$corpus/cpfg-$(basename "$f" .l)"
    done
fi
for f in examples/*.ls; do
    name=example-$(basename "$f" .ls)
    if [ "$target" = derive ] || [ "$target" = cpfg ]; then
        {
            printf '\x0b'
            cat "$f"
        } >"$corpus/$name"
    else
        cp "$f" "$corpus/$name"
    fi
done

exec cargo fuzz run "${build_flags[@]}" "$target" "$corpus" -- "${fuzzer_flags[@]}"
