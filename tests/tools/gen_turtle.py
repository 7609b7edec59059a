#!/usr/bin/env python3
"""Regenerate tests/expected/turtle/ with the reference turtle (turtle.py).

Usage (from the repository root, after `cargo build`):
    python3 tests/tools/gen_turtle.py            # write the files
    python3 tests/tools/gen_turtle.py --check    # compare only, exit 1 on a difference

For each case, the module string comes from lsgen (`lsgen -n N MODEL.ls`,
itself checked against tests/tools/ref.py), and the expected segment list
from tests/tools/turtle.py, which shares no code with lsgen-turtle.
tests/turtle.rs compares lsgen-turtle's `-f segments` output with these
files to 1e-6.
"""

import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import turtle  # noqa: E402

# (case name, example, derivation length): 2D, 3D, tropism, polygons, $.
CASES = [
    ("plant_a", "plant_a", 3),
    ("koch_snowflake", "koch_snowflake", 2),
    ("hilbert3d", "hilbert3d", 2),
    ("ternary_tree", "ternary_tree", 3),
    ("bush", "bush", 3),
    ("monopodial_tree", "monopodial_tree", 5),
    ("row_of_trees", "row_of_trees", 6),
    # cpfg's tropism (`view: tropism model = cpfg`) and `_`.
    ("cpfg_bend", "cpfg_bend", 4),
]


def main():
    check = "--check" in sys.argv[1:]
    bad = 0
    lsgen = os.path.join(ROOT, "target", "debug", "lsgen")
    out_dir = os.path.join(ROOT, "tests", "expected", "turtle")
    os.makedirs(out_dir, exist_ok=True)
    for name, example, n in CASES:
        # An example, else a test model of tests/turtle/.
        model = os.path.join(ROOT, "examples", example + ".ls")
        if not os.path.exists(model):
            model = os.path.join(ROOT, "tests", "turtle", example + ".ls")
        text = subprocess.run([lsgen, "-n", str(n), model], check=True,
                              capture_output=True, text=True).stdout
        lines = turtle.interpret(text, turtle.view_settings(model), [])
        path = os.path.join(out_dir, "%s.n%d.txt" % (name, n))
        data = "".join(line + "\n" for line in lines)
        if check:
            old = open(path).read() if os.path.exists(path) else None
            if old != data:
                print(path, "differs")
                bad += 1
            continue
        with open(path, "w") as f:
            f.write(data)
        print(path, len(lines), "lines")
    if bad:
        sys.exit(1)


if __name__ == "__main__":
    main()
