#!/usr/bin/env python3
"""Regenerate tests/expected/ from examples/*.ls with the reference rewriter,
and tests/expected/structural/ from tests/structural/*.ls (the models of
docs/structural.md, which lsgen does not parse yet).

Usage (from the repository root):
    python3 tests/tools/gen_expected.py          # write all files + README.md
    python3 tests/tools/gen_expected.py --check  # only compare, exit 1 on any difference

Each expected file is tests/expected/NAME.nN.txt: the output of
examples/NAME.ls after N derivation steps (homomorphism applied if the file
has one), on one line, newline-terminated.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import ref  # noqa: E402

# example name -> derivation lengths to record
MANIFEST = {
    "algae": list(range(0, 16)),
    "signal": [1, 2, 3, 6, 7],
    "koch_snowflake": [0, 1, 2, 3, 4, 5],
    "koch_island": [0, 1, 2, 3],
    "quadratic_koch_island": [1, 2],
    "quadratic_snowflake": [1, 4],
    "islands_and_lakes": [1, 2],
    "koch_curve_a": [4],
    "koch_curve_b": [4],
    "koch_curve_c": [3],
    "koch_curve_d": [4],
    "koch_curve_e": [5],
    "koch_curve_f": [4],
    "dragon_curve": [1, 2, 10],
    "sierpinski_gasket": [1, 2, 6],
    "hilbert3d": [1, 2, 3],
    "plant_a": [1, 5],
    "plant_b": [1, 5],
    "plant_c": [1, 4],
    "plant_d": [1, 2, 7],
    "plant_e": [1, 2, 7],
    "plant_f": [1, 2, 5],
    "stochastic_plant": [0],
    "parametric": [0, 1, 2, 3, 4, 5, 6],
    "parametric_context": [1],
    "monopodial_tree": [1, 3, 10],
    "sympodial_tree": [1, 3, 10],
    "ternary_tree": [1, 2, 6],
    "row_of_trees": [1, 2, 10],
    "context_brackets": [1],
    "context_plant_a": [1, 2, 3, 30],
    "context_plant_b": [1, 2, 3, 4, 30],
    "context_plant_c": [1, 2, 3, 26],
    "context_plant_d": [1, 2, 3, 24],
    "context_plant_e": [1, 2, 3, 12, 26],
    # issue 11, moved from tests/structural/ once lsgen implemented them
    "shedding_plant": [3, 4, 5],
    "compound_leaf": [0, 1, 2, 3],
    "alternating_tables": [1, 2, 3, 4, 6],
}

# tests/structural/NAME.ls -> derivation lengths (tests/expected/structural/)
STRUCTURAL_MANIFEST = {
    "group_expression": [1, 2, 4],
    "step_number": [0, 3, 4, 5],
    "cpfg_cut": [3, 4, 5],
    "cpfg_decomposition": [0, 1, 2],
    "cpfg_homomorphism_depth": [0, 1, 2],
}

STRUCTURAL_README_HEAD = """\
# Expected outputs of the structural models

Each `NAME.nN.txt` is the exact output of `tests/structural/NAME.ls` after
`N` derivation steps (homomorphism applied), on one line,
newline-terminated: decomposition, homomorphism depth, the cut `%`,
production groups and `step`, as designed in `docs/structural.md`.  They
live in this subdirectory, not in `tests/expected/`, because their models
are test models, not examples (`tests/examples.rs` runs lsgen on every
`tests/expected/*.txt` with `examples/NAME.ls`); `tests/structural.rs`
runs lsgen on them.

Produced by `tests/tools/ref.py` (hand-checked in `tests/tools/check_ref.py`);
regenerate or check all of them with

    python3 tests/tools/gen_expected.py [--check]

| file | bytes | command |
| --- | --- | --- |
"""

README_HEAD = """\
# Expected outputs

Each `NAME.nN.txt` is the exact output of `examples/NAME.ls` after `N`
derivation steps (the file's homomorphism, if any, applied once at the end),
on one line, newline-terminated.  Numbers are formatted like Rust's `ryu`
crate without the trailing `.0`.

These files are produced by `tests/tools/ref.py`, an independent Python
reference rewriter (it shares no code with lsgen).  Regenerate all of them,
and this README, with

    python3 tests/tools/gen_expected.py

or check that they are up to date with

    python3 tests/tools/gen_expected.py --check

A single file is regenerated with the command listed next to it (run from
the repository root).  `python3 tests/tools/check_ref.py` runs the
reference's own sanity checks (hand-derived strings, Fibonacci lengths,
7*4^n for the snowflake, ...).

| file | bytes | command |
| --- | --- | --- |
"""


def generate(manifest, srcdir, outdir, readme_head, check):
    """Write (or with check, compare) one directory of expected files and
    its README; return (files, differing)."""
    os.makedirs(os.path.join(ROOT, outdir), exist_ok=True)
    rows = []
    bad = 0
    for name in sorted(manifest):
        src = os.path.join(ROOT, srcdir, name + ".ls")
        for n in manifest[name]:
            text = ref.run_file(src, n) + "\n"
            fname = "%s.n%d.txt" % (name, n)
            path = os.path.join(ROOT, outdir, fname)
            cmd = "python3 tests/tools/ref.py %s/%s.ls -n %d > %s/%s" % (
                srcdir,
                name,
                n,
                outdir,
                fname,
            )
            rows.append("| `%s` | %d | `%s` |\n" % (fname, len(text), cmd))
            if check:
                try:
                    with open(path, encoding="utf-8") as f:
                        old = f.read()
                except FileNotFoundError:
                    old = None
                if old != text:
                    print("differs: %s/%s" % (outdir, fname))
                    bad += 1
            else:
                with open(path, "w", encoding="utf-8", newline="\n") as f:
                    f.write(text)
    readme = readme_head + "".join(rows)
    readme_path = os.path.join(ROOT, outdir, "README.md")
    if check:
        try:
            with open(readme_path, encoding="utf-8") as f:
                if f.read() != readme:
                    print("differs: %s/README.md" % outdir)
                    bad += 1
        except FileNotFoundError:
            print("missing: %s/README.md" % outdir)
            bad += 1
    else:
        with open(readme_path, "w", encoding="utf-8", newline="\n") as f:
            f.write(readme)
    return len(rows), bad


def main(argv):
    check = "--check" in argv
    files, bad = generate(MANIFEST, "examples", "tests/expected", README_HEAD, check)
    more, more_bad = generate(
        STRUCTURAL_MANIFEST,
        "tests/structural",
        "tests/expected/structural",
        STRUCTURAL_README_HEAD,
        check,
    )
    files += more
    bad += more_bad
    if check:
        print("%d expected files checked, %d differ" % (files, bad))
        return 1 if bad else 0
    print("wrote %d expected files and their README.md" % files)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
