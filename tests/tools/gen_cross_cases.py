#!/usr/bin/env python3
"""Random deterministic systems with the structural features of
docs/structural.md (groups, `group:`, `step`, decomposition with depth, the
cut `%`, homomorphism depth, contexts), derived by ref.py, written to
tests/expected/structural/random_cases.txt. The Rust reference's test
`reference::tests::agrees_with_ref_py_on_random_cases` derives each and
must give the same string, so the two references check each other; the
implementation's differential tests may reuse the cases.

Usage (from anywhere):
    python3 tests/tools/gen_cross_cases.py          # write the file
    python3 tests/tools/gen_cross_cases.py --check  # compare, exit 1 if stale

File format: for each case, a line `=== STEPS`, the .ls text, a line
`--- expected`, the output line (no case derives an error).
"""

import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import ref  # noqa: E402

OUT = os.path.join(ROOT, "tests", "expected", "structural", "random_cases.txt")
CASES = 300
MAX_OUTPUT = 2000


def generate(r):
    def succ(param, brackets=True):
        out = []
        for _ in range(r.randint(0, 4)):
            c = r.choice("ABCDF+%" if brackets else "ABCDF+")
            if c in "ABCD" and param and r.random() < 0.5:
                out.append("%s(%s)" % (c, r.choice(["x+1", "x*2", "step", "x-step", "1"])))
            else:
                out.append(c)
        if brackets and r.random() < 0.4:
            out.insert(r.randint(0, len(out)), "[" + "".join(succ(param, False)) + "]")
        return out

    def production(contexts=True):
        sym = r.choice("ABCD%")
        param = sym != "%" and r.random() < 0.4
        lhs = sym + ("(x)" if param else "")
        if contexts and r.random() < 0.25:
            lhs = r.choice("ABCDF") + " < " + lhs
        if contexts and r.random() < 0.2:
            lhs = lhs + " > " + r.choice(["A", "B", "[C]", "F"])
        cond = ""
        if r.random() < 0.3:
            cond = " : " + r.choice(
                ["step > 1", "step == 2", "x > 1" if param else "step < 3", "step != 3"]
            )
        return lhs + cond + " -> " + "".join(succ(param))

    lines = []
    groups = r.choice([0, 0, 1, 2])
    if groups:
        if r.random() < 0.5:
            n = r.randint(1, 3)
            lines.append("groups: " + " ".join(str(r.randint(0, groups)) for _ in range(n)))
        else:
            lines.append("group: floor(step / 2) - 2 * floor(step / 4)")
    lines.append("productions:")
    lines += [production() for _ in range(r.randint(0, 4))]
    for g in range(1, groups + 1):
        lines.append("productions %d:" % g)
        lines += [production() for _ in range(r.randint(0, 3))]
    if r.random() < 0.6:
        lines.append("decomposition:" + r.choice(["", " warnings"]))
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(1, 3))
        lines += [production(False) for _ in range(r.randint(0, 3))]
    if r.random() < 0.5:
        lines.append("homomorphism:")
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(1, 3))
        lines += [production() for _ in range(r.randint(0, 3))]
    axiom = "".join(succ(False)) + "[" + "".join(succ(False)) + "]" + "".join(succ(False))
    return "\n".join(lines) + "\naxiom: " + axiom + "\n", r.randint(0, 4)


def main(argv):
    r = random.Random(11)
    parts = []
    made = 0
    while made < CASES:
        text, steps = generate(r)
        out = ref.format_string(ref.Rewriter(ref.parse_ls(text)).derive(steps))
        if len(out) > MAX_OUTPUT:
            continue
        parts.append("=== %d\n%s--- expected\n%s\n" % (steps, text, out))
        made += 1
    content = "".join(parts)
    if "--check" in argv:
        with open(OUT, encoding="utf-8") as f:
            same = f.read() == content
        print("%s: %s" % (os.path.relpath(OUT, ROOT), "up to date" if same else "differs"))
        return 0 if same else 1
    with open(OUT, "w", encoding="utf-8", newline="\n") as f:
        f.write(content)
    print("wrote %d cases to %s" % (made, os.path.relpath(OUT, ROOT)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
