#!/usr/bin/env python3
"""Sanity checks for tests/tools/ref.py against hand-derived results.

Run from anywhere:  python3 tests/tools/check_ref.py
Prints 'N passed, N failed' and exits non-zero on any failure.
"""

import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import ref  # noqa: E402

passed = 0
failed = 0


def check(label, got, want):
    global passed, failed
    if got == want:
        passed += 1
    else:
        failed += 1
        g, w = str(got), str(want)
        print("FAIL %s\n  got:  %s\n  want: %s" % (label, g[:300], w[:300]))


def run(name, n):
    return ref.run_file(os.path.join(ROOT, "examples", name + ".ls"), n)


def run_text(text, n):
    return ref.format_string(ref.Rewriter(ref.parse_ls(text)).derive(n))


# --- number formatting (ryu-like, no trailing .0) -------------------------
for value, text in [
    (2.0, "2"),
    (0.5, "0.5"),
    (math.sqrt(2.0), "1.4142135623730951"),
    (-3.0, "-3"),
    (0.00001, "0.00001"),
    (0.0001234, "0.0001234"),
    (1e-7, "1e-7"),
    (1e-6, "1e-6"),
    (1.5e-6, "1.5e-6"),
    (1e15, "1000000000000000"),
    (1e16, "1e16"),
    (1.2345e20, "1.2345e20"),
    (123456.789, "123456.789"),
    (0.1 + 0.2, "0.30000000000000004"),
    (-0.0, "-0"),
    (0.0, "0"),
    (5e-324, "5e-324"),
]:
    check("fmt %r" % value, ref.fmt_num(value), text)

# --- expressions ------------------------------------------------------------
for expr, want in [
    ("1+2*3", 7.0),
    ("(1+2)*3", 9.0),
    ("2^3^2", 512.0),
    ("-2^2", -4.0),
    ("2^-1", 0.5),
    ("7-2-1", 4.0),
    ("8/2/2", 2.0),
    ("1 < 2 && 2 <= 2", 1.0),
    ("1 > 2 || !(1 == 1)", 0.0),
    ("sin(90)", 1.0),
    ("max(3, min(1, 2))", 3.0),
    ("floor(-1.5) + ceil(1.2) + trunc(-1.7) + abs(-2)", 1.0),
]:
    check("expr %s" % expr, ref.eval_expr(ref.parse_expr(expr), {}), want)

# --- algae: lengths are Fibonacci numbers -----------------------------------
fib = [1, 2]
while len(fib) < 16:
    fib.append(fib[-1] + fib[-2])
for n in range(16):
    s = run("algae", n)
    check("algae n%d length" % n, len(s), fib[n])
    check("algae n%d a-count" % n, s.count("a"), fib[n - 1] if n else 1)
for n, s in enumerate(["a", "ab", "aba", "abaab", "abaababa", "abaababaabaab"]):
    check("algae n%d" % n, run("algae", n), s)

# --- signal ------------------------------------------------------------------
for n, s in [(1, "abaaaaa"), (2, "aabaaaa"), (3, "aaabaaa"), (6, "aaaaaab"), (7, "aaaaaaa")]:
    check("signal n%d" % n, run("signal", n), s)

# --- Koch snowflake: 3*4^n edges, 7*4^n symbols -----------------------------
# Each F becomes 4 F's and 4 turns, so symbols(n) = 3*4^n + 4 + 4*(3*4^n - 3)/3
# = 7*4^n.
for n in range(6):
    s = run("koch_snowflake", n)
    check("snowflake n%d length" % n, len(s), 7 * 4**n)
    check("snowflake n%d F" % n, s.count("F"), 3 * 4**n)
check("snowflake n1", run("koch_snowflake", 1), "F+F--F+F--F+F--F+F--F+F--F+F")

# --- Koch island (fig 1.6): each F -> 8 F's and 6 turns ----------------------
for n in range(4):
    s = run("koch_island", n)
    edges = 4 * 8**n
    check("koch island n%d F" % n, s.count("F"), edges)
    check("koch island n%d length" % n, len(s), edges + 3 + 6 * (edges - 4) // 7)
check("koch island n1", run("koch_island", 1), "-".join(["F-F+F+FF-F-F+F"] * 4))

# --- bracketed plants: closed-form lengths ------------------------------------
# F -> w (k F's, |w| symbols):  length(n) = 1 + (|w|-1) * (1 + k + ... + k^(n-1))
for name, n, w in [
    ("plant_a", 5, "F[+F]F[-F]F"),
    ("plant_b", 5, "F[+F]F[-F][F]"),
    ("plant_c", 4, "FF-[-F+F+F]+[+F-F-F]"),
]:
    k = w.count("F")
    want = 1 + (len(w) - 1) * sum(k**i for i in range(n))
    s = run(name, n)
    check("%s n%d length" % (name, n), len(s), want)
    check("%s n1" % name, run(name, 1), w)
check("plant_d n2", run("plant_d", 2), "FF[+F[+X]F[-X]+X]FF[-F[+X]F[-X]+X]+F[+X]F[-X]+X")

# --- dragon curve and Sierpinski gasket (homomorphism) ----------------------
check("dragon n1", run("dragon_curve", 1), "Fl+rF+")
check("dragon n2", run("dragon_curve", 2), "Fl+rF++-Fl-rF+")
check("sierpinski n1", run("sierpinski_gasket", 1), "F-F-F")
check("sierpinski n2", run("sierpinski_gasket", 2), "F+F+F-F-F-F-F+F+F")

# --- parametric example, ABOP 1.10.1 (derived by hand) -----------------------
# B(2)A(4,4): B(2) -> B(1) (x >= 1); A(4,4) -> B(4)A(1,0) (y > 3)
# B(1)B(4)A(1,0): B(0), B(3), A(1,0) -> A(2,1)
# B(0)B(3)A(2,1): C, B(2), A(4,3)
# C B(2)A(4,3): C, B(1), A(8,7); the homomorphism maps C to F(1.456)
# step 5: B(1) -> B(0); A(8,7) -> B(8)A(8/7,0)
# step 6: B(0) -> C; B(8) -> B(7); A(8/7,0) -> A(16/7, 8/7)
for n, s in [
    (0, "B(2)A(4,4)"),
    (1, "B(1)B(4)A(1,0)"),
    (2, "B(0)B(3)A(2,1)"),
    (3, "F(1.456)B(2)A(4,3)"),
    (4, "F(1.456)B(1)A(8,7)"),
    (5, "F(1.456)B(0)B(8)A(%s,0)" % ref.fmt_num(8 / 7)),
    (6, "F(1.456)F(1.456)B(7)A(%s,%s)" % (ref.fmt_num(8 / 7 * 2), ref.fmt_num(8 / 7))),
]:
    check("parametric n%d" % n, run("parametric", n), s)
check("8/7", ref.fmt_num(8 / 7), "1.1428571428571428")
check("parametric_context n1", run("parametric_context", 1), "A(4)E(4.5)F(5.5)C(6)A(1)B(2)C(3)")

# --- trees: first step by hand -----------------------------------------------
w = ref.fmt_num(10 * 0.707)
check("10*0.707", w, "7.069999999999999")
check(
    "monopodial n1",
    run("monopodial_tree", 1),
    "!(10)F(1)[&(45)B(0.6,%s)]/(137.5)A(0.9,%s)" % (w, w),
)
check(
    "sympodial n1",
    run("sympodial_tree", 1),
    "!(10)F(1)[&(10)B(0.9,%s)]/(180)[&(60)B(0.7,%s)]" % (w, w),
)
br = "[&(18.95)F(50)A]"
check(
    "ternary n1",
    run("ternary_tree", 1),
    "!(1.732)F(%s)/(45)!(1.732)F(50)%s/(94.74)%s/(132.63)%s" % (ref.fmt_num(200 * 1.109), br, br, br),
)
h = ref.fmt_num(math.pow(0.3 * 0.7, 0.5))
check("row of trees n1", run("row_of_trees", 1), "F(0.3,2)+F(%s,1)--F(%s,1)+F(0.7,0)" % (h, h))

# --- context-sensitive ---------------------------------------------------------
check("context_brackets n1", run("context_brackets", 1), "aBc[de][sg[hi[jk]l]mno]")

# Fig 1.31a by hand (ignore: +-F; the ends of the string have no context):
# F1F1F1   -> 1 (no left) | 1<1>1 -> 0 | 1 (no right)          = F1F0F1
# F1F0F1   -> 1 | 1<0>1 -> 1F1 | 1                            = F1F1F1F1
# F1F1F1F1 -> 1 | 1<1>1 -> 0 | 1<1>1 -> 0 | 1                  = F1F0F0F1
# F1F0F0F1 -> 1 | 1<0>0 -> 0 | 0<0>1 -> 1[+F1F1] | 1           = F1F0F1[+F1F1]F1
# F1F0F1[+F1F1]F1: 0: 1<0>1 -> 1F1; next 1: 0<1>1 (branch skipped) -> 1;
#   first 1 in the branch: left is its parent 1 -> 1<1>1 -> 0; last 1 in the
#   branch: ']' follows, no right context; + -> -     = F1F1F1F1[-F0F1]F1
for n, s in [
    (1, "F1F0F1"),
    (2, "F1F1F1F1"),
    (3, "F1F0F0F1"),
    (4, "F1F0F1[+F1F1]F1"),
    (5, "F1F1F1F1[-F0F1]F1"),
]:
    check("context_plant_a n%d" % n, run("context_plant_a", n), s)
# Fig 1.31b, first steps by hand: p1 0<0>0 -> 1, p5 1<0>0 -> 0, p2 0<0>1 -> 1[-F1F1]
for n, s in [(1, "F1F0F1"), (2, "F1F1F1F1"), (3, "F1F0F0F1"), (4, "F1F0F1[-F1F1]F1")]:
    check("context_plant_b n%d" % n, run("context_plant_b", n), s)
# Fig 1.31d starts from F0F1F1: 0 (no left) | 0<1>1 -> 1F1 | 1 (no right)
check("context_plant_d n1", run("context_plant_d", 1), "F0F1F1F1")
# Each step keeps brackets balanced and only 0/1/F/+/-/[/] occur.
for letter, n in [("a", 30), ("b", 30), ("c", 26), ("d", 24), ("e", 26)]:
    s = run("context_plant_" + letter, n)
    check("context_plant_%s alphabet" % letter, set(s) <= set("01F+-[]"), True)
    depth = 0
    ok = True
    for c in s:
        depth += {"[": 1, "]": -1}.get(c, 0)
        ok = ok and depth >= 0
    check("context_plant_%s brackets" % letter, ok and depth == 0, True)

# Parametric context with a condition and a consider: setting.
check(
    "consider",
    run_text(
        "consider: AB\nproductions:\nA(x) < B(y) > A(z) : x < z -> B(x+y+z)\n"
        "axiom:\nA(1)F[C]B(2)+[A(9)]A(3)B(4)\n",
        1,
    ),
    "A(1)F[C]B(6)+[A(9)]A(3)B(4)",
)

# The structural models (tests/structural/), against strings derived by
# hand from the cpfg manual's descriptions and docs/structural.md.
def run_structural(name, n):
    # Models lsgen implements moved to examples/ (issue 11).
    path = os.path.join(ROOT, "tests", "structural", name + ".ls")
    if not os.path.exists(path):
        path = os.path.join(ROOT, "examples", name + ".ls")
    return ref.run_file(path, n)


STRUCTURAL_BY_HAND = [
    # cpfg manual 6.4: D(17) reaches 20 in step 3, is % after step 4, cuts in step 5.
    ("cpfg_cut", 3, "F[+D(4)F]F[-D(20)F]F"),
    ("cpfg_cut", 4, "F[+D(5)F]F[-%F]F"),
    ("cpfg_cut", 5, "F[+D(6)F]F[-]F"),
    # cpfg manual 4.4: the axiom is not decomposed; decomposed parts stay.
    ("cpfg_decomposition", 0, "LA"),
    ("cpfg_decomposition", 1, "[+F][-F]I[+F][-F]A"),
    ("cpfg_decomposition", 2, "[+FF][-FF]I[+FF][-FF]I[+F][-F]A"),
    # cpfg manual 4.3.2: G sees the original P(x,y), f when y > 3.
    ("cpfg_homomorphism_depth", 0, "fP(0,0)P(1,5)GP(0,0)P(1,2)"),
    ("cpfg_homomorphism_depth", 1, "fP(0,0)P(1,6)GP(0,0)P(1,3)"),
    ("cpfg_homomorphism_depth", 2, "fP(0,0)P(1,7)fP(0,0)P(1,4)"),
    ("compound_leaf", 1, "I[+F[+[&K]][-[&K]][&K]][-F[+[&K]][-[&K]][&K]]A(2)"),
    (
        "compound_leaf",
        2,
        "I[+F[+[&K]][-[&K]][&K]][-F[+[&K]][-[&K]][&K]]"
        "I[+F[+[&K]][-[&K]]F[+[&K]][-[&K]]P][-F[+[&K]][-[&K]]F[+[&K]][-[&K]]P]A(3)",
    ),
    ("alternating_tables", 2, "FI[+I[+A][-A]A][-I[+A][-A]A]I[+A][-A]A"),
    ("alternating_tables", 3, "FI[+I[+RA][-RA]RA][-I[+RA][-RA]RA]I[+RA][-RA]RA"),
    ("group_expression", 4, "A[-C(4)][+B(3)][-C(2)][+B(1)]"),
    ("step_number", 5, "F(1)F(2)F(3)F(4)[+B(5)]F(5)[+B(5)]A"),
    ("shedding_plant", 2, "FI[+S(1)FFL]FI[-S(1)FFL]I[+S(0)FL]I[-S(0)FL]A"),
    (
        "shedding_plant",
        4,
        "FFFFFFFI[+%FFFFFFFFL]FFFFFFFI[-%FFFFFFFFL]FFFI[+S(2)FFFFL]FFFI[-S(2)FFFFL]"
        "FI[+S(1)FFL]FI[-S(1)FFL]I[+S(0)FL]I[-S(0)FL]A",
    ),
]
for name, n, want in STRUCTURAL_BY_HAND:
    check("%s n%d" % (name, n), run_structural(name, n), want)
# Shedding: after step 5 the two oldest branches are empty, the next two hold %.
s5 = run_structural("shedding_plant", 5)
check("shedding_plant n5 cut branches", (s5.count("[+]"), s5.count("[-]"), s5.count("%")), (1, 1, 2))

# The structural features (docs/structural.md): ref.py's own hand-derived
# self-test.
check("ref.py --self-test failures", ref.self_test(), 0)

print("%d passed, %d failed" % (passed, failed))
sys.exit(1 if failed else 0)
