#!/usr/bin/env python3
"""Random cpfg (`.l`) systems derived by the independent reference
cpfg_ref.py, written to tests/expected/cpfg/random/cases.txt. The Rust test
`random_cases_match_cpfg_ref` (tests/cpfg_random.rs) derives each with lsgen's
cpfg dialect and must print the same string: the differential test of the
cpfg dialect, as gen_cross_cases.py is for the `.ls` structural features.

The generator covers the dialect's features together: parameters stored as
32-bit floats, cpfg's operators and precedence (`^`, `%`, `/` by zero,
`<>`, `?:`, `!`, `&&`, `||`, unary minus), conditions and `*`, contexts
(with `*`, brackets and `=` in right contexts), `ignore:` / `consider:`,
multi-module predecessors, first-applicable choice, stochastic choice with
`seed:` (drand48), `ran`, decomposition and homomorphism with `maximum
depth:`, the cut `%`, `Q` and `Z`, header blocks with globals and
pre-/post-condition blocks with locals. A second batch of cases (its own
generator) also assigns `Q` and `Z` in blocks and has more decomposition
and homomorphism at small depths (0 included), where cpfg tries the
productions at the depth limit. A third (its own generator again) is the
second with contexts in decomposition productions, which cpfg reads around
the whole predecessor of the production that made the module. A fourth is
the second with an axiom whose parameters read globals, `ran` and a `Q` or
`Z` that `Start:` assigns: cpfg reads the axiom after `Start:`. A fifth
is seeded, without decomposition, with two keys of their own (E, G) that
have two or three productions each with constant successors, mostly
without weights: in a seeded system each weighs 1 and they compete.

Usage (from anywhere):
    python3 tests/tools/gen_cpfg_cases.py          # write the file
    python3 tests/tools/gen_cpfg_cases.py --check  # compare, exit 1 if stale

File format: for each case, a line `=== STEPS`, the `.l` text, a line
`--- expected`, the output line. Cases the reference refuses, that print
more than MAX_OUTPUT characters, or whose string holds `inf` / `nan` (an
error in lsgen, README) are not kept.
"""

import io
import os
import random
import sys
import tempfile
import contextlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import cpfg_ref  # noqa: E402

OUT = os.path.join(ROOT, "tests", "expected", "cpfg", "random", "cases.txt")
CASES = 300
# The second batch (`generate`'s `extended`), after the first.
EXTENDED = 100
# The third (`extended` and `decomp_contexts`), after the second.
DECOMP_CONTEXTS = 100
# The fourth (`extended` and `late_axiom`), after the third.
LATE_AXIOM = 60
# The fifth (`alternatives`, without decomposition), after the fourth.
ALTERNATIVES = 40
MAX_OUTPUT = 2000

SYMS = "ABCD"


def generate(r, extended=False, decomp_contexts=False, late_axiom=False, alternatives=False):
    """A random system and a number of steps. `extended`: a second batch
    (its own generator, so the first batch stays as it was) whose blocks
    also assign `Q` and `Z`, with more decomposition and homomorphism at
    small depths, where cpfg tries productions at the depth limit.
    `decomp_contexts`: decomposition productions with contexts too.
    `late_axiom`: the axiom's parameters read globals and draw too, and
    `Start:` assigns them, `Q` or `Z`. `alternatives`: seeded, with two
    keys without parameters (E, G) that have two or three productions of
    their own, mostly without weights (each weighs 1 when the system is
    seeded)."""
    globals_ = extended or r.random() < 0.3
    stochastic = r.random() < 0.3 or alternatives

    def expr(var, axiom=False):
        a = var if var and r.random() < 0.7 else str(r.randint(0, 3))
        ops = [
            "%s+1", "%s*2", "%s-1", "%s/2", "%s^2", "-%s^2", "%s%%3",
            "trunc(%s/3)", "%s/0", "(%s>1?%s:1)", "!%s", "Q", "Z-%s",
        ]
        # The first three batches keep globals and `ran` out of the axiom
        # (lsgen once read its parameters as constant expressions).
        if globals_ and (not axiom or late_axiom):
            ops.append("g+%s")
        if (not axiom or late_axiom) and (stochastic or r.random() < 0.1):
            ops.append("floor(ran(3))+%s")
        if axiom and late_axiom and r.random() < 0.6:
            ops = ["g+%s", "floor(ran(3))+%s", "Q+%s", "Z-%s", "g*Q+%s", "%s/(g-g)"]
        e = r.choice(ops)
        return e.replace("%s", a).replace("%%", "%")

    def module(var, param, axiom):
        s = r.choice(SYMS)
        if param:
            return "%s(%s)" % (s, expr(var, axiom))
        return s

    def succ(var, brackets=True, axiom=False):
        out = []
        for _ in range(r.randint(0, 4)):
            c = r.choice(SYMS + "F+%,")
            if c in SYMS and r.random() < 0.5:
                out.append(module(var, True, axiom))
            else:
                out.append(c)
        if brackets and r.random() < 0.4:
            inner = succ(var, False, axiom)
            out.insert(r.randint(0, len(out)), "[" + ("" if inner == "*" else inner) + "]")
        if not out:
            return "*"
        return "".join(out)

    def pred_module():
        s = r.choice(SYMS)
        if r.random() < 0.4:
            return s + "(x)", "x"
        return s, None

    def production(contexts=True, multi=True, weights=False):
        lhs, var = pred_module()
        # The third batch: more multi-module predecessors, whose
        # successors' decomposition reads contexts around all of them.
        if multi and r.random() < (0.5 if decomp_contexts else 0.1):
            lhs += r.choice(SYMS)
        ctx = 0.5 if decomp_contexts and not multi else 0.3
        if contexts and r.random() < ctx:
            lhs = r.choice(["A", "B", "C", "*", "AB"]) + " < " + lhs
        if contexts and r.random() < ctx:
            lhs = lhs + " > " + r.choice(["A", "B", "[C]", "C]", "*", "[A]B", "=B"])
        cond = ""
        x = r.random()
        if x < 0.15:
            cond = " : *"
        elif x < 0.45:
            v = var or "Q"
            cond = " : " + r.choice([
                "%s > 1" % v, "%s <> 2" % v, "%s %% 2 == 0" % v, "Q < 3 && %s >= 1" % v,
                "!(%s == 1) || Q == 2" % v, "Q > 1",
            ])
        if globals_ and not extended and r.random() < 0.3:
            cond = " : {g = g + 1; t = %s;}%s" % (var or "Q", cond[2:] if cond else " *")
            if r.random() < 0.5:
                cond += " {g = g + t;}"
        if extended:
            # cpfg's Q and Z are globals a block may assign (`Start:`
            # assigns them in the fourth batch only).
            pre = r.choice(["", "", "{g = g + 1;}", "{Q = Q + 1;}", "{Z = Z - 1;}",
                            "{if (g > 2) {Q = 0;}}", "{g = g + 1; Z = Z + Q;}"])
            post = r.choice(["", "", "{g = g * 2;}", "{Q = g;}", "{Z = Z + g;}"])
            if pre or post:
                c = cond[3:] if cond else "*"
                cond = " : " + (pre + " " if pre else "") + c + (" " + post if post else "")
        weight = ""
        if weights and r.random() < 0.6:
            weight = " : " + r.choice(["1", "2", "0.5", "Q", "%s+1" % (var or "1")])
        return lhs + cond + " --> " + succ(var) + weight

    lines = ["Lsystem: 1"]
    if stochastic:
        lines.append("seed: %d" % r.randint(1, 100))
    lines.append("derivation length: %d" % r.randint(1, 5))
    if r.random() < 0.3:
        lines.append(r.choice(["ignore: F +", "ignore: C", "consider: A B [ ]", "consider: A B"]))
    if globals_:
        lines.append("Start: {g = 0;}" if not late_axiom else
                     r.choice(["Start: {g = 2;}", "Start: {g = 1; Q = 3;}",
                               "Start: {g = Z + 1; Z = 7;}", "Start: {srand(7); g = ran(4);}",
                               "Start: {g = 1; srand(3);}"]))
        if r.random() < 0.5:
            lines.append("StartEach: {g = g + 1;}" if not extended else
                         r.choice(["StartEach: {g = g + 1;}", "StartEach: {Q = Q * 2;}",
                                   "StartEach: {Z = Z + Q;}"]))
        if extended and r.random() < 0.5:
            lines.append(r.choice(["EndEach: {Q = Q + 10;}", "EndEach: {Z = Z * 2;}",
                                   "End: {Q = 100; Z = g;}"]))
    axiom = "[".join(succ(None, False, True) for _ in range(2)) + "]" + succ(None, False, True)
    axiom = axiom.replace("*", "")
    lines.append("Axiom: " + (axiom or "A"))
    if alternatives:
        # Keys of their own (E, G), in the axiom and in their successors,
        # mostly without weights: no other production shares them.
        lines[-1] += "".join(r.choice("EG") for _ in range(r.randint(2, 6)))
        for s in "EG":
            for _ in range(r.randint(2, 3)):
                cond = " : *" if r.random() < 0.2 else ""
                weight = " : " + r.choice(["1", "2", "0.5"]) if r.random() < 0.15 else ""
                # (Constant successors, as the fast paths that took a
                # key's first production had them.)
                plain = "".join(r.choice("ABEGF+") for _ in range(r.randint(0, 3)))
                lines.append("%s%s --> %s%s" % (s, cond, plain or "*", weight))
    lines += [production(weights=stochastic) for _ in range(r.randint(1, 5))]
    if not alternatives and r.random() < (0.7 if extended else 0.35):
        lines.append("decomposition")
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(0 if extended else 1, 3))
        lines += [production(contexts=decomp_contexts, multi=False)
                  for _ in range(r.randint(1, 3))]
    if r.random() < (0.7 if extended else 0.35):
        lines.append("homomorphism" + r.choice(["", ": no warnings"]))
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(1, 3))
        lines += [production(multi=False) for _ in range(r.randint(1, 3))]
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", r.randint(0, 4)


def derive(text, steps):
    """The reference's string, or None if it refuses the system."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "case.l")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        try:
            # Warnings (undefined names, division by zero) are printed by
            # the reference; they are not part of the expected output.
            with contextlib.redirect_stderr(io.StringIO()):
                return cpfg_ref.run_file(path, steps)
        except cpfg_ref.CpfgError:
            return None
        except (OverflowError, ZeroDivisionError, ValueError, RecursionError):
            return None


def main(argv):
    parts = []
    made = 0
    tried = 0
    r = random.Random(12)
    third = CASES + EXTENDED + DECOMP_CONTEXTS
    fourth = third + LATE_AXIOM
    while made < fourth + ALTERNATIVES:
        if made == CASES:
            r = random.Random(13)
        if made == CASES + EXTENDED:
            r = random.Random(14)
        if made == third:
            r = random.Random(15)
        if made == fourth:
            r = random.Random(16)
        tried += 1
        late = third <= made < fourth
        alt = made >= fourth
        text, steps = generate(
            r, CASES <= made < fourth, CASES + EXTENDED <= made < third, late, alt
        )
        out = derive(text, steps)
        # lsgen refuses a parameter a 32-bit float cannot hold (README), where
        # cpfg stores inf.
        if out is None or len(out) > MAX_OUTPUT or "inf" in out or "nan" in out:
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
    print("wrote %d cases (%d generated) to %s" % (made, tried, os.path.relpath(OUT, ROOT)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
