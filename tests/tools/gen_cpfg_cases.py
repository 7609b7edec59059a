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
without weights: in a seeded system each weighs 1 and they compete. A
sixth (`generate_func`) calls `func(id, x)` in successors' parameters,
conditions, pre-/post-condition blocks, `Start:` and `EndEach:`, with 1-3
functions of its own: random control points (x from 0 to 1), the `fver 1
1` format (multiplicities, background and markers lines) and the old
`range:` one, samples <= 2 (the bisection) and more (the table), ids with
a fraction (C's `(int)`) and out-of-[0, 1] arguments (clamped), in a view
file or passed directly, sometimes in a function set whose names are
macros for their numbers. A seventh is the second with few keys (A, B),
mostly with a parameter, many productions each, and pre-condition blocks
that assign to the formal parameter: cpfg binds the formals again for
every production it tries, so the next one sees the string's value. An
eighth (`generate_arrays`) has a `define:` block of 1-3 arrays (1 or 2
dimensions, sizes 1-5, initializer lists of the right length, short,
long or absent) and reads their elements in successors, conditions,
blocks, the axiom and the homomorphism, with integer subscripts that are
sometimes out of range (clamped) and occasionally fractional ones that
stay inside the storage, and assigns elements in `Start:`, `StartEach:`,
`EndEach:` and pre-/post-condition blocks; its cases print parameters. A
ninth is the second with string literals among the parameters (alone and
in arithmetic) and a `printf` in `Start:`: a string's value is its number
among the file's strings, the `printf` format counted. A tenth is the
second with predecessors of several modules (two or three, parameters on
the later ones, conditions on them, contexts) in the decomposition and the
homomorphism, which cpfg matches there too (`PredDiff`), at maximum depths
from 0 to 3, seeded or not (a section's weights are ignored: cpfg chooses
the first applicable production there); only cases where such a
predecessor applied at least once are kept. An eleventh
(`generate_curves`) calls `curveX`, `curveY`, `curveZ` and `curveGAL`
with 1-3 contour files of its own (every kind cpfg evaluates, dimensions
2-4, multiplicities, optional header lines, missing points) and often
functions too, in a view file (`curve:` lines with or without samples,
mixed with `function:` lines) or passed directly (`--functions` or
`--curves`), with t inside and outside [0, 1] and calls nested in `func`.
A twelfth (`generate_queries`) has turtle queries `?P`, `?H`, `?L`, `?U`
(0-4 parameters, mostly 2-3) among the turtle's modules (F f G g with and
without a length, the turns with and without an angle, `|`, branches, `_`
and `_(e)`, `%` in branches, `@v`, `@M(x,y[,z])`, `@o`), with a view file
`case.v` given with `--cpfg-view` (`angle factor:` or `angle increment:`,
`tropism direction:`, `initial elasticity:` up to 0.3, `elasticity
increment:`, `initial scale:`, `interpretation past %: off`): a key A
grows in branches, each copy followed by a query of the case's watched
kind, which conditions read through right and left contexts, a
predecessor may start with a query (`?P(x,y,z) : x < 0 --> ...`), the
decomposition sometimes emits queries; its strings may be longer
(MAX_OUTPUT_QUERIES), and a case where no condition on a query was both
true and false is kept only half of the times (the run prints how many
kept cases have one). A thirteenth is the twelfth with a homomorphism
that cannot change the turtle, which cpfg's turtle (and the reference's)
reads the string through: productions for A, C (the modules showing the
queries) and B whose successors have still modules outside their own
brackets (`K(x)`, `X`, `;(2)`, `!`, ...) and turtle moves inside them
(with `@O`, `%`, `@v`, `@G`, nested branches), e.g. `[F(x)+F(1)@O]K(x)`,
sometimes a context and a condition on a query, sometimes `maximum depth:
2` with a production for a module that another successor makes (K or X);
successors also have `@Gs`, `@Gc(2)`, `@Ge(2)`, `@Gt(1,2)`, `@Gr(1)`
(generalized cylinders: the turtle does not move); only cases where a
homomorphism production applied while the turtle read the string are
kept. A fourteenth is the thirteenth with a homomorphism that moves the
turtle: its successors have moves outside their brackets too, and
sometimes a production rewrites a move of the string (`F(l) -->
F(l)-(10)`, `+ --> -`, ...); only cases where a production that moves
applied while the turtle read the string are kept. A fifteenth is the
twelfth with cpfg's movements: 1-3 `tropism:` and `torque:` lines in the
view file (`T`, often `A`, `E`, `S`, sometimes `I`) and `@Ts`, `@Ti`,
`@Td`, `@Tp`, `@Tf` (with and without parameters) among the turtle's
modules. The printed string is the last one after the homomorphism, as in
the other batches.

Usage (from anywhere):
    python3 tests/tools/gen_cpfg_cases.py          # write the file
    python3 tests/tools/gen_cpfg_cases.py --check  # compare, exit 1 if stale

File format: for each case, a line `=== STEPS`, the `.l` text, then (sixth
batch on) zero or more file sections, a line `--- file NAME` and the
file's text (each ends with a newline), then optionally a line `--- args`
with options and their files (`--functions A --functions B ...`,
`--curves A` too: the same option; `--cpfg-view case.v` in the twelfth to
fifteenth batches: the view file of the queries' turtle, whose functions count too),
then a line `--- expected` and the output line. The files go beside
case.l (in the case's own directory). The options to pass, in order and
files relative to that directory: those of the `--- args` line if there
is one, else `--functions case.v` if the case has that file (a view
file: its `function:` / `function set:` lines name the other files), else
none. Cases the reference refuses, that print more than MAX_OUTPUT
characters (MAX_OUTPUT_QUERIES in the twelfth to fifteenth batches), or whose string
holds `inf` / `nan` (an error in lsgen, README) are not kept.
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
# The sixth (`generate_func`: func with its own function files), after
# the fifth.
FUNC = 40
# The seventh (`extended` and `formals`), after the sixth.
FORMALS = 80
# The eighth (`generate_arrays`: define: blocks and array elements), after
# the seventh.
ARRAYS = 60
# The ninth (`extended` and `strings`), after the eighth.
STRINGS = 30
# The tenth (`extended` and `multi_sections`), after the ninth.
MULTI_SECTIONS = 60
# The eleventh (`generate_curves`: curveX/Y/Z and curveGAL with contour
# files of their own), after the tenth.
CURVES = 60
# The twelfth (`generate_queries`: ?P ?H ?L ?U with a view file given with
# --cpfg-view), after the eleventh; its strings may be longer.
QUERIES = 60
# The thirteenth (`generate_queries` with a homomorphism that cannot
# change the turtle, and @G), after the twelfth.
HOMO_QUERIES = 30
# The fourteenth batch: a homomorphism that moves the turtle.
MOVING_QUERIES = 30
# The fifteenth batch: cpfg's movements.
MOVEMENT_QUERIES = 30
# The sixteenth (`generate_order_free`: nothing that runs in string order),
# after the fifteenth.
ORDER_FREE = 40
MAX_OUTPUT = 2000
MAX_OUTPUT_QUERIES = 6000

SYMS = "ABCD"
# generalized cylinders (the thirteenth batch): the turtle does not move
GC_MODULES = ["@Gs", "@Gc(2)", "@Ge(2)", "@Gs", "@Gc(2)", "@Ge(2)", "@Gt(1,2)", "@Gr(1)"]


def generate(r, extended=False, decomp_contexts=False, late_axiom=False, alternatives=False,
             formals=False, strings=False, multi_sections=False):
    """A random system and a number of steps. `extended`: a second batch
    (its own generator, so the first batch stays as it was) whose blocks
    also assign `Q` and `Z`, with more decomposition and homomorphism at
    small depths, where cpfg tries productions at the depth limit.
    `decomp_contexts`: decomposition productions with contexts too.
    `late_axiom`: the axiom's parameters read globals and draw too, and
    `Start:` assigns them, `Q` or `Z`. `alternatives`: seeded, with two
    keys without parameters (E, G) that have two or three productions of
    their own, mostly without weights (each weighs 1 when the system is
    seeded). `formals`: pre-condition blocks also assign to the
    production's formal parameter, and keys have several productions
    (cpfg binds the formals again for each production it tries).
    `strings`: some parameters are string literals and some blocks print
    (a string's value is its number among the file's strings).
    `multi_sections`: predecessors of several modules in the decomposition
    and the homomorphism, seeded more often, with depths from 0."""
    globals_ = extended or r.random() < 0.3
    stochastic = r.random() < (0.5 if multi_sections else 0.3) or alternatives

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
        if strings and r.random() < 0.35:
            # (A string's number, in arithmetic too.)
            return r.choice(['"s"', '" %.f"', '"a b"', '"x"+%s', '%s*"y"']).replace("%s", a)
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
        if formals:
            # Few keys, mostly with a parameter: productions compete.
            s = r.choice("AB")
            return (s + "(x)", "x") if r.random() < 0.8 else (s, None)
        s = r.choice(SYMS)
        if r.random() < 0.4:
            return s + "(x)", "x"
        return s, None

    def production(contexts=True, multi=True, weights=False, runs=0.0):
        lhs, var = pred_module()
        contexts = contexts and not (formals and r.random() < 0.7)
        # `runs`: how often the predecessor has one or two modules more,
        # the later ones sometimes with a parameter `y` (the tenth batch's
        # sections).
        later = None
        if runs and r.random() < runs:
            for _ in range(1 if r.random() < 0.75 else 2):
                if later is None and r.random() < 0.4:
                    later = "y"
                    lhs += r.choice(SYMS) + "(y)"
                else:
                    lhs += r.choice(SYMS)
        # The third batch: more multi-module predecessors, whose
        # successors' decomposition reads contexts around all of them.
        elif multi and r.random() < (0.5 if decomp_contexts else 0.1):
            lhs += r.choice(SYMS)
        ctx = 0.5 if decomp_contexts and not multi else 0.3
        if contexts and r.random() < ctx:
            lhs = r.choice(["A", "B", "C", "*", "AB"]) + " < " + lhs
        if contexts and r.random() < ctx:
            lhs = lhs + " > " + r.choice(["A", "B", "[C]", "C]", "*", "[A]B", "=B"])
        cond = ""
        x = r.random()
        if formals:
            # Mostly conditions on the formal, which a block may change.
            x = 0.15 + 0.3 * r.random() if r.random() < 0.8 else x
        if x < 0.15:
            cond = " : *"
        elif x < 0.45:
            v = var or "Q"
            cond = " : " + r.choice([
                "%s > 1" % v, "%s <> 2" % v, "%s %% 2 == 0" % v, "Q < 3 && %s >= 1" % v,
                "!(%s == 1) || Q == 2" % v, "Q > 1",
            ])
        if later and r.random() < 0.5:
            cond = " : " + r.choice(["y > 1", "y <> 2", "%s < y" % (var or "Q"), "y %% 2 == 0",
                                     "y + %s >= 2" % (var or "Q")])
        if globals_ and not extended and r.random() < 0.3:
            cond = " : {g = g + 1; t = %s;}%s" % (var or "Q", cond[2:] if cond else " *")
            if r.random() < 0.5:
                cond += " {g = g + t;}"
        if extended:
            # cpfg's Q and Z are globals a block may assign (`Start:`
            # assigns them in the fourth batch only).
            pre = r.choice(["", "", "{g = g + 1;}", "{Q = Q + 1;}", "{Z = Z - 1;}",
                            "{if (g > 2) {Q = 0;}}", "{g = g + 1; Z = Z + Q;}"])
            if formals and var and r.random() < 0.8:
                pre = r.choice(["{%s = %s + 2;}", "{%s = %s * 3; g = g + %s;}",
                                "{%s = Q - %s;}", "{if (%s > 1) {%s = 0;}}", "{%s = -%s;}",
                                "{%s = 0;}"]).replace("%s", var)
            post = r.choice(["", "", "{g = g * 2;}", "{Q = g;}", "{Z = Z + g;}"])
            if pre or post:
                c = cond[3:] if cond else "*"
                cond = " : " + (pre + " " if pre else "") + c + (" " + post if post else "")
        weight = ""
        if weights and r.random() < 0.6:
            weight = " : " + r.choice(["1", "2", "0.5", "Q", "%s+1" % (var or "1")])
        rhs = succ(var)
        if later and r.random() < 0.6:
            # the later module's parameter in the successor
            rhs = ("" if rhs == "*" else rhs) + r.choice(
                ["A(y)", "B(y+1)", "C(%s*y)" % (var or "2"), "D(y-Q)"])
        return lhs + cond + " --> " + rhs + weight

    lines = ["Lsystem: 1"]
    if stochastic:
        lines.append("seed: %d" % r.randint(1, 100))
    lines.append("derivation length: %d" % r.randint(1, 5))
    if r.random() < 0.3:
        lines.append(r.choice(["ignore: F +", "ignore: C", "consider: A B [ ]", "consider: A B"]))
    if globals_:
        lines.append(("Start: {g = 0; printf(\"go %d\\n\", g);}" if strings else "Start: {g = 0;}")
                     if not late_axiom else
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
    if formals:
        # Modules the productions rewrite, with values on both sides of
        # their conditions.
        axiom += "".join("%s(%d)" % (r.choice("AB"), r.randint(-1, 4))
                         for _ in range(r.randint(2, 5)))
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
    lines += [production(weights=stochastic)
              for _ in range(r.randint(4, 8) if formals else r.randint(1, 5))]
    # (The tenth batch's sections: runs, contexts, ignored weights.)
    runs = 0.6 if multi_sections else 0.0
    section_weights = stochastic and multi_sections
    if not alternatives and r.random() < (0.85 if multi_sections else 0.7 if extended else 0.35):
        lines.append("decomposition")
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(0 if extended else 1, 3))
        lines += [production(contexts=decomp_contexts or multi_sections, multi=False,
                             weights=section_weights, runs=runs)
                  for _ in range(r.randint(2, 4) if multi_sections else r.randint(1, 3))]
    if r.random() < (0.85 if multi_sections else 0.7 if extended else 0.35):
        lines.append("homomorphism" + r.choice(["", ": no warnings"]))
        if r.random() < 0.5:
            lines.append("maximum depth: %d" % r.randint(0 if multi_sections else 1, 3))
        lines += [production(multi=False, weights=section_weights, runs=runs)
                  for _ in range(r.randint(2, 4) if multi_sections else r.randint(1, 3))]
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", r.randint(1 if formals else 0, 4)


# Names a function set gives its functions (macros in the `.l` file): none
# is a module, a variable of these systems or a word of cpfg.
FUNC_NAMES = ["len", "ang", "width", "elas", "br_ang", "curv2", "Size", "k_up"]


def func_points(r, multiplicity):
    """Control points, x from 0 to 1 and never decreasing (sometimes twice
    the same x), 6 decimals as cpfg's function editor writes them; each
    point may carry a multiplicity (fver format only)."""
    k = r.randint(4, 8)
    inner = sorted(round(r.random(), 6) for _ in range(k - 2))
    if k > 4 and r.random() < 0.2:
        i = r.randrange(len(inner) - 1)
        inner[i + 1] = inner[i]
    xs = [0.0] + inner + [1.0]
    lines = []
    for x in xs:
        y = round(r.uniform(-1.5, 2.5), r.choice([1, 2, 6, 6]))
        line = "%.6f %s" % (x, ("%.6f" % y) if r.random() < 0.7 else repr(y))
        if multiplicity and r.random() < 0.25:
            line += " %d" % r.choice([1, 2, 2, 3])
        elif multiplicity and r.random() < 0.5:
            line += " 1"
        lines.append(line)
    return lines


def func_file(r, name, old, samples):
    """A function file's text: the old format (`range:`, samples from the
    view file's line) or `fver 1 1` with its own `samples:` (sometimes a
    background and markers, ignored)."""
    if old:
        pts = func_points(r, False)
        sep = r.choice([" ", "\t", "  "])
        return "range: 0.0 1.0\npoints: %d\n%s\n" % (
            len(pts), "\n".join(p.replace(" ", sep) for p in pts))
    pts = func_points(r, True)
    text = "fver 1 1\nname: %s\nsamples: %d\n" % (name, samples)
    if r.random() < 0.15:
        text += "background: leaf.png\n0.0 0.0 1.0 1.0\n"
    if r.random() < 0.15:
        text += "markers: 2\nm1 0.25 0.5\nm2 0.75 0.5\n"
    text += "flip: %s\npoints: %d\n%s\n" % (r.choice(["off", "on"]), len(pts), "\n".join(pts))
    return text


def generate_func(r):
    """The sixth batch: a system that calls func in successors' parameters,
    conditions and blocks, with 1-3 functions of its own (random points,
    the old and the fver format, multiplicities, samples <= 2 for the
    bisection and more for the table), in a view file `case.v` or passed
    directly (an `args` line), sometimes in a function set whose names are
    macros. Returns (text, steps, files, args): files a list of (name,
    text), args None (lsgen reads case.v) or the --functions files."""
    nfun = r.randint(1, 3)
    use_set = r.random() < 0.3
    direct = r.random() < 0.3
    names = r.sample(FUNC_NAMES, nfun)
    files = []
    # the functions' ids in the .l file: numbers, or names from a set
    ids = []
    if use_set:
        # A set, its names as macros (cpfg defines them only when the
        # set is the view file's last function line, and a set drops the
        # functions read before it: the set's line is the only one).
        items = "".join(func_file(r, n, False, r.choice([0, 2, -1, 10, 100, 5]))
                        for n in names)
        files.append(("funcs.fset", "funcgalleryver 1 1\nitems: %d\n%s" % (nfun, items)))
        args = None
        extra = []
        if direct and r.random() < 0.5:
            # passed directly, after a function of its own (lsgen's
            # numbering: in order, so the set's names start at 2)
            extra.append(("first.func", func_file(r, "first", False, r.choice([0, 10]))))
        if direct:
            files = extra + files
            args = [f for f, _ in files]
        else:
            files.insert(0, ("case.v", "/* view file */\nangle factor: 12\n"
                             "function set: funcs.fset\ninitial color: 1\n"))
        base = len(extra)
        ids = ["%s" % n for n in names] + [str(base + i + 1) for i in range(nfun)]
        nall = base + nfun
    else:
        view = ["/* view file of a func case */", "angle factor: 8"]
        args = []
        for i, n in enumerate(names):
            old = r.random() < 0.3
            fname = "%s.func" % n
            samples = r.choice([0, 1, 2, -1, 3, 10, 10, 100, 100, 7])
            if old:
                line = "function: %s" % fname
                vs = r.choice([None, None, 2, 10, 100, 4])
                if vs is not None:
                    line += " %d" % vs
                if direct:
                    line = None  # given directly: -1 samples
            else:
                line = "function: %s" % fname + (" %d" % r.choice([100, 10, 2]) if r.random() < 0.5 else "")
            files.append((fname, func_file(r, n, old, samples)))
            if line:
                view.append(line)
            args.append(fname)
            if r.random() < 0.3:
                view.append(r.choice(["initial line width: 2", "/* a comment */",
                                      "line style: cylinder", "z buffer: on"]))
        if not direct:
            files.insert(0, ("case.v", "\n".join(view) + "\n"))
            args = None
        nall = nfun
        ids = [str(i + 1) for i in range(nfun)]

    def fid(has_x):
        x = r.random()
        i = r.choice(ids)
        if x < 0.15 and i.isdigit():
            return i + "." + str(r.randint(1, 9))  # (int) toward zero
        if x < 0.2 and nall >= 2 and has_x:
            return "(x > 0.5 ? 1 : %d)" % nall
        return i

    in_production = ["x", "x", "x/4", "x*0.3", "x-1", "1-x", "x/(x+1)", "0.5",
                     "x+0.05", "-x", "x*x", "0", "1", "g/3", "t"]
    in_start = ["0.5", "0.2", "1", "0", "-3", "0.999", "2"]
    in_end_each = ["g/4", "g", "t", "1-g"]

    def call(pool=in_production, depth=0):
        a = r.choice(pool)
        if depth == 0 and r.random() < 0.1:
            a = call(pool, 1)
        return "func(%s, %s)" % (fid(pool is in_production), a)

    def pexpr():
        return r.choice(["%s" % call(), "x+%s" % call(), "%s*10" % call(), "x+0.25",
                         "x*2+0.1", "x+0.3", "t", "g+%s" % call(), "(%s)^2" % call(),
                         "trunc(%s*100)" % call(), "%s" % call(), "x/2+%s" % call()])

    def succ():
        return successor(r, pexpr)

    lines = ["Lsystem: 1", "derivation length: %d" % r.randint(1, 4)]
    lines.append(r.choice(["Start: {g = %s; t = 0;}" % call(in_start),
                           "Start: {g = 0.5; t = 0.1;}", "Start: {g = 1; t = 0;}"]))
    if r.random() < 0.4:
        lines.append("EndEach: {g = g + %s;}" % call(in_end_each))
    return axiom_and_productions(r, lines, call, succ, files, args,
                                 ["0", "0.5", "1", "-0.2"], "t > 0.3")


# Array names (none is a module, a variable of these systems or a word of
# cpfg).
ARRAY_NAMES = ["a", "b", "len", "w", "tab", "m2"]


def generate_arrays(r):
    """The eighth batch: a `define:` (or `Define:`) block of 1-3 arrays (1
    or 2 dimensions, sizes 1-5, a dimension sometimes an expression C's
    (int) truncates; initializer lists of the right length, short (0 past
    them), long (the rest ignored) or absent; one or several `array`
    statements, on one line or several) and elements read in successors'
    parameters, conditions, blocks, the axiom and the homomorphism, with
    integer subscripts, sometimes out of range (clamped), sometimes the
    formal parameter, `Q` or a global, and occasionally fractional ones
    that stay inside the array's storage (the index is (int) of the
    row-major offset); elements assigned in `Start:`, `StartEach:`,
    `EndEach:` and pre-/post-condition blocks. Returns (text, steps)."""
    arrays = []  # (name, sizes)
    defs = []
    for name in r.sample(ARRAY_NAMES, r.randint(1, 3)):
        sizes = [r.randint(1, 5) for _ in range(r.choice([1, 1, 2]))]
        dims = []
        for n in sizes:
            k = r.random()
            if k < 0.1:
                dims.append("%d.%d" % (n, r.randint(1, 9)))  # (int) toward zero
            elif k < 0.2:
                dims.append(r.choice(["%d+0", "2*%d/2", "Z-Z+%d"]) % n)
            else:
                dims.append(str(n))
        total = 1
        for n in sizes:
            total *= n
        k = r.random()
        if k < 0.25:
            count = None
        elif k < 0.55:
            count = total
        elif k < 0.8:
            count = r.randint(1, total) if total > 1 else 1
        else:
            count = total + r.randint(1, 3)
        text = name + "".join("[%s]" % d for d in dims)
        if count is not None:
            pool = ["0", "1", "2", "3", "5", "-1", "-2", "0.5", "1.25", "-0.75", "7", "9",
                    "2*3", "1/3", "Z", "Q+1", "10"]
            # an element of an array defined before
            earlier = [a for a in arrays]
            vals = []
            for _ in range(count):
                if earlier and r.random() < 0.1:
                    an, asz = r.choice(earlier)
                    vals.append(an + "".join("[%d]" % r.randint(0, n - 1) for n in asz) + "+1")
                else:
                    vals.append(r.choice(pool))
            if len(vals) > 6 and r.random() < 0.5:
                cut = r.randint(2, len(vals) - 2)
                text += " = {%s,\n\t\t%s}" % (", ".join(vals[:cut]), ", ".join(vals[cut:]))
            else:
                text += " = {%s}" % ", ".join(vals)
        defs.append(text)
        arrays.append((name, sizes))

    def sub(n, var):
        k = r.random()
        if k < 0.5:
            return str(r.randint(0, n - 1))
        if k < 0.65:
            return str(r.choice([n, n + 1, n + 3, -1, -2]))
        cands = ["Q", "Q-1", "g"]
        if var:
            cands += [var, var, "%s-1" % var, "%s+1" % var, "%s%%3" % var]
        return r.choice(cands)

    def ref(var, arr=None):
        name, sizes = arr or r.choice(arrays)
        if r.random() < 0.1:
            # fractional, inside the storage
            if len(sizes) == 1:
                return "%s[%d.%s]" % (name, r.randint(0, sizes[0] - 1), r.choice(["25", "5", "9"]))
            n1, n2 = sizes
            if n1 >= 2 and r.random() < 0.5:
                return "%s[%d.5][%d]" % (name, r.randint(0, n1 - 2), r.randint(0, n2 - 1))
            return "%s[%d][%d.%s]" % (name, r.randint(0, n1 - 1), r.randint(0, n2 - 1),
                                      r.choice(["25", "5", "9"]))
        return name + "".join("[%s]" % sub(n, var) for n in sizes)

    def value(var):
        pool = ["%s+1" % ref(var), "%s*2" % ref(var), "Q", "0.5", "g", "%s-%s" % (ref(var), ref(var)),
                "3", "-1"]
        if var:
            pool += [var, "%s*2" % var, "%s+%s" % (var, ref(var))]
        return r.choice(pool)

    def assign(var):
        return "%s = %s;" % (ref(var), value(var))

    def stmts(var, k):
        return " ".join(assign(var) for _ in range(k))

    def pexpr(var):
        pool = [ref(var), "%s+1" % ref(var), "Q", "%s*%s" % (ref(var), ref(var)), "g"]
        if var:
            pool += [var, "%s+1" % var, "%s+%s" % (var, ref(var)), "%s-1" % var]
        return r.choice(pool)

    def succ(var):
        out = []
        for _ in range(r.randint(1, 3)):
            c = r.choice("ABCF[")
            if c in "ABC":
                out.append("%s(%s)" % (c, pexpr(var)) if r.random() < 0.9 else c)
            elif c == "[":
                out.append("[B(%s)]" % pexpr(var))
            else:
                out.append(c)
        return "".join(out)

    n = r.randint(1, 4)
    lines = ["Lsystem: 1", "derivation length: %d" % n]
    settings = []
    word = "Define:" if r.random() < 0.2 else "define:"
    if r.random() < 0.5:
        define = "%s { array %s; }" % (word, ", ".join(defs))
    else:
        body = []
        i = 0
        while i < len(defs):
            k = r.randint(1, len(defs) - i)
            body.append("\tarray %s;" % ", ".join(defs[i:i + k]))
            i += k
        define = "%s {\n%s\n}" % (word, "\n".join(body))
    settings.append("Start: {g = %s; %s}" % (r.choice(["0", "1", "2"]), stmts(None, r.randint(0, 2))))
    if r.random() < 0.5:
        settings.append("StartEach: {%s}" % stmts(None, r.randint(1, 2)))
    if r.random() < 0.5:
        settings.append("EndEach: {%s}" % r.choice([stmts(None, 1), "g = g + 1; " + stmts(None, 1),
                                                   "g = %s;" % ref(None)]))
    ignore = r.random() < 0.2
    if ignore and r.random() < 0.5:
        settings.append("ignore: F")
        ignore = False
    r.shuffle(settings)
    # (an array is defined by the time a block that uses it is read)
    if ignore:
        lines.append("ignore: F")
    lines.append(define)
    lines += settings
    axiom = []
    for _ in range(r.randint(2, 4)):
        s = r.choice("ABC")
        if r.random() < 0.9:
            arg = str(r.randint(-1, 4)) if r.random() < 0.7 else ref(None)
            axiom.append("%s(%s)" % (s, arg))
        else:
            axiom.append(s)
    lines.append("Axiom: " + "".join(axiom))
    keys = list("ABC") + [r.choice("ABC") for _ in range(r.randint(0, 2))]
    r.shuffle(keys)
    for key in keys:
        var = "x" if r.random() < 0.9 else None
        pred = key + ("(x)" if var else "")
        if r.random() < 0.15:
            pred = r.choice("ABC") + " < " + pred
        k = r.random()
        cond = ""
        if k < 0.3:
            cond = " : " + r.choice(["%s > %s" % (var or "Q", ref(var)),
                                     "%s <> 0" % ref(var), "%s < %s" % (ref(var), ref(var)),
                                     "Q <= %s" % ref(var)])
        elif k < 0.6:
            c = r.choice(["*", "*", "%s > 0" % ref(var), "%s < 3" % (var or "Q")])
            pre = "{%s} " % stmts(var, r.randint(1, 2))
            post = " {%s}" % stmts(var, 1) if r.random() < 0.5 else ""
            if r.random() < 0.3:
                pre, post = "", " {%s}" % stmts(var, r.randint(1, 2))
            cond = " : " + pre + c + post
        lines.append("%s%s --> %s" % (pred, cond, succ(var)))
    if r.random() < 0.25:
        lines.append("homomorphism")
        lines.append("B(x) --> B(%s)" % pexpr("x"))
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", r.randint(0 if r.random() < 0.1 else 1, 4)


# Productions of several modules in a section that the reference applied
# (the tenth batch keeps only cases with one).
SECTION_RUNS = []


def spy_successor(successor):
    """cpfg_ref's Deriver.successor (called for each production applied),
    noting in SECTION_RUNS each predecessor of several modules of the
    decomposition or the homomorphism."""
    def spied(self, p):
        if len(p.pred) > 1 and any(p is q for q in (self.ls.decomp or []) + (self.ls.homo or [])):
            SECTION_RUNS.append(p)
        return successor(self, p)
    return spied


cpfg_ref.Deriver.successor = spy_successor(cpfg_ref.Deriver.successor)


CURVE_KINDS = ["bspline", "bspline", "bspline-closed", "bspline-phantom", "bspline-endpoint",
               "bezier", "spline"]


def contour_file(r):
    """A contour file's text (vlab's `version: 1.4` format): header lines
    in any number, `points: N`, then `range:`, `dimension:` and `type:` in
    some order, N points (x y [z [multiplicity]]), sometimes fewer (cpfg
    fills in the origin)."""
    head = []
    if r.random() < 0.8:
        head.append("version: 1.4")
    for label, n in [("contact:", 3), ("end:", 3), ("heading:", 3), ("up:", 3), ("size:", 1)]:
        if r.random() < 0.6:
            head.append(label + "".join(" %s" % r.choice(["0", "1", "-1", "0.5"]) for _ in range(n)))
    if r.random() < 0.15:
        head.append("// a comment: ignored")
    kind = r.choice(CURVE_KINDS)
    dim = r.choice([2, 3, 4, 4, None])
    npts = r.randint(4, 8) if dim != 4 else r.randint(2, 7)
    after = []
    if r.random() < 0.7:
        after.append("range: 0.0 1.0")
    if dim is not None:
        after.append("dimension: %d" % dim)
    if kind != "bspline" or r.random() < 0.7:
        after.append("type: %s" % kind)
    r.shuffle(after)
    pts = []
    total = 0
    for i in range(npts):
        x = round(r.uniform(-1, 1), 6)
        y = round(r.uniform(-1, 1), 6)
        words = ["%.6f" % x, "%.6f" % y if r.random() < 0.8 else repr(y)]
        if (dim or 2) >= 3:
            words.append(r.choice(["0", "0.000000", "%.6f" % r.uniform(-1, 1)]))
        if dim == 4:
            m = r.choice([1, 1, 1, 2, 3]) if 0 < i < npts - 1 else r.choice([1, 3, 3])
            if r.random() < 0.05:
                m = 0
            words.append(str(m))
            total += m
        else:
            total += 1
        pts.append(r.choice([" ", " ", "\t"]).join(words))
    declared = npts
    if r.random() < 0.08 and total >= 5:
        pts = pts[:-1]  # the last one promised but missing: the origin
    return "\n".join(head + ["points: %d" % declared] + after + pts) + "\n"


def generate_curves(r):
    """The eleventh batch: curveX, curveY, curveZ (t in and out of [0, 1])
    and curveGAL in successors' parameters, conditions, blocks, `Start:`
    and `EndEach:`, with 1-3 contour files of their own and 0-2 functions,
    in a view file (`curve:` lines with or without samples, among
    `function:` lines and other settings) or passed directly. Returns
    (text, steps, files, args)."""
    ncurves = r.randint(1, 3)
    nfuncs = r.choice([0, 0, 1, 1, 2])
    direct = r.random() < 0.3
    files = []
    view = ["/* view file of a curve case */", "angle factor: 8"]
    entries = [("c", i) for i in range(ncurves)] + [("f", i) for i in range(nfuncs)]
    r.shuffle(entries)
    args = []
    for what, i in entries:
        if what == "c":
            name = "c%d.con" % (i + 1)
            files.append((name, contour_file(r)))
            line = "curve: %s" % name
            if r.random() < 0.4:
                line += " %d" % r.choice([2, 3, 10, 50, 100, 200])
            view.append(line)
            args.append(name)
        else:
            name = "f%d.func" % (i + 1)
            files.append((name, func_file(r, "fn%d" % (i + 1), False, r.choice([0, 10, 100]))))
            view.append("function: %s" % name)
            args.append(name)
        if r.random() < 0.3:
            view.append(r.choice(["initial line width: 2", "/* a comment */",
                                  "contour sides: 7", "z buffer: on"]))
    # curves and functions each numbered in order of appearance
    if direct:
        # (a contour file given directly has 100 samples)
        opt = r.choice(["--functions", "--curves"])
        args = [(opt, a) for a in args]
    else:
        files.insert(0, ("case.v", "\n".join(view) + "\n"))
        args = None

    def cid():
        x = r.random()
        i = str(r.randint(1, ncurves))
        if x < 0.1:
            return i + "." + str(r.randint(1, 9))  # (int) toward zero
        return i

    in_production = ["x", "x", "x/4", "x*0.3", "1-x", "x-1", "0.5", "0", "1", "x+0.2",
                     "-x", "g/3", "t", "x*x", "2"]
    in_start = ["0.5", "0.2", "1", "0", "-3", "0.999", "2"]

    def curve(pool=in_production, depth=0):
        k = r.random()
        if k < 0.15:
            return "curveGAL(%s)" % cid()
        a = r.choice(pool)
        if depth == 0 and r.random() < 0.1:
            a = curve(pool, 1)
        c = "curve%s(%s, %s)" % (r.choice("XXYYZ"), cid(), a)
        if nfuncs and depth == 0 and r.random() < 0.15:
            return "func(%d, %s)" % (r.randint(1, nfuncs), c)
        return c

    def call(pool=in_production):
        if nfuncs and r.random() < 0.2:
            return "func(%d, %s)" % (r.randint(1, nfuncs), r.choice(pool))
        return curve(pool)

    def pexpr():
        return r.choice(["%s" % call(), "x+%s" % call(), "%s*10" % call(), "x+0.25",
                         "x*2+0.1", "t", "g+%s" % call(), "(%s)^2" % call(),
                         "trunc(%s*100)" % call(), "%s" % call(), "x/2+%s" % call(),
                         "%s/curveGAL(%s)" % (call(), cid())])

    def succ():
        return successor(r, pexpr)

    lines = ["Lsystem: 1", "derivation length: %d" % r.randint(1, 4)]
    lines.append(r.choice(["Start: {g = %s; t = 0;}" % call(in_start),
                           "Start: {L = curveGAL(1); g = L; t = 0.1;}",
                           "Start: {g = 1; t = 0;}"]))
    if r.random() < 0.4:
        lines.append("EndEach: {g = g + %s;}" % call(["g/4", "g", "t", "1-g"]))
    return axiom_and_productions(r, lines, call, succ, files, args,
                                 ["0", "0.2", "-0.2", "0.5"], "t > 0")


def successor(r, pexpr):
    """A successor of 1-3 modules (A B C with `pexpr()` parameters, a
    branch, F, +) for the func and curves batches."""
    out = []
    for _ in range(r.randint(1, 3)):
        c = r.choice("ABCF+[")
        if c in "ABC":
            out.append("%s(%s)" % (c, pexpr()))
        elif c == "[":
            out.append("[B(%s)]" % pexpr())
        else:
            out.append(c)
    return "".join(out)


def axiom_and_productions(r, lines, call, succ, files, args, bounds, t_test):
    """The end of a `func` or curves case (sixth and eleventh batches): the
    axiom, a production for every module (one of them often false; `call`
    makes a function or curve call, `succ` a successor; `bounds` and
    `t_test` vary the conditions), perhaps a homomorphism. Gives the case
    as its generator does."""
    axiom = "".join("%s(%s)" % (r.choice("ABC"), r.choice(["0", "0.1", "0.5", "1", "2", "-1", "0.75"]))
                    for _ in range(r.randint(1, 3)))
    lines.append("Axiom: " + axiom)
    keys = list("ABC") + [r.choice("ABC") for _ in range(r.randint(0, 1))]
    r.shuffle(keys)
    for key in keys:
        pred = key + "(x)"
        if r.random() < 0.2:
            pred = r.choice("ABC") + " < " + pred
        k = r.random()
        if k < 0.3:
            cond = " : %s > %s" % (call(), r.choice(bounds))
        elif k < 0.45:
            cond = " : %s < %s" % (call(), call())
        elif k < 0.75:
            cond = " : {t = %s;} %s" % (call(), r.choice([t_test, "*", "t <> 1", "x < 3"]))
            if r.random() < 0.3:
                cond += " {g = g + t;}"
        else:
            cond = ""
        lines.append("%s%s --> %s" % (pred, cond, succ()))
    if r.random() < 0.3:
        lines.append("homomorphism")
        lines.append("B(x) --> B(%s)" % call())
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", r.randint(1, 4), files, args


# Outcomes of the conditions of productions that read a query's parameters
# (a `?` in the predecessor or a context), per production, for the twelfth
# batch's statistic: {production: set of outcomes}.
QUERY_CONDITIONS = {}


def spy_try_prod(try_prod):
    """cpfg_ref's Deriver._try_prod, noting in QUERY_CONDITIONS the outcome
    of the condition of a production with a `?` in its predecessor or
    contexts (when the predecessor and the contexts matched)."""
    def spied(self, p, seq, k, S, left, right):
        if p.cond is None or not any(sym == "?" for mods in (p.lc, p.pred, p.rc)
                                     for sym, _ in (mods or [])):
            return try_prod(self, p, seq, k, S, left, right)
        seen = []
        rt = self.rt
        evaluate = rt.eval

        def spied_eval(e):
            v = evaluate(e)
            if e is p.cond:
                seen.append(v != 0)
            return v
        rt.eval = spied_eval
        try:
            return try_prod(self, p, seq, k, S, left, right)
        finally:
            del rt.eval
            if seen:
                QUERY_CONDITIONS.setdefault(p, set()).add(seen[-1])
    return spied


cpfg_ref.Deriver._try_prod = spy_try_prod(cpfg_ref.Deriver._try_prod)

# The homomorphism productions applied while the queries' turtle read the
# string (the thirteenth batch keeps only cases with one), and whether the
# turtle is reading.
HOMO_IN_FILL = []
FILLING = [False]


def spy_fill(fill):
    def spied(self, S, deriver=None):
        FILLING[0] = True
        try:
            return fill(self, S, deriver)
        finally:
            FILLING[0] = False
    return spied


def spy_homo_successor(successor):
    def spied(self, p):
        if FILLING[0] and p in (self.ls.homo or ()):
            HOMO_IN_FILL.append(p)
        return successor(self, p)
    return spied


cpfg_ref.QueryTurtle.fill = spy_fill(cpfg_ref.QueryTurtle.fill)
cpfg_ref.Deriver.successor = spy_homo_successor(cpfg_ref.Deriver.successor)


def generate_queries(r, homomorphism=False, moving=False, movements=False):
    """The twelfth batch: turtle queries `?P`, `?H`, `?L`, `?U` (0-4
    parameters, mostly 2-3) among turtle modules (F, f, G, g with and
    without a length, the turns with and without an angle, `|`, branches,
    `_` and `_(e)`, `%` in branches, `@v`, `@M`, `@o`), with a view file
    `case.v` (`angle factor:` or `angle increment:`, `tropism direction:`,
    small elasticities, `elasticity increment:`, `initial scale:`,
    `interpretation past %:`, `box:`, `environment display:`) given with
    `--cpfg-view`. A key (A) grows in
    branches, each copy followed by a query of the case's watched kind,
    which conditions read through right and left contexts; a predecessor
    may start with the query (`?P(x,y,z) : x < 0 --> ...`), and the
    decomposition sometimes emits queries. `homomorphism`: the thirteenth
    batch (homo_section), the twelfth's cases with a homomorphism that
    cannot change the turtle (cpfg's turtle reads the string through it)
    and `@Gs @Gc(2) @Ge(2) @Gt(1,2) @Gr(1)` (generalized cylinders) in
    successors. `moving`: the fourteenth batch, the thirteenth's with a
    homomorphism that moves the turtle (moves outside its successors'
    brackets, sometimes a production for a move), which cpfg's turtle
    follows. `movements`: the fifteenth batch, the twelfth's with cpfg's
    movements: 1-3 `tropism:` and `torque:` lines in the view (T, and
    often A, E, S, I) and `@Ts`, `@Ti`, `@Td`, `@Tp`, `@Tf` among the
    turtle's modules. Returns (text, steps, files, args)."""
    view = []
    if r.random() < 0.5:
        view.append("angle factor: %d" % r.choice([4, 5, 6, 7, 8, 8, 9, 12, 16]))
    else:
        view.append("angle increment: %s" % r.choice(["30", "45", "22.5", "60", "17.3", "90",
                                                       "36", "12.5"]))
    if r.random() < 0.7:
        view.append("tropism direction: %s" % r.choice([
            "0,-1,0", "1,0,0", "0,1,0", "0,0,1", "1,-1,0", "0.3,-1,0.2", "1,2,2", "-2,1,0.5",
            "0.5,0,-1", "0, -1, 0.25"]))
    if r.random() < 0.65:
        view.append("initial elasticity: %s" % r.choice(["0", "0.05", "0.1", "0.15", "0.2",
                                                         "0.3", "0.25", "0.12"]))
    if r.random() < 0.4:
        view.append("elasticity increment: %s" % r.choice(["0.01", "0.02", "0.05", "0.1",
                                                           "-0.05"]))
    if r.random() < 0.25:
        view.append("initial scale: %s" % r.choice(["0.5", "2", "1.5", "0.75"]))
    if r.random() < 0.35:
        view.append("interpretation past %: off")
    elif r.random() < 0.15:
        view.append("interpretation past %: on")
    if r.random() < 0.3:
        view.append(r.choice(["initial color: 1", "line width: 2", "z buffer: on",
                              "/* a comment */"]))
    # whether cpfg fills the saved string's queries: not with `box:`
    # (no view volume worked out) unless `environment display: before`
    if r.random() < 0.3:
        view.append("box: x: -10,10 y: -10,10 z: -10,10")
    if r.random() < 0.25:
        view.append("environment display: before")
    if movements:
        for _ in range(r.randint(1, 3)):
            line = "%s T: %s" % (r.choice(["tropism:", "tropism:", "torque:"]), r.choice([
                "0,-1,0", "1,0,0", "0, 1, 0", "0 0 1", "1,-1,0", "0.3,-1,0.2", "-2 1 0.5"]))
            if r.random() < 0.4:
                line += " A: %s" % r.choice(["90", "45", "30", "0", "120"])
            if r.random() < 0.7:
                line += " E: %s" % r.choice(["0.1", "0.2", "0.3", "0.05", "0", "0.5"])
            if r.random() < 0.4:
                line += " S: %s" % r.choice(["0.1", "0.05", "-0.1"])
            if r.random() < 0.15:
                line += " I: %s" % r.choice(["0.5", "2", "0.8"])
            view.append(line)
    r.shuffle(view)
    view.insert(0, "/* view file of a query case */")
    files = [("case.v", "\n".join(view) + "\n")]
    args = [("--cpfg-view", "case.v")]

    # each query kind's usual number of parameters in this case, and the
    # kind the conditions watch (with 1-4 parameters)
    nparams = {"P": r.choice([2, 3, 3, 3, 1, 4]), "H": r.choice([2, 3, 3, 0, 1]),
               "L": r.choice([3, 2, 4, 0]), "U": r.choice([3, 2, 1, 0])}
    watched = r.choice("PPPHHLU")
    if not nparams[watched]:
        nparams[watched] = r.choice([2, 3])
    names = ["x", "y", "z", "w"]
    decomposition = r.random() < 0.3

    def query(q=None):
        q = q or r.choice("PPPHHLU")
        k = nparams[q] if r.random() < 0.9 else r.randint(0, 4)
        if k == 0:
            return "?" + q
        return "?%s(%s)" % (q, ",".join(r.choice(["0", "0", "1", "-1", "9"]) for _ in range(k)))

    def turtle(var=None):
        k = r.random()
        ln = r.choice(["1", "0.5", "2", "1.5", "0.75"])
        if var and r.random() < 0.2:
            ln = r.choice(["%s*0.5", "%s+1", "1-%s"]).replace("%s", var)
        ang = r.choice(["30", "45", "90", "20", "75", "120", "15"])
        if var and r.random() < 0.1:
            ang = "%s*60" % var
        if k < 0.3:
            return r.choice(["F", "F(%s)" % ln, "F(%s)" % ln, "f(%s)" % ln, "G", "g",
                             "G(%s)" % ln, "f", "g(%s)" % ln])
        if k < 0.65:
            c = r.choice("+-&^/\\")
            return c + ("(%s)" % ang if r.random() < 0.5 else "")
        if k < 0.72:
            return "|"
        if k < 0.82:
            return r.choice(["_", "_(%s)" % r.choice(["0", "0.1", "0.2", "0.3", "0.05"])])
        if k < 0.9:
            return "@v"
        if movements and k < 0.93:
            return r.choice(["@Ts(1,%s)" % r.choice(["0.2", "0", "0.4", "0.1"]),
                             "@Ts(2,0.3)", "@Ti(1)", "@Td(1)", "@Ti(1,0.1)", "@Td(2,0.05)",
                             "@Tp", "@Tf", "@Ts(1)", "@Ts", "@Ti"])
        if k < 0.96:
            xy = [r.choice(["0", "1", "-1", "2", "0.5", "-1.5"]) for _ in range(3)]
            if var and r.random() < 0.3:
                xy[0] = var
            return "@M(%s)" % ",".join(xy[:r.choice([2, 3])])
        return r.choice(["@o", "@O(1)", "@c(2)", "!", ";", "#(2)", ".", "B", "C"])

    def turtles(lo, hi, var=None):
        return [turtle(var) for _ in range(r.randint(lo, hi))]

    def join(mods):
        text = ""
        for m in mods:
            # `//` and `/*` start comments in the preprocessor
            if text.endswith("/") and m[:1] in "/*":
                text += " "
            text += m
        if text.endswith("\\"):
            text += "(45)"  # (a \ before the newline splices the lines)
        return text

    def branch(inner):
        if r.random() < 0.15:
            # a cut: the rest of the branch goes at the next step, and the
            # turtle skips it when `interpretation past %:` is off
            inner.insert(r.randint(0, len(inner)), "%")
        return "[" + join(inner) + "]"

    def grow(var=None):
        """A's successor: turtle moves, one or two copies of A, each with
        the watched query after it, other queries."""
        out = turtles(1, 3, var)
        for _ in range(r.choice([1, 2, 2])):
            a = turtles(0, 2, var) + ["A", query(watched)]
            if r.random() < 0.2:
                a.insert(-2, query(watched))  # (a left context for A)
            if r.random() < 0.3:
                a.append(query())
            out.append(branch(a) if r.random() < 0.6 else join(a))
        if r.random() < 0.4:
            out.insert(r.randint(0, len(out)), branch(turtles(1, 2, var) + [query()]))
        if homomorphism and r.random() < 0.35:
            out.insert(r.randint(0, len(out)), r.choice(GC_MODULES))
        return out

    def homo_section():
        """The thirteenth batch's homomorphism: productions for A, often C
        (the modules showing the queries) and B, whose successors have
        still modules (K, X, Y, ;(2), !, ...) outside their brackets and
        turtle moves inside them (with @O, @o, %, @G, @v, nested
        branches), sometimes contexts and conditions on queries, and with
        `maximum depth: 2` a production for K or X, which other
        successors make."""
        lines = ["homomorphism"]
        depth2 = r.random() < 0.4
        if depth2:
            lines.append("maximum depth: 2")
        elif r.random() < 0.1:
            lines.append("maximum depth: 1")

        def bracket(var=None):
            inner = turtles(1, 3, var)
            if r.random() < 0.5:
                inner.insert(r.randint(0, len(inner)),
                             r.choice(["@O", "@o", "@O(2)", "%", "[F]", "@v", "[+F(2)]"]
                                      + GC_MODULES))
            return "[" + join(inner) + "]"

        made = []

        def succ(var=None):
            v = var or r.choice(["1", "2", "0.5"])
            parts = []
            for _ in range(r.randint(1, 3)):
                if moving and r.random() < 0.5:
                    # (the fourteenth batch: moves outside the brackets)
                    parts += turtles(1, 2, var)
                elif r.random() < 0.55:
                    parts.append(bracket(var))
                else:
                    m = r.choice(["X", "Y", "K(%s)" % v, "K(%s)" % v, ";(2)", ";", "!", "#(2)",
                                  ".", "E"])
                    made.append(m[0])
                    parts.append(m)
            if not any(p.startswith("[") for p in parts):
                parts.insert(r.randint(0, len(parts)), bracket(var))
            return join(parts)

        fw = formal(watched)
        if r.random() < 0.35:
            # a context (a query) and a condition on it
            v, _ = shows(watched)
            lhs = "A > %s" % fw if r.random() < 0.7 else "%s < A" % fw
            lines.append("%s : %s --> %s" % (lhs, cond_on(watched, nparams[watched]),
                                             succ(v)))
        lines.append("A --> %s" % succ())
        if r.random() < 0.6:
            if r.random() < 0.5:
                lines.append("C(x) : x %s --> %s" % (r.choice(["> 0", "< 0.5", ">= 0"]),
                                                     succ("x")))
            lines.append("C(x) --> %s" % succ("x"))
        if r.random() < 0.4:
            lines.append("B --> %s" % succ())
        if moving and r.random() < 0.3:
            # a production for a move of the string
            lines.append(r.choice(["F(l) --> F(l)-(10)", "F(l) --> F(l*0.5)[+F]F(l*0.5)",
                                   "f(l) --> f(l)+(20)", "F --> f(2)", "+(a) --> +(a*0.5)",
                                   "+ --> -", "_(e) --> _(e*0.5)"]))
        if depth2:
            # a production for a module another successor makes
            if "K" in made or r.random() < 0.5:
                lines.append("K(u) --> %s" % succ("u"))
            else:
                lines.append("X --> %s" % succ())
        return lines

    def cond_on(q, k):
        """A condition on a query q of k parameters named x y z w."""
        v = names[r.randrange(min(k, 3))]
        if q == "P":
            tests = {"x": ["x < 0", "x > 0", "x < -0.5", "x > 0.3"],
                     "y": ["y > %s" % r.choice(["0.5", "1", "1.5", "2", "3"]), "y < 2",
                           "y - x > 1" if k >= 2 else "y < 1"],
                     "z": ["z < 0", "z > 0.1", "z >= 0", "x*x + z*z > 0.5"]}[v]
        else:
            tests = {"x": ["x < 0", "x > 0.3", "x < -0.2", "x >= 0"],
                     "y": ["y > 0.5", "y < 0.9", "y < 0", "y > 0.95"],
                     "z": ["z <= 0", "z > 0.2", "z < -0.3", "z == 0"]}[v]
        t = r.choice(tests)
        if r.random() < 0.15:
            t = "Q > 1 && " + t
        return t

    def formal(q):
        return "?%s(%s)" % (q, ",".join(names[:nparams[q]]))

    def shows(q):
        """Modules that show a query's values (its first three named)."""
        v = names[r.randrange(min(nparams[q], 3))]
        return v, r.choice(["C(%s)" % v, "F(%s+1)" % v, "C(trunc(%s*100))" % v,
                            "[+(%s*90)F]" % v, "C(%s,Q)" % v])

    k = nparams[watched]
    fw = formal(watched)
    prods = []
    # conditions on the query after A (or before it)
    for _ in range(r.randint(1, 2)):
        lhs = "A > %s" % fw if r.random() < 0.75 else "%s < A" % fw
        v, show = shows(watched)
        succ = [show] + turtles(0, 2, v)
        if r.random() < 0.5:
            succ += grow(v)
        r.shuffle(succ)
        prods.append("%s : %s --> %s" % (lhs, cond_on(watched, k), join(succ)))
    # a predecessor that starts with the query
    if r.random() < 0.6:
        q = watched if r.random() < 0.7 else r.choice([c for c in "PHLU" if nparams[c]])
        v, show = shows(q)
        succ = [show] + turtles(0, 1, v)
        r.shuffle(succ)
        if r.random() < 0.75:
            succ.insert(0, formal(q))  # the query stays
        prods.append("%s : %s --> %s" % (formal(q), cond_on(q, nparams[q]), join(succ)))
    # the growth, last: the productions with conditions are tried first
    prods.append("A --> %s" % join(grow() + (["D"] if decomposition and r.random() < 0.6 else [])))
    if r.random() < 0.5:
        prods.append("B --> %s" % join(turtles(1, 2) + [query()]))
    lines = ["Lsystem: 1"]
    steps = r.randint(1, 5)
    lines.append("derivation length: %d" % steps)
    if r.random() < 0.15:
        lines.append(r.choice(["ignore: F f +", "ignore: + - & ^", "ignore: F"]))
    axiom = turtles(0, 2) + ["A", query(watched)] + turtles(0, 2)
    if r.random() < 0.5:
        axiom.append(branch(turtles(1, 2) + ["A", query(watched)]))
    if r.random() < 0.4:
        axiom.append(query())
    lines.append("Axiom: " + join(axiom))
    lines += prods
    if decomposition:
        lines.append("decomposition")
        if r.random() < 0.3:
            lines.append("maximum depth: 2")
        lines.append("D --> %s" % join(turtles(1, 2) + [query()] + turtles(0, 1)))
        if r.random() < 0.4:
            q = r.choice([c for c in "PHLU" if nparams[c]])
            v, show = shows(q)
            lines.append("%s : %s --> %s%s" % (formal(q), cond_on(q, nparams[q]), formal(q), show))
    if homomorphism:
        lines += homo_section()
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", steps, files, args


def generate_order_free(r):
    """The sixteenth batch: systems without what cpfg runs in string
    order (no `seed:`, `ran`, blocks, contexts, predecessors of several
    modules, queries, `/` by anything but a constant other than 0, `Q`, a
    decomposition, a homomorphism's depth or warnings it could say, a
    cut), which lsgen
    may derive depth first and on several threads: parametric keys with
    several productions under conditions (the first that applies), cpfg's
    operators and functions, parameters rounded to 32-bit floats, branches,
    sometimes `ignore:`, a homomorphism (with warnings and a depth from 1
    to 3 only where its successors hold no module it rewrites) and a
    function
    of its own (`func(1, x)`, the view file case.v naming its file).
    Returns (text, steps, files)."""
    files = []
    funcs = r.random() < 0.4
    if funcs:
        files = [("case.v", "/* view file */\nfunction: len.func\n"),
                 ("len.func", func_file(r, "len", False, r.choice([0, 10, 100])))]

    def expr(var):
        a = var if var and r.random() < 0.8 else str(r.choice([0, 1, 2, 3, 0.5, 1.25]))
        if funcs and r.random() < 0.3:
            return r.choice(["func(1,%s)", "%s+func(1,%s*0.3)", "func(1.5,0.5)*%s"]).replace("%s", a)
        e = r.choice([
            "%s+1", "%s*2", "%s-1", "%s/2", "%s/3", "%s^2", "-%s", "%s%%3", "trunc(%s/3)",
            "(%s>1?%s:1)", "!%s", "Z-%s", "%s*0.1+0.05", "sin(%s)", "sqrt(%s*%s)",
            "%s*1.456", "%s/1.456+0.3", "floor(%s*2.5)", "%s&&1", "%s||0", "exp(%s/10)",
            "atan(%s)", "%s", "%s",
        ])
        return e.replace("%s", a).replace("%%", "%")

    def module(var, syms=SYMS):
        s = r.choice(syms)
        if s in "AB" or r.random() < 0.4:
            n = 2 if s == "B" else 1
            return "%s(%s)" % (s, ",".join(expr(var) for _ in range(n)))
        return s

    def succ(var, depth=0, syms=SYMS):
        out = []
        for _ in range(r.randint(1, 4)):
            x = r.random()
            if x < 0.55:
                out.append(module(var, syms))
            elif x < 0.7:
                out.append("F(%s)" % expr(var) if var else "F")
            elif x < 0.85:
                out.append(r.choice(["+", "-", "+(22.5)", "-(%s)" % expr(var)]))
            elif depth < 2:
                out.append("[" + succ(var, depth + 1, syms) + "]")
        return "".join(out) or "*"

    lines = ["Lsystem: 1", "derivation length: %d" % r.randint(2, 6)]
    if r.random() < 0.2:
        lines.append(r.choice(["ignore: F +", "ignore: C", "consider: A B"]))
    lines.append("Axiom: " + "".join(
        r.choice(["A(%d)" % r.randint(-1, 4), "B(%d,%s)" % (r.randint(0, 3), r.choice(["1", "0.5"])),
                  "C", "D(1)", "[A(2)]", "F"]) for _ in range(r.randint(1, 4))))
    for s, formal in [("A", "A(x)"), ("B", "B(x,y)"), ("C", "C"), ("D", "D(x)")]:
        var = "x" if "(" in formal else None
        for k in range(r.randint(0, 3)):
            cond = ""
            if var and r.random() < 0.7:
                cond = " : " + r.choice([
                    "x > 1", "x <> 2", "x %% 2 == 0", "x >= 1 && x < 3", "!(x == 1) || x > 3",
                    "x < Z", "y > x" if s == "B" else "x > 0.5", "*"]).replace("%%", "%")
            lines.append("%s%s --> %s" % (formal, cond, succ(var)))
    if r.random() < 0.4:
        # With warnings (depth 1), its successors hold no module it
        # rewrites: the warning could not be said, and one application is
        # all there is.
        warn = r.random() < 0.5
        lines.append("homomorphism" if warn else "homomorphism: no warnings")
        if warn and r.random() < 0.5:
            # (Any depth from 1: it applies once.)
            lines.append("maximum depth: %d" % r.randint(1, 3))
        for formal in r.sample(["A(x)", "C", "D(x)"], r.randint(1, 2)):
            var = "x" if "(" in formal else None
            lines.append("%s --> %s" % (formal, succ(var, syms="BEG" if warn else SYMS)))
    lines.append("endlsystem")
    return "\n".join(lines) + "\n", r.randint(1, 6), files


def derive(text, steps, files=(), args=None):
    """The reference's string, or None if it refuses the system. `files`:
    (name, text) written beside case.l; `args`: the --functions files (by
    default case.v if there is one)."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "case.l")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        for name, body in files:
            with open(os.path.join(d, name), "w", encoding="utf-8") as f:
                f.write(body)
        if args is None:
            args = ["case.v"] if any(n == "case.v" for n, _ in files) else []
        # (an `--functions` or `--curves` file: the same option)
        functions = [os.path.join(d, a if isinstance(a, str) else a[1]) for a in args
                     if isinstance(a, str) or a[0] != "--cpfg-view"]
        view = [os.path.join(d, a[1]) for a in args
                if not isinstance(a, str) and a[0] == "--cpfg-view"]
        try:
            # Warnings (undefined names, division by zero) are printed by
            # the reference; they are not part of the expected output.
            with contextlib.redirect_stderr(io.StringIO()):
                return cpfg_ref.run_file(path, steps, functions=functions,
                                         view=view[0] if view else None)
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
    fifth = fourth + ALTERNATIVES
    sixth = fifth + FUNC
    seventh = sixth + FORMALS
    eighth = seventh + ARRAYS
    ninth = eighth + STRINGS
    # Each batch has a generator of its own, seeded where the batch starts
    # (once: a case the reference refuses is tried again from where the
    # generator stands). The first four batches were made when the seed was
    # set again at each try; their first tries are all kept, so that is the
    # same.
    eleventh = ninth + MULTI_SECTIONS
    twelfth = eleventh + CURVES
    thirteenth = twelfth + QUERIES
    fourteenth = thirteenth + HOMO_QUERIES
    fifteenth = fourteenth + MOVING_QUERIES
    sixteenth = fifteenth + MOVEMENT_QUERIES
    seeds = {CASES: 13, CASES + EXTENDED: 14, third: 15, fourth: 16, fifth: 17, sixth: 18,
             seventh: 19, eighth: 20, ninth: 21, eleventh: 22, twelfth: 23, thirteenth: 24,
             fourteenth: 25, fifteenth: 26, sixteenth: 27}
    # the twelfth and thirteenth batches: cases with a condition on a
    # query's values that was both true and false
    both_ways = [0, 0, 0, 0]
    while made < sixteenth + ORDER_FREE:
        if made in seeds:
            r = random.Random(seeds.pop(made))
        tried += 1
        late = third <= made < fourth
        alt = fourth <= made < fifth
        files, args = [], None
        if made >= sixteenth:
            text, steps, files = generate_order_free(r)
        elif made >= fifteenth:
            text, steps, files, args = generate_queries(r, movements=True)
        elif made >= fourteenth:
            text, steps, files, args = generate_queries(r, homomorphism=True, moving=True)
        elif made >= thirteenth:
            text, steps, files, args = generate_queries(r, homomorphism=True)
        elif made >= twelfth:
            text, steps, files, args = generate_queries(r)
        elif made >= eleventh:
            text, steps, files, args = generate_curves(r)
        elif made >= ninth:
            text, steps = generate(r, True, False, False, False, multi_sections=True)
        elif made >= eighth:
            text, steps = generate(r, True, False, False, False, strings=True)
        elif made >= seventh:
            text, steps = generate_arrays(r)
        elif made >= sixth:
            text, steps = generate(r, True, False, False, False, formals=True)
        elif made >= fifth:
            text, steps, files, args = generate_func(r)
        else:
            text, steps = generate(
                r, CASES <= made < fourth, CASES + EXTENDED <= made < third, late, alt
            )
        del SECTION_RUNS[:]
        QUERY_CONDITIONS.clear()
        del HOMO_IN_FILL[:]
        out = derive(text, steps, files, args)
        # lsgen refuses a parameter a 32-bit float cannot hold (README), where
        # cpfg stores inf.
        limit = MAX_OUTPUT_QUERIES if twelfth <= made < sixteenth else MAX_OUTPUT
        if out is None or len(out) > limit or "inf" in out or "nan" in out:
            continue
        if ninth <= made < eleventh and not SECTION_RUNS:
            # (no predecessor of several modules of a section applied)
            continue
        if thirteenth <= made < fifteenth and not HOMO_IN_FILL:
            # (no homomorphism production applied while the turtle read)
            continue
        if fourteenth <= made < fifteenth and not any(cpfg_ref.homomorphism_moves(p)
                                          for p in HOMO_IN_FILL):
            # (none that moves the turtle)
            continue
        if made >= seventh and "(" not in out:
            # (a string without parameters shows too little)
            continue
        both = any(len(v) == 2 for v in QUERY_CONDITIONS.values())
        if twelfth <= made < sixteenth and not both and r.random() < 0.5:
            # (most cases have a condition on a query both true and false)
            continue
        sections = "".join("--- file %s\n%s" % (name, body) for name, body in files)
        if args is not None:
            sections += "--- args %s\n" % " ".join(
                ("--functions %s" % a) if isinstance(a, str) else "%s %s" % a for a in args)
        parts.append("=== %d\n%s%s--- expected\n%s\n" % (steps, text, sections, out))
        if twelfth <= made < sixteenth and both:
            both_ways[(made >= thirteenth) + (made >= fourteenth) + (made >= fifteenth)] += 1
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
    print("queries batch: %d of %d cases have a condition on a query that was both true "
          "and false" % (both_ways[0], QUERIES))
    print("queries with a homomorphism batch: %d of %d cases have a condition on a query "
          "that was both true and false" % (both_ways[1], HOMO_QUERIES))
    print("queries with a moving homomorphism batch: %d of %d cases have a condition on a "
          "query that was both true and false" % (both_ways[2], MOVING_QUERIES))
    print("queries with movements batch: %d of %d cases have a condition on a query that "
          "was both true and false" % (both_ways[3], MOVEMENT_QUERIES))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
