#!/usr/bin/env bash
# Instruction counts of the benchmark workloads at their 10^6 size, for one
# or more lsgen binaries, with valgrind's callgrind. Unlike wall times these
# do not depend on what else the machine is doing, so two builds can be
# compared on a busy (shared) machine.
#
#   benches/callgrind.sh OLD_BIN NEW_BIN ...
#
# Each binary derives each workload with -o to a file in a scratch dir; the
# context workloads first derive their axiom (not counted), as the suite does.
set -euo pipefail
cd "$(dirname "$0")/workloads"
[ $# -ge 1 ] || { echo "usage: benches/callgrind.sh BIN [BIN...]" >&2; exit 2; }
tmp=$(mktemp -d)
# One thread (LSGEN_JOBS=1; 9bc7f68 ignores it): callgrind adds up every
# thread's instructions, so these rows compare the one-thread engine; the
# parallel split's extra work is measured apart (benches/RESULTS.md).
export LSGEN_JOBS=1
trap 'rm -rf "$tmp"' EXIT
# name | file | -n | axiom generator and its -n (or -)
rows=(
    "koch_snowflake|koch_snowflake.ls|9|-"
    "dragon_curve|dragon_curve.ls|18|-"
    "plant_d|plant_d.ls|11|-"
    "parametric_tree|parametric_tree.ls|11|-"
    "parametric_tree_cpfg|parametric_tree.l|11|-"
    "stochastic_plant|stochastic_plant.ls|10|-"
    "context_signal_1|context_signal.ls|1|signal_axiom.ls 11"
    "context_signal_3|context_signal.ls|3|signal_axiom.ls 11"
    "skip_branches|skip_branches.ls|1|skip_axiom.ls 11"
    "koch_homomorphism|koch_homomorphism.ls|8|-"
)
printf '| workload |'; for b in "$@"; do printf ' %s |' "$b"; done; printf ' change |\n'
printf '|---|'; for _ in "$@"; do printf -- '--:|'; done; printf -- '--:|\n'
for row in "${rows[@]}"; do
    IFS='|' read -r name file n gen <<<"$row"
    printf '| %s |' "$name"
    first=
    last=
    ok=0
    for bin in "$@"; do
        # Each binary writes a new file: replacing an existing one costs
        # about 15,000 instructions more (the leftover check), 1.5% of a
        # D0L row, which went to whichever binary came second.
        rm -f "$tmp/out"
        args=(-n "$n" --seed 1 "$file" -o "$tmp/out")
        if [ "$gen" != - ]; then
            read -r gfile gn <<<"$gen"
            "$bin" -n "$gn" "$gfile" -o "$tmp/axiom"
            args+=(--axiom "$tmp/axiom")
        fi
        if ! valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" "$bin" "${args[@]}" \
            2>"$tmp/log" >/dev/null; then
            # (A build that cannot run this row: an older one on a `.l` file.)
            printf ' — |'
            continue
        fi
        ir=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$tmp/log")
        [ -n "$first" ] || first=$ir
        last=$ir
        ok=$((ok + 1))
        printf ' %s |' "$ir"
    done
    # The change from the first build that ran the row to the last.
    awk -v a="$first" -v b="$last" -v ok="$ok" \
        'BEGIN { if (ok < 2) print " — |"; else printf " %+.1f%% |\n", (b - a) * 100 / a }'
done
