#!/usr/bin/env python3
"""Independent reference for cpfg (L-studio / vlab) `.l` files.

A deliberately simple, in-memory implementation of the subset of cpfg that a
string rewriter can reproduce, written from /work/shared/cpfg-behaviour.md,
issue 12 and a reading of cpfg's sources (vlab commit 9bf820d: generate.c,
lsys_input.l, lsys_input.y, utility.c, control.c, interpret.c).  No code is
shared with lsgen or copied from cpfg.  It judges lsgen's cpfg dialect: the
expected strings in tests/expected/cpfg/ come from here.

Usage:
    python3 tests/tools/cpfg_ref.py FILE.l [-n STEPS] [--no-homomorphism]
                                    [--functions FILE ...] [--cpfg-view FILE.v]
    python3 tests/tools/cpfg_ref.py --self-test

Prints the final string on one line (cpfg's own `-str` file wraps lines at 70
characters; this prints one line, as lsgen does).  Parameters are stored as
32-bit floats and printed with C's %g.  By default the homomorphism (if any)
is applied to the derived string, up to its `maximum depth:`; with
--no-homomorphism the derived string itself is printed (what cpfg saves).

Supported: a C-preprocessor subset (#define object-like and function-like,
#undef, #include "file", #if/#ifdef/#ifndef/#elif/#else/#endif with integer
expressions, #error, /* */ and // comments, backslash-newline), the cpfg
layout (Lsystem:, settings in any order, Start:/StartEach:/EndEach:/End:
blocks, Axiom:, productions with --> (and lsgen's ->), decomposition,
homomorphism, endlsystem), newline+TAB continuation, cpfg expressions and
statements, deterministic and stochastic choice, cpfg context matching,
the cut symbol %, drand48 seeded as interactive cpfg seeds it, the
ran/nran/bran/biran/srand generator, and func(id, x) (splinefun.cpp,
splinearr.cpp, interpret.c's `function:` and `function set:`, generate.c's
PreprocessLsystem), and curveX/curveY/curveZ/curveGAL.

func: each --functions FILE (repeatable, in order) is, by its first line, a
function set (`funcgalleryver 1 1`), one function (`fver 1 1` or
`range: LOW HIGH`) or else a view file, of which only the `function: FILE
[SAMPLES]` and `function set: FILE` lines count (label before the first
`:`, blanks collapsed; paths relative to the view file).  The functions are
numbered from 1 in the order met; a function set's names (C identifiers)
are object-like macros for their numbers.  A function is the uniform open
cubic B-spline of its points (read as 32-bit floats, a point repeated by its
multiplicity), evaluated as SplineFunction::GetValue: x clamped to [0, 1],
then the bisection on the curve's parameter until its x is within 0.001,
or, with more than 2 samples, a table of that at i/(samples-1) read with
linear interpolation.  Samples: the file's `samples:`, the view line's
SAMPLES for the old format (-1 without, or given directly; 100 in a
function set).  Refused: fewer than 4 points, a bisection that never ends
(cpfg hangs), func of NaN, an id out of range (cpfg warns and gives 0).

Curves (curveXYZ.cpp, curveXYZc.cpp; interpret.c's `curve: FILE
[SAMPLES]`, 100 samples without a number; a contour file given directly
with --functions, by its `version:` first line or `.con` name, has 100):
a table apart from the functions, numbered from 1 in the order met.  The
contour file is read line by line as openCurve/readCurve do: labels
(`version:`, `contact:`, `end:`, `heading:`, `up:`, `size:`, `points:`,
`range:`, `dim:`/`dimension:`, `type:`, `//`) by prefix, their numbers
checked with sscanf's rules; other lines longer than 2 characters and
without `:` are points of `dimension` words (2: x y, 3: x y z, 4: x y z
multiplicity; atof), points that `points: N` promises but the file lacks
are the origin.  The kinds (calcPValue): `bspline` (any unknown word too:
uniform knots 0, 1, 2, ...), `bspline-closed` (three more points),
`bspline-phantom` (mirrored end points), `bspline-endpoint` (clamped
knots), `bezier`.  createAPoints samples the curve at i/(SAMPLES-1), sums
the chords (curveGAL) and divides the partial sums by the total;
curveX/Y/Z(id, t) clamp t to [0, 1], find the chord by bisection on the
index and interpolate the parameter (calcAValue).  Refused: a line
without its newline or past cpfg's 255 bytes, a point before `points:`
or past N, a nested `points:`, `dimension:`/`type:` before `points:`, a
dimension other than 2-4, a negative multiplicity, `bezier-surface`,
fewer than 4 points, SAMPLES below 2, an id out of range, a NaN t, and
0 / 0 in the interpolation (a curve of length 0).

Arrays (lsys_input.y's Defines, ArrayDef, LHS and Name with ArrayRefs;
generate.c's AllocateArray, InitializeArray, ProcessArrayDef, the
tARRAYREF / tARRAYLHS evaluation and AssignArrayElement): `define: {
array A[d1][d2] = {e, ...}, B[n]; ... }` among the settings (only `array`
statements; a later block replaces the earlier one, whose arrays stay
defined with their values as read).  Dimensions: (int) of their values
when the file is read, each at least 1, at most 2^20 elements.  The
initializers run when the file is read (as many as there are elements)
and, for the last block, again right before Start: (0 past the
initializers).  An array is one global of doubles; an element `A[i][j]`
in any expression or as the left side of an assignment (the value is
evaluated before the subscripts): each subscript out of [0, size) is
replaced by 0 or size - 1, the index is (int)((s1 * size2 + s2) ...)
row-major; an index past the storage (fractional subscripts) or a NaN
subscript is an error (cpfg reads outside the array).  Errors: an array
name without subscripts, subscripts on a non-array, the wrong number of
subscripts, a name defined twice (or used before its definition).  An
array named Q or Z hides the global (cpfg's tables).

Queries (interpret.c's InterpretSymbol and bend, blackbox.c's @v and @M,
generate.c's SkipCutPart and Derive): `?P(x,y,z)` is two modules, `?` and
`P`, and likewise `?H`, `?L`, `?U`, in any module list (axiom,
successors, predecessors, contexts). A file with queries needs its view
file (--cpfg-view, whose `function:` / `curve:` lines also count, before
those of --functions). Its string is interpreted from the start by a
turtle (position 0, H = (0,1,0), L = (-1,0,0), U = (0,0,-1)) before each
step, on the string the step rewrites (before StartEach:), and at the
end (not with `box:`, unless `environment display: before`): each `?`
writes the position (P) or the vector (H, L, U) into the
first min(3, n) parameters of the module after it, as floats. The turtle:
`+ - & ^ / \ |` (the view's `angle increment:` or `angle factor:`, or
the parameter in degrees), `F G f g` (the parameter or 1, times `initial
scale:`, then the tropism's bend with `tropism direction:` and the
elasticity: `initial elasticity:`, `_(e)`, `_` adds `elasticity
increment:`), `[ ]`, `%` (with `interpretation past %: off`: the rest of
the branch is not interpreted), `@v`, `@M(x,y[,z])`; all else does not
move it (`@o @O @c`, `@Gs @Gc @Ge @Gt @Gr` too). With a homomorphism the
turtle reads the string through it, as cpfg's does (InterpretHomomorphism:
each module's production, contexts read in the string being filled, its
successor interpreted in turn to `maximum depth:`, `%` ignored there; the
module after a `?` or an `@` is read directly). Refused in a file with
queries: a homomorphism production with a pre- or post-condition block, a
probability, a call to ran/nran/bran/biran/srand, a predecessor module
among `[ ] ? @ % $ ~`, a successor with `%` or `$` outside its own
brackets, a `]` closing nothing or a `[` not closed in it, or a `?`; and
where the homomorphism can move the turtle (a predecessor module among
`F f G g + - & ^ / \ | _`, or a successor with a module of `F f G g + -
& ^ / \ | _ [ ] @ ~ ? % $` outside its own brackets): a predecessor
module that a `?` or an `@` reads (read past the homomorphism), a
query module in a left context (cpfg reads it filled already), and in
its successors, branches too, what is refused in the strings (below; a
bend past 1 there too, where cpfg's NaN would be discarded by the `]`);
`~`, `@` other than `@o @O @c @v @M`, `@G` + `s c e t r` and `@T` +
`i d s p f x` (below), `s` with 2 or 3 parameters (cpfg's old position
query; not `@Ts(i,e)`); in its strings an unmatched `]`, a `?` not
followed by P, H, L or U, a bend with a sine outside [-1, 1] (but in a
homomorphism successor's branch: cpfg's NaN, which its `]` discards).

Movements (movements.c, turtle.c's adjust_up_and_left, quaternions.c,
blackbox.c's case 'T'; all in doubles, in cpfg's operation order; class
Movements). The view's `tropism:` (label 32) and `torque:` (33) lines:
fgets gives the rest of the line after the label's `:` (newline
included), read_movement tokenizes it: the first word by strtok(" \t:"),
the next ones by strtok(" \t:\n"), each command by its first letter; a
number by strtok(" ,\t:") and atof (so `T: 1,0,0`, `T 1 0 0`, `Tropism:
1 0 0` are one). `T x,y,z`: the direction, len = 1/|T| (a 0 vector:
ignored); `I i`: len *= i (0: ignored), clamped to [-1, 1] (the clamp is
on len = i/|T|, not on i); `A a`: gamma in degrees (default 0); `E e`:
the initial elasticity (0); `S s`: @T's increment (0). The direction is T
* len (without `T`: the slot's old direction, times 0). Ignored (cpfg
says so, the reference warns): an unknown command, a 0 vector or
intensity, an 11th movement; an ignored line leaves its fields in the
slot for the next one. The global sums: for a tropism gea,geb,gec += cos
gamma * e * T, esin = e sin gamma; for a torque twist += e T, length
|twist|; updated incrementally (update_movement(i, delta): the global
elasticity += delta, the sums by cos gamma * delta * T, esin += delta *
sin gamma when cos/sin gamma != 0, twist by delta T). They persist for the
whole run: each interpretation (fill) starts (InitializeTurtle) by giving
each turtle elasticity its initial value and calling update_movement(i,
initial - current global elasticity), so rounding residues carry from
one fill to the next (one state per derivation run, on the QueryTurtle).
Before each F G f g (before the move; the old `tropism direction:` bend
after it): movement_adjust: des = the sums, plus for each tropism with
sin gamma != 0 esin/|H x T| * T x (H x T) (H parallel to T: the left
vector instead of H x T, length 1) -- cpfg's loop runs to i <=
number_of_movements, one entry past the last, whose sin gamma is 0 (it
adds nothing; 10 movements, where that entry is outside cpfg's arrays,
are refused); rot = H x des; if |rot| >= 1e-6, H turns by min(|rot|, 1)
rad towards des (the quaternion q^-1 v q) and adjust_up_and_left; then a
nonzero twist: with d = twist/|twist|, v = H x d, if v.v > 1e-8, des =
(v x H) * length and U turns by min(|U x des|, 1) rad about U x des in
q^-1 v q's sense (away from des), if |U x des| >= 1e-7 (then L = H x U),
and prev H/U are set. adjust_up_and_left: when |H x prevH| > 1e-6, U is
prevU turned by the rotation taking prevH to H (asin, or pi/2 minus it
when H.prevH < 0): a roll since the last F G is undone; L = H x U always.
prevH/prevU: set at the turtle's start, after F and G (not f g), by @Tf,
in the twist part; saved by `[` with the turtle. Each turtle (saved with
`[`) has its own elasticities; at `]` each movement whose saved value
differs from the current one gets update_movement(i, saved - current).
@T (call_blackbox): T without parameter, then the subfunction module;
index = (short)(its first parameter - 1) (truncated; out of [0, n):
ignored, @Tp/@Tf too), 0 without one; the amount: its second parameter,
else the movement's S. `i` +amount, `d` -amount, `s` sets (second
parameter - turtle elasticity, or to 0): applied to the turtle's and the
global elasticity only when the subfunction has a parameter; `p`
adjust_up_and_left, `f` prevH/prevU = H/U; `x(n)` a texture (nothing).
In a homomorphism successor @T changes the global sums (a branch's `]`
gives them back by a difference): a successor with `@T` counts as one
that moves the turtle. Refused: a movement line cpfg crashes on (a
number missing: atof of NULL), a non-finite or hexadecimal number, a line
past fgets' 254 bytes, 10 movements, @T with parameters on the T (cpfg
reads T again as a module), @T at the end of a string or module list,
@Tx without a parameter (likewise), other subfunctions, an index outside
a C short.

Refused with an error (a string rewriter cannot do them, or the reference
does not model them): ?E, ?Q, a ? not followed by P, H, L or U,
sub-L-systems (?(id,s), $, several Lsystem: blocks), `external` in define:, @S,
vv*/play/stop/fopen/fscanf/..., ring L-systems, -o> object
productions, % with parameters, & addresses.
"""

import argparse
import math
import os
import re
import struct
import sys


class CpfgError(Exception):
    def __init__(self, msg, where=None):
        Exception.__init__(self, msg)
        self.msg = msg
        self.where = where

    def __str__(self):
        if self.where:
            return "%s:%d: %s" % (self.where[0], self.where[1], self.msg)
        return self.msg


WARNINGS = []


def warn(msg, where=None):
    if where:
        msg = "%s:%d: %s" % (where[0], where[1], msg)
    WARNINGS.append(msg)
    sys.stderr.write("cpfg_ref.py: warning: %s\n" % msg)


# ---------------------------------------------------------------------------
# 32-bit floats and %g
# ---------------------------------------------------------------------------


def f32(v):
    try:
        return struct.unpack("<f", struct.pack("<f", v))[0]
    except OverflowError:
        return math.copysign(math.inf, v)


def fmt_g(v):
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return "%g" % v


# ---------------------------------------------------------------------------
# drand48 family (48-bit LCG, a = 0x5DEECE66D, c = 0xB), written from the
# POSIX description: X' = (a X + c) mod 2^48, result X' / 2^48.
# ---------------------------------------------------------------------------

A48 = 0x5DEECE66D
C48 = 0xB
M48 = (1 << 48) - 1


class Rand48:
    def __init__(self, x):
        self.x = x & M48

    def next(self):
        self.x = (A48 * self.x + C48) & M48
        return self.x / float(1 << 48)

    @staticmethod
    def from_xsubi(x0, x1, x2):
        return Rand48(((x2 & 0xFFFF) << 32) | ((x1 & 0xFFFF) << 16) | (x0 & 0xFFFF))


class Randomness:
    """cpfg's two generators.

    main: drand48()'s global state.  Interactive cpfg calls
    seed48({seed, 0, 155}) when the file's `seed:` is non-zero; otherwise
    drand48 starts from glibc's unseeded state (X = 0).
    xsubi: main_xsubi of utility.c, used by ran/nran/bran/biran through
    erand48; it starts as {0x330E, 0, 0} (as after srand(0)) and srand(x)
    sets it to {0x330E, x & 0xFFFF, (x >> 16) & 0xFFFF}.
    """

    def __init__(self, seed):
        if seed != 0:
            self.main = Rand48.from_xsubi(seed & 0xFFFF, 0, 155)
        else:
            self.main = Rand48(0)
        self.xsubi = Rand48.from_xsubi(0x330E, 0, 0)
        # nrand's state: iset starts at 10 (not 0), so the first nran()
        # before any srand() returns gset (0) * sd + mean = mean.
        self.iset = 10
        self.gset = 0.0

    def srand(self, a):
        self.xsubi = Rand48.from_xsubi(0x330E, a & 0xFFFF, (a >> 16) & 0xFFFF)
        self.iset = 0

    def ran(self, v):
        return self.xsubi.next() * v

    def nran(self, mean, sd):
        if self.iset == 0:
            while True:
                v1 = 2.0 * self.xsubi.next() - 1.0
                v2 = 2.0 * self.xsubi.next() - 1.0
                rsq = v1 * v1 + v2 * v2
                if not (rsq >= 1.0 or rsq == 0.0):
                    break
            fac = math.sqrt(-2.0 * math.log(rsq) / rsq)
            self.gset = v1 * fac
            self.iset = 1
            return v2 * fac * sd + mean
        self.iset = 0
        return self.gset * sd + mean

    def bran(self, a, b):
        s = a + b
        if min(a, b) <= 1:
            lam = min(a, b)
        else:
            lam = math.sqrt((2 * a * b - s) / (s - 2))
        u = a + lam
        while True:
            u1 = self.xsubi.next()
            while u1 == 0:
                u1 = self.xsubi.next()
            u2 = self.xsubi.next()
            while u2 == 0:
                u2 = self.xsubi.next()
            v = (1 / lam) * math.log(u1 / (1 - u1))
            ym = a * math.exp(v)
            if not (s * math.log(s / (b + ym)) + u * v - math.log(4) < math.log(u1 * u1 * u2)):
                return ym / (b + ym)

    def biran(self, n, p):
        j = 0
        for _ in range(1, n + 1):
            if self.xsubi.next() <= p:
                j += 1
        return float(j)


# ---------------------------------------------------------------------------
# Preprocessor subset
# ---------------------------------------------------------------------------

PP_TOKEN = re.compile(
    r"(?P<nl>\n)|(?P<ws>[ \t\r\f\v]+)|(?P<id>[A-Za-z_$][A-Za-z0-9_$]*)"
    r"|(?P<num>\.?[0-9](?:[eEpP][+-]|[A-Za-z0-9_.])*)"
    r'|(?P<str>"(?:\\.|[^"\\\n])*")'
    # a character constant, not macro-expanded; vlabcpp (cccp.c) ends one
    # that is not closed at the end of its line, with a message, and goes on
    r"|(?P<chr>'(?:\\.|[^'\\\n])*'?)|(?P<other>.)",
    re.S,
)


class Tok:
    __slots__ = ("kind", "text", "painted")

    def __init__(self, kind, text, painted=False):
        self.kind = kind
        self.text = text
        self.painted = painted

    def copy(self):
        return Tok(self.kind, self.text, self.painted)


def pp_lex(text):
    return [Tok(m.lastgroup, m.group()) for m in PP_TOKEN.finditer(text)]


class Macro:
    def __init__(self, params, body):
        self.params = params  # None for object-like
        self.body = body


def splice_and_strip(text, fname):
    """Backslash-newline splices (the removed newlines are put back after the
    joined line) and comments (one space followed by the comment's
    newlines), keeping the file's line count."""
    text = text.replace("\r\n", "\n")
    lines = text.split("\n")
    out = []
    i = 0
    while i < len(lines):
        cur = lines[i]
        extra = 0
        while cur.endswith("\\") and i + 1 < len(lines):
            cur = cur[:-1] + lines[i + 1]
            i += 1
            extra += 1
        out.append(cur)
        out.extend([""] * extra)
        i += 1
    s = "\n".join(out)
    res = []
    i = 0
    n = len(s)
    while i < n:
        c = s[i]
        if c in "\"'":
            j = i + 1
            while j < n and s[j] != c and s[j] != "\n":
                j += 2 if s[j] == "\\" and j + 1 < n and s[j + 1] != "\n" else 1
            if j < n and s[j] == c:
                j += 1
            elif c == "'":
                # a ' not closed on its line: cccp keeps the rest of the
                # line, and cpfg's scanner skips a /* */ comment in it
                res.append(c)
                i += 1
                continue
            res.append(s[i:j])
            i = j
        elif s.startswith("/*", i):
            k = s.find("*/", i + 2)
            if k < 0:
                raise CpfgError("unterminated comment", (fname, s.count("\n", 0, i) + 1))
            res.append(" " + "\n" * s.count("\n", i, k))
            i = k + 2
        elif s.startswith("//", i):
            k = s.find("\n", i)
            k = n if k < 0 else k
            res.append(" ")
            i = k
        else:
            res.append(c)
            i += 1
    return "".join(res)


class Preprocessor:
    def __init__(self):
        self.macros = {}
        self.include_stack = []
        self.lines = []  # (text, (file, line))

    def run(self, path):
        self.include(path, None)
        return self.lines

    def include(self, path, where):
        real = os.path.realpath(path)
        # As cpp: a file may include itself (an include guard ends the
        # recursion); only the depth is limited (gcc's cpp: 200 files).
        if len(self.include_stack) >= 200:
            raise CpfgError("#include nested too deeply (a recursion without end?)", where)
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise CpfgError("cannot read %s: %s" % (path, e.strerror), where)
        self.include_stack.append(real)
        self.process(splice_and_strip(text, path), path)
        self.include_stack.pop()

    def process(self, text, fname):
        lines = text.split("\n")
        if lines and lines[-1] == "" and text.endswith("\n"):
            lines.pop()
        cond = []  # [parent_active, active, taken, seen_else]
        chunk = []
        chunk_start = 0

        def active():
            return not cond or cond[-1][1]

        def flush():
            if chunk:
                self.emit_chunk(chunk, fname, chunk_start)
                del chunk[:]

        for idx, line in enumerate(lines):
            lineno = idx + 1
            where = (fname, lineno)
            stripped = line.lstrip(" \t")
            m = re.match(r"#[ \t]*([A-Za-z_]\w*)?", stripped)
            is_dir = bool(m) and (m.group(1) is not None or stripped[m.end():].strip() == "")
            if not is_dir:
                if stripped.startswith("#") and active():
                    warn("line taken as a directive in cpfg, kept as text", where)
                if active():
                    if not chunk:
                        chunk_start = lineno
                    chunk.append(line)
                else:
                    flush()
                    self.lines.append(("", where))
                continue
            flush()
            name = m.group(1) or ""
            rest = stripped[m.end():]
            if name in ("ifdef", "ifndef"):
                ident = rest.strip()
                if not re.fullmatch(r"[A-Za-z_$][A-Za-z0-9_$]*", ident):
                    raise CpfgError("#%s needs one name" % name, where)
                val = (ident in self.macros) == (name == "ifdef")
                par = active()
                cond.append([par, par and val, par and val, False])
            elif name == "if":
                par = active()
                val = par and self.eval_if(rest, where) != 0
                cond.append([par, val, val, False])
            elif name == "elif":
                if not cond or cond[-1][3]:
                    raise CpfgError("#elif without #if", where)
                c = cond[-1]
                if c[0] and not c[2]:
                    v = self.eval_if(rest, where) != 0
                    c[1] = v
                    c[2] = v
                else:
                    c[1] = False
            elif name == "else":
                if not cond or cond[-1][3]:
                    raise CpfgError("#else without #if", where)
                c = cond[-1]
                c[1] = c[0] and not c[2]
                c[2] = True
                c[3] = True
            elif name == "endif":
                if not cond:
                    raise CpfgError("#endif without #if", where)
                cond.pop()
            elif not active():
                pass
            elif name == "define":
                self.define(rest, where)
            elif name == "undef":
                self.macros.pop(rest.strip(), None)
            elif name == "include":
                mm = re.fullmatch(r'\s*"([^"]+)"\s*', rest)
                if not mm:
                    raise CpfgError('#include needs "file"', where)
                target = os.path.join(os.path.dirname(fname), mm.group(1))
                self.include(target, where)
                continue
            elif name == "error":
                raise CpfgError("#error%s" % rest, where)
            elif name == "":
                pass
            else:
                raise CpfgError("unknown directive #%s" % name, where)
            self.lines.append(("", where))
        flush()
        if cond:
            raise CpfgError("unterminated #if", (fname, len(lines)))

    def define(self, rest, where):
        m = re.match(r"[ \t]*([A-Za-z_$][A-Za-z0-9_$]*)", rest)
        if not m:
            raise CpfgError("#define needs a name", where)
        name = m.group(1)
        body = rest[m.end():]
        params = None
        if body.startswith("("):
            k = body.find(")")
            if k < 0:
                raise CpfgError("unterminated macro parameter list", where)
            plist = body[1:k].strip()
            params = [p.strip() for p in plist.split(",")] if plist else []
            for p in params:
                if not re.fullmatch(r"[A-Za-z_$][A-Za-z0-9_$]*", p):
                    raise CpfgError("bad macro parameter %r" % p, where)
            body = body[k + 1:]
        toks = pp_lex(body.strip(" \t"))
        if any(t.text == "#" for t in toks) and params is not None:
            for i, t in enumerate(toks):
                if t.text == "#":
                    nxt = [u for u in toks[i + 1:] if u.kind != "ws"]
                    if nxt and (nxt[0].text == "#" or nxt[0].text in params):
                        raise CpfgError("# and ## in macros are not supported by the reference", where)
        self.macros[name] = Macro(params, toks)

    def expand(self, toks, active, where):
        out = []
        i = 0
        while i < len(toks):
            t = toks[i]
            if t.kind == "id" and not t.painted and t.text in self.macros:
                name = t.text
                if name in active:
                    p = t.copy()
                    p.painted = True
                    out.append(p)
                    i += 1
                    continue
                m = self.macros[name]
                if m.params is None:
                    out.extend(self.expand([b.copy() for b in m.body], active | {name}, where))
                    i += 1
                    continue
                j = i + 1
                nl = 0
                while j < len(toks) and toks[j].kind in ("ws", "nl"):
                    nl += toks[j].kind == "nl"
                    j += 1
                if j >= len(toks) or toks[j].text != "(":
                    out.append(t)
                    i += 1
                    continue
                depth = 0
                args = [[]]
                k = j + 1
                while k < len(toks):
                    tk = toks[k]
                    if tk.text == "(":
                        depth += 1
                    elif tk.text == ")":
                        if depth == 0:
                            break
                        depth -= 1
                    elif tk.text == "," and depth == 0:
                        args.append([])
                        k += 1
                        continue
                    if tk.kind == "nl":
                        nl += 1
                        tk = Tok("ws", " ")
                    args[-1].append(tk)
                    k += 1
                if k >= len(toks):
                    raise CpfgError("unterminated call of macro %s" % name, where)
                args = [[a for a in arg] for arg in args]
                for a in args:
                    while a and a[0].kind == "ws":
                        a.pop(0)
                    while a and a[-1].kind == "ws":
                        a.pop()
                if not m.params and len(args) == 1 and not args[0]:
                    args = []
                if len(args) != len(m.params):
                    raise CpfgError(
                        "macro %s takes %d argument(s), %d given" % (name, len(m.params), len(args)),
                        where,
                    )
                exp_args = [self.expand(a, active, where) for a in args]
                body = []
                for b in m.body:
                    if b.kind == "id" and b.text in m.params:
                        body.extend(x.copy() for x in exp_args[m.params.index(b.text)])
                    else:
                        body.append(b.copy())
                out.extend(self.expand(body, active | {name}, where))
                out.extend(Tok("pnl", "") for _ in range(nl))
                i = k + 1
                continue
            out.append(t)
            i += 1
        return out

    def emit_chunk(self, chunk, fname, start):
        toks = pp_lex("\n".join(chunk) + "\n")
        for t in toks:
            if t.kind == "chr" and (len(t.text) < 2 or not t.text.endswith("'")):
                warn("unterminated character constant (kept as it is)", (fname, start))
        out = self.expand(toks, frozenset(), (fname, start))
        text = []
        pending = 0
        for t in out:
            if t.kind == "pnl":
                pending += 1
            elif t.kind == "nl":
                text.append("\n" * (1 + pending))
                pending = 0
            else:
                text.append(t.text)
        s = "".join(text)
        if s.endswith("\n"):
            s = s[:-1]
        for k, line in enumerate(s.split("\n")):
            self.lines.append((line, (fname, start + k)))

    def eval_if(self, text, where):
        toks = pp_lex(text)
        res = []
        i = 0
        while i < len(toks):
            t = toks[i]
            if t.kind == "id" and t.text == "defined":
                j = i + 1
                while j < len(toks) and toks[j].kind == "ws":
                    j += 1
                paren = j < len(toks) and toks[j].text == "("
                if paren:
                    j += 1
                    while j < len(toks) and toks[j].kind == "ws":
                        j += 1
                if j >= len(toks) or toks[j].kind != "id":
                    raise CpfgError("defined needs a name", where)
                val = toks[j].text in self.macros
                j += 1
                if paren:
                    while j < len(toks) and toks[j].kind == "ws":
                        j += 1
                    if j >= len(toks) or toks[j].text != ")":
                        raise CpfgError("missing ) after defined", where)
                    j += 1
                res.append(Tok("num", "1" if val else "0"))
                i = j
                continue
            res.append(t)
            i += 1
        res = self.expand(res, frozenset(), where)
        items = []
        i = 0
        while i < len(res):
            t = res[i]
            if t.kind in ("ws", "nl", "pnl"):
                i += 1
                continue
            if t.kind == "id":
                items.append(("num", 0))
            elif t.kind == "num":
                s = t.text.rstrip("uUlL")
                try:
                    items.append(("num", int(s, 0) if not re.fullmatch(r"0[0-7]+", s) else int(s, 8)))
                except ValueError:
                    raise CpfgError("bad number %r in #if" % t.text, where)
            else:
                two = t.text + (res[i + 1].text if i + 1 < len(res) else "")
                if two in ("&&", "||", "==", "!=", "<=", ">=", "<<", ">>"):
                    items.append(("op", two))
                    i += 2
                    continue
                items.append(("op", t.text))
            i += 1
        return IntExpr(items, where).parse()


class IntExpr:
    BIN = [
        ("||",),
        ("&&",),
        ("|",),
        ("^",),
        ("&",),
        ("==", "!="),
        ("<", "<=", ">", ">="),
        ("<<", ">>"),
        ("+", "-"),
        ("*", "/", "%"),
    ]

    def __init__(self, items, where):
        self.items = items + [("end", None)]
        self.pos = 0
        self.where = where

    def peek(self):
        return self.items[self.pos]

    def take(self):
        self.pos += 1
        return self.items[self.pos - 1]

    def parse(self):
        v = self.cond()
        if self.peek()[0] != "end":
            raise CpfgError("bad #if expression", self.where)
        return v

    def cond(self):
        c = self.binary(0)
        if self.peek() == ("op", "?"):
            self.take()
            a = self.cond()
            if self.take() != ("op", ":"):
                raise CpfgError("bad #if expression", self.where)
            b = self.cond()
            return a if c else b
        return c

    def binary(self, lvl):
        if lvl == len(self.BIN):
            return self.unary()
        v = self.binary(lvl + 1)
        while self.peek()[0] == "op" and self.peek()[1] in self.BIN[lvl]:
            op = self.take()[1]
            w = self.binary(lvl + 1)
            if op in ("/", "%") and w == 0:
                raise CpfgError("division by zero in #if", self.where)
            v = {
                "||": lambda: int(bool(v) or bool(w)),
                "&&": lambda: int(bool(v) and bool(w)),
                "|": lambda: v | w,
                "^": lambda: v ^ w,
                "&": lambda: v & w,
                "==": lambda: int(v == w),
                "!=": lambda: int(v != w),
                "<": lambda: int(v < w),
                "<=": lambda: int(v <= w),
                ">": lambda: int(v > w),
                ">=": lambda: int(v >= w),
                "<<": lambda: v << w,
                ">>": lambda: v >> w,
                "+": lambda: v + w,
                "-": lambda: v - w,
                "*": lambda: v * w,
                "/": lambda: int(v / w) if (v < 0) != (w < 0) else v // w,
                "%": lambda: v - w * (int(v / w) if (v < 0) != (w < 0) else v // w),
            }[op]()
        return v

    def unary(self):
        t = self.take()
        if t[0] == "num":
            return t[1]
        if t == ("op", "("):
            v = self.cond()
            if self.take() != ("op", ")"):
                raise CpfgError("missing ) in #if", self.where)
            return v
        if t[0] == "op" and t[1] in "!~-+":
            v = self.unary()
            return {"!": int(not v), "~": ~v, "-": -v, "+": v}[t[1]]
        raise CpfgError("bad #if expression", self.where)


# ---------------------------------------------------------------------------
# cpfg's lexer (lsys_input.l): states SYMBOL and EXPRESSION
# ---------------------------------------------------------------------------

KEYWORDS = [
    (re.compile(r"(Lsystem|lsystem):"), "LSTART", "SYMBOL"),
    (re.compile(r"(seed|Seed):"), "SEED", "EXPRESSION"),
    (re.compile(r"(D|d)erivation ?(L|l)ength:"), "DLENGTH", "EXPRESSION"),
    (re.compile(r"(M|m)aximum (D|d)epth:"), "MDEPTH", "EXPRESSION"),
    (re.compile(r"(consider|Consider):"), "CONSIDER", None),
    (re.compile(r"(ignore|Ignore):"), "IGNORE", None),
    (re.compile(r"(axiom|Axiom):"), "AXIOM", None),
    (re.compile(r"(define|Define):"), "DEFINE", "EXPRESSION"),
    (re.compile(r"(R|r)ing (L|l)system"), "RING", None),
    (re.compile(r"(start|Start):"), "STARTBLOCK", "EXPRESSION"),
    (re.compile(r"(end|End):"), "ENDBLOCK", "EXPRESSION"),
    (re.compile(r"(start|Start) ?(each|Each):"), "STARTEACH", "EXPRESSION"),
    (re.compile(r"(end|End) ?(each|Each):"), "ENDEACH", "EXPRESSION"),
    (re.compile(r"(H|h)omomorphism:?"), "STARTHOMO", None),
    (re.compile(r"(D|d)ecomposition:?"), "STARTDECOMP", None),
    (re.compile(r"no warnings"), "NOWARNING", None),
    (re.compile(r"warnings"), "WARNING", None),
    (re.compile(r"(E|e)nd(L|l)system"), "END", None),
]

FUNCTIONS = {
    "tan": 1, "sin": 1, "cos": 1, "atan": None, "asin": 1, "acos": 1,
    "atan2": None, "ran": 1, "nran": 2, "bran": 2, "biran": 2, "srand": 1,
    "exp": 1, "log": 1, "floor": 1, "ceil": 1, "trunc": 1, "fabs": 1,
    "sign": 1, "sqrt": 1, "printf": None, "fprintf": None, "func": 2,
    "curveX": 2, "curveY": 2, "curveZ": 2, "curveGAL": 1,
}
UNSUPPORTED_FUNCTIONS = {
    "play", "vvXmin",
    "vvXmax", "vvYmin", "vvYmax", "vvZmin", "vvZmax", "vvScale", "Display",
    "SetDerivationLength", "GetDerivationLength", "stop", "fopen", "fclose",
    "fflush", "fscanf", "inblob", "external", "array",
}
STATEMENT_WORDS = {"if", "while", "do", "else"}

NAME_RE = re.compile(r"[a-zA-Z][a-zA-Z0-9_]*")
REAL_RE = re.compile(r"[0-9]+\.[0-9]*(?:[Ee][-+]?[0-9]+)?|[0-9]*\.[0-9]+(?:[Ee][-+]?[0-9]+)?|[0-9]+")
STR_RE = re.compile(r'"[^"\n]*["\n]')
EXPR_OPS = ["-->", "->", "-o>", "<>", "!=", "==", "<=", ">=", "&&", "||",
            "=", "&", "+", "-", "*", "/", "%", "^", ";", ",", "?", ":",
            "(", ")", "[", "]", "<", ">", "!", "{", "}"]


class Lexer:
    def __init__(self, lines):
        self.text = "\n".join(t for t, _ in lines) + "\n"
        self.origins = [o for _, o in lines] or [("?", 1)]
        self.line_starts = [0]
        for i, c in enumerate(self.text):
            if c == "\n":
                self.line_starts.append(i + 1)

    def where(self, pos):
        lo, hi = 0, len(self.line_starts) - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.line_starts[mid] <= pos:
                lo = mid
            else:
                hi = mid - 1
        return self.origins[min(lo, len(self.origins) - 1)]

    def tokens(self):
        s = self.text
        n = len(s)
        i = 0
        state = "INITIAL"
        nesting = 0
        braces = 0  # cpfg's c_expression: open { of blocks
        out = []
        while i < n:
            c = s[i]
            w = self.where(i)
            if c in " \t":
                i += 1
                continue
            if c == "\n":
                if i + 1 < n and s[i + 1] == "\t":
                    i += 2
                    continue
                i += 1
                if braces == 0:
                    state = "SYMBOL"
                    out.append(("EOL", None, w))
                continue
            # keywords are active in every state; they win ties
            best = None
            for rx, kind, newstate in KEYWORDS:
                m = rx.match(s, i)
                if m and (best is None or m.end() > best[0].end()):
                    best = (m, kind, newstate)
            other_len = 0
            if state == "EXPRESSION":
                m2 = NAME_RE.match(s, i)
                if m2:
                    other_len = m2.end() - i
            if best and best[0].end() - i >= other_len:
                m, kind, newstate = best
                out.append((kind, m.group(), w))
                if newstate:
                    state = newstate
                i = m.end()
                continue
            if state == "SYMBOL":
                if s.startswith("-->", i):
                    out.append(("YIELDS", "-->", w))
                    i += 3
                elif s.startswith("-o>", i):
                    out.append(("OYIELDS", "-o>", w))
                    i += 3
                elif s.startswith("->", i):  # lsgen's extension; cpfg has only -->
                    out.append(("YIELDS", "->", w))
                    i += 2
                elif c == "*":
                    out.append(("NULL", c, w))
                    i += 1
                elif c == ")":
                    out.append(("NULL", c, w))
                    i += 1
                elif c == ":":
                    nesting = 1
                    state = "EXPRESSION"
                    out.append(("COLON", c, w))
                    i += 1
                elif c == "<":
                    out.append(("LSEP", c, w))
                    i += 1
                elif c == ">":
                    out.append(("RSEP", c, w))
                    i += 1
                elif c == "(":
                    nesting = 1
                    state = "EXPRESSION"
                    out.append(("LPAREN", c, w))
                    i += 1
                else:
                    out.append(("SYMBOL", c, w))
                    i += 1
                continue
            if state == "EXPRESSION":
                if c == "\\":
                    # lsys_input.l has no rule for a backslash in the
                    # EXPRESSION state: flex's default rule echoes it and
                    # scanning goes on (vlab's `#define f(x) \\` idiom).
                    i += 1
                    continue
                m = NAME_RE.match(s, i)
                if m:
                    out.append(("NAME", m.group(), w))
                    i = m.end()
                    continue
                m = STR_RE.match(s, i)
                if m:
                    # lsys_input.l ProcessString: \n \t \r, \x is x
                    body = re.sub(r"\\(.)", lambda e: {"n": "\n", "t": "\t", "r": "\r"}.get(
                        e.group(1), e.group(1)), m.group()[1:-1], flags=re.S)
                    # Its number in cpfg's global string table (control.c's
                    # GlobalStringIndex: every string the parser meets, in
                    # order; 255 places, the last one's number past them).
                    self.strings = getattr(self, "strings", 0) + 1
                    out.append(("STRING", (body, min(self.strings - 1, 254)), w))
                    i = m.end()
                    continue
                m = REAL_RE.match(s, i)
                if m:
                    j = m.end()
                    if j < n and s[j] in "eE" and "." not in m.group():
                        raise CpfgError("cpfg needs a dot in an exponent literal (1.0e6, not 1e6)", w)
                    out.append(("VALUE", float(m.group()), w))
                    i = j
                    continue
                for op in EXPR_OPS:
                    if s.startswith(op, i):
                        break
                else:
                    raise CpfgError("unexpected character %r in an expression" % c, w)
                i += len(op)
                if op in ("-->", "->"):
                    state = "SYMBOL"
                    out.append(("YIELDS", op, w))
                elif op == "-o>":
                    state = "SYMBOL"
                    out.append(("OYIELDS", op, w))
                elif op == "(":
                    nesting += 1
                    out.append(("LPAREN", op, w))
                elif op == ")":
                    nesting -= 1
                    if nesting == 0:
                        state = "SYMBOL"
                    out.append(("RPAREN", op, w))
                elif op == "{":
                    nesting += 1
                    braces += 1
                    out.append(("LBRACE", op, w))
                elif op == "}":
                    nesting -= 1
                    if braces > 0:
                        braces -= 1
                    out.append(("RBRACE", op, w))
                elif op == "<>":
                    out.append(("OP", "!=", w))
                elif op == "=":
                    out.append(("ASSIGN", op, w))
                elif op == "&":
                    raise CpfgError("& (address) is not supported", w)
                elif op in (";", ",", "?", ":", "[", "]"):
                    out.append(({";": "SEMI", ",": "COMMA", "?": "QUESTION", ":": "COLON",
                                 "[": "LBRACKET", "]": "RBRACKET"}[op], op, w))
                else:
                    out.append(("OP", op, w))
                continue
            raise CpfgError("unexpected %r before Lsystem:" % c, w)
        out.append(("EOF", None, self.where(n - 1)))
        return out


# ---------------------------------------------------------------------------
# Parser (lsys_input.y, subset)
# ---------------------------------------------------------------------------


class Cell:
    __slots__ = ("name", "value")

    def __init__(self, name, value=0.0):
        self.name = name
        self.value = value


class ArrayCell:
    """An array of `define:` (generate.c's AllocateArray): one copy for the
    whole run, in the L-system's symbol table (a global); its values are
    doubles, in row-major order."""

    MAX_ELEMENTS = 1 << 20

    def __init__(self, name, sizes, inits, where):
        self.name = name
        self.sizes = sizes
        self.total = 1
        for n in sizes:
            self.total *= n
        self.inits = inits  # list of expressions, or None
        self.where = where
        self.values = [0.0] * self.total


class Production:
    def __init__(self, where):
        self.where = where
        self.lc = None  # list of (sym, [Cell]) in file order
        self.pred = None
        self.rc = None
        self.pre = []
        self.cond = None  # None: always true
        self.post = []
        self.succ = []  # list of (sym, [expr])
        self.prob = None
        self.has_pre = False  # a pre-condition block (even an empty one)
        self.has_post = False


class LSystem:
    def __init__(self):
        self.homo_moves = False  # the homomorphism can move the query turtle
        self.n = 0
        self.seed = 0
        self.stochastic = False
        self.ignore = set()
        self.consider = None
        self.start = []
        self.end = []
        self.start_each = []
        self.end_each = []
        self.define = []  # the arrays of the last define: block, in order
        self.axiom = []
        self.prods = []
        self.decomp = None  # list of productions or None
        self.decomp_depth = 1
        self.decomp_warning = True
        self.homo = None
        self.homo_depth = 1
        self.homo_seed = -1
        self.homo_warning = True
        self.queries = False  # ?P ?H ?L ?U somewhere: the turtle fills them


# precedence (lsys_input.y): ?: < || < && < == != < relational < + - < * / %
# < ^ < unary - < !, all binary operators left-associative.
BIN_LEVELS = [("||",), ("&&",), ("==", "!="), ("<", "<=", ">", ">="), ("+", "-"),
              ("*", "/", "%"), ("^",)]


class Parser:
    def __init__(self, toks, rt):
        self.toks = toks
        self.pos = 0
        self.rt = rt  # Runtime, for expressions evaluated while parsing
        self.globals = {}
        self.lsys_table = {}
        self.tables = [self.lsys_table, self.globals]
        self.ls = LSystem()
        self.section = "L"
        self.all_lists = []  # every module list of the file, with where
        self.hom_lists = []  # the homomorphism's successors, with where
        self.has_query = False  # a ?P ?H ?L ?U somewhere

    def peek(self, k=0):
        return self.toks[min(self.pos + k, len(self.toks) - 1)]

    def take(self):
        t = self.peek()
        self.pos += 1
        return t

    def err(self, msg, t=None):
        t = t or self.peek()
        return CpfgError(msg, t[2])

    def expect(self, kind, what=None):
        t = self.take()
        if t[0] != kind:
            shown = t[1] if t[1] is not None else t[0]
            raise self.err("expected %s, found %r" % (what or kind, shown), t)
        return t

    def eols(self):
        while self.peek()[0] == "EOL":
            self.take()

    # -- names ------------------------------------------------------------
    def lookup(self, name, t, assign=False):
        for tab in self.tables:
            if name in tab:
                return tab[name]
        if not assign:
            warn("identifier %s not previously defined (it is 0)" % name, t[2])
        cell = Cell(name)
        self.tables[0][name] = cell
        return cell

    # -- file -------------------------------------------------------------
    def parse(self):
        self.eols()
        self.expect("LSTART", "Lsystem:")
        while self.peek()[0] not in ("EOL", "EOF"):
            self.take()
        self.expect("EOL", "end of line")
        ls = self.ls
        while True:
            t = self.peek()
            k = t[0]
            if k == "EOL":
                self.take()
            elif k == "RING":
                raise self.err("ring L-systems are not supported by the reference")
            elif k == "SEED":
                self.take()
                ls.stochastic = True
                ls.seed = c_int(self.rt.eval(self.expression()))
                self.expect("EOL", "end of line")
            elif k == "DLENGTH":
                self.take()
                ls.n = c_int(self.rt.eval(self.expression()))
                # A later line sets the length but adds a second `Z` to
                # cpfg's symbol table (SymbolTableAdd appends), which
                # SymbolTableFind never reaches: `Z` keeps the first value.
                if not getattr(self, "dlength_seen", False):
                    self.rt.z_cell.value = float(ls.n)
                self.dlength_seen = True
                self.globals["Q"] = self.rt.q_cell
                self.globals["Z"] = self.rt.z_cell
                self.expect("EOL", "end of line")
            elif k in ("IGNORE", "CONSIDER"):
                self.take()
                chars = []
                while self.peek()[0] == "SYMBOL":
                    chars.append(self.take()[1])
                if not chars:
                    raise self.err("expected symbols")
                self.expect("EOL", "end of line")
                # a later ignore:/consider: line replaces the earlier one
                if k == "IGNORE":
                    ls.ignore, ls.consider = set(chars), None
                else:
                    ls.ignore, ls.consider = set(), set(chars)
            elif k == "DEFINE":
                self.take()
                # Defines: tDEFINE DefineBlock tEOL; cpfg keeps the last
                # block (LsysPtr->defineBlock = $2), whose arrays it
                # initializes again at the start of the run; the arrays of
                # an earlier block stay defined with the values their
                # initializers had when the file was read.
                ls.define = self.define_block()
                self.expect("EOL", "end of line")
            elif k in ("STARTBLOCK", "ENDBLOCK", "STARTEACH", "ENDEACH"):
                self.take()
                block = self.block()
                self.expect("EOL", "end of line")
                attr = {"STARTBLOCK": "start", "ENDBLOCK": "end",
                        "STARTEACH": "start_each", "ENDEACH": "end_each"}[k]
                setattr(ls, attr, block)
            elif k == "AXIOM":
                self.take()
                where = self.peek()[2]
                ls.axiom = self.modules()
                self.check_queries(ls.axiom, where)
                if not ls.axiom:
                    raise self.err("the axiom is empty")
                self.expect("EOL", "end of line")
                break
            else:
                raise self.err("expected a setting or Axiom:, found %r" % (t[1] or k))
        ls.prods = self.productions()
        if self.peek()[0] == "STARTDECOMP":
            self.take()
            if self.peek()[0] in ("WARNING", "NOWARNING"):
                ls.decomp_warning = self.take()[0] == "WARNING"
            self.expect("EOL", "end of line")
            self.eols()
            if self.peek()[0] == "MDEPTH":
                self.take()
                ls.decomp_depth = c_int(self.rt.eval(self.expression()))
                self.expect("EOL", "end of line")
            self.section = "D"
            ls.decomp = self.productions()
        if self.peek()[0] == "STARTHOMO":
            self.take()
            if self.peek()[0] in ("WARNING", "NOWARNING"):
                ls.homo_warning = self.take()[0] == "WARNING"
            self.expect("EOL", "end of line")
            while True:
                self.eols()
                if self.peek()[0] == "SEED":
                    self.take()
                    ls.homo_seed = c_int(self.rt.eval(self.expression()))
                    self.expect("EOL", "end of line")
                elif self.peek()[0] == "MDEPTH":
                    self.take()
                    ls.homo_depth = c_int(self.rt.eval(self.expression()))
                    self.expect("EOL", "end of line")
                else:
                    break
            self.section = "H"
            ls.homo = self.productions()
        self.expect("END", "endlsystem")
        self.eols()
        t = self.peek()
        if t[0] == "LSTART":
            raise self.err("several L-systems in one file (sub-L-systems) are not supported")
        if t[0] != "EOF":
            raise self.err("unexpected text after endlsystem")
        if self.has_query:
            self.check_query_file()
        return ls

    # -- turtle queries ?P ?H ?L ?U ---------------------------------------
    def check_queries(self, mods, where, branches_restore=False):
        """A `?` must be the query `?P`, `?H`, `?L` or `?U`: no parameters
        on the `?` (sub-L-systems), one of those modules right after it in
        the same list (`?E`, `?Q` and others are refused). Every list is
        kept for check_query_file; a homomorphism's successor
        (`branches_restore`) apart: check_query_file checks it only where
        the homomorphism can move the turtle; else it has only still
        modules outside its branches, and whatever a branch holds, its `]`
        gives the whole turtle back."""
        if not branches_restore:
            self.all_lists.append((mods, where))
        else:
            self.hom_lists.append((mods, where))
        for i, (sym, params) in enumerate(mods):
            if sym != "?":
                continue
            if params:
                raise CpfgError("?(id, s) (sub-L-systems) is not supported", where)
            if i + 1 == len(mods):
                raise CpfgError("? at the end of a module list: a query is ?P, ?H, ?L or ?U",
                                where)
            q = mods[i + 1][0]
            if q in "EQ":
                raise CpfgError("?%s is not supported (queries: ?P ?H ?L ?U)" % q, where)
            if q not in QUERY_MODULES:
                raise CpfgError("?%s: a query is ?P, ?H, ?L or ?U" % q, where)
            self.has_query = True

    def check_query_file(self):
        """What a file with queries may not have (the turtle of the queries
        does not model it): a homomorphism production that could change
        the turtle (check_followed_homomorphism), `~` (surfaces), `@` other
        than `@o @O @c @v @M`, `@G` + `s c e t r` and `@T` (without
        parameters) + `i d s p f x` (`x` with a parameter), `s` with 2 or 3
        parameters."""
        homo = self.ls.homo or []
        for p in homo:
            check_followed_homomorphism(p)
        # A homomorphism that can move the turtle: the turtle reads its
        # successors' modules too (branches included), and cpfg reads the
        # module after a `?` or an `@` from the string, past the
        # homomorphism (not modelled: refused where it has a production).
        self.ls.homo_moves = any(homomorphism_moves(p) for p in homo)
        lists = self.all_lists
        if self.ls.homo_moves:
            lists = self.all_lists + self.hom_lists
            queried, read = read_past(lists)
            for p in homo:
                for sym, _ in p.pred:
                    if sym in read:
                        raise CpfgError("a homomorphism predecessor %s, which a ? or an @ reads, "
                                        "in a file with queries is not supported" % sym, p.where)
                # cpfg reads a homomorphism's contexts in the string as it
                # fills it: a query module on the left is filled already,
                # which lsgen (reading an image of the string made before
                # the fill) does not model
                for sym, _ in p.lc or []:
                    if sym in queried:
                        raise CpfgError("a homomorphism left context %s, which a query fills, "
                                        "in a file with queries is not supported" % sym, p.where)
        for mods, where in lists:
            for i, (sym, params) in enumerate(mods):
                # (@Ts(i,e) is @T's subfunction: call_blackbox reads it)
                if sym == "s" and len(params) in (2, 3) and not (
                        i >= 2 and mods[i - 1][0] == "T" and not mods[i - 1][1] and mods[i - 2][0] == "@"):
                    # interpret.c's `case 's'` (backward compatibility): in
                    # the environment pass before each step, s(x,y[,z])
                    # gets the position, as ?P does; not modelled
                    raise CpfgError("s with 2 or 3 parameters in a file with queries is not "
                                    "supported (cpfg's old position query)", where)
                if sym == "~":
                    raise CpfgError("~ (surfaces) in a file with queries is not supported", where)
                if sym == "@":
                    nxt = mods[i + 1][0] if i + 1 < len(mods) else ""
                    if nxt == "T":
                        # movements (blackbox.c's case 'T'): cpfg reads the
                        # subfunction when T has no parameter
                        if mods[i + 1][1]:
                            raise CpfgError("@T with parameters in a file with queries is not "
                                            "supported (cpfg reads T again as a module)", where)
                        sub, sv = mods[i + 2] if i + 2 < len(mods) else ("", ())
                        if sub not in T_SUBFUNCTIONS:
                            raise CpfgError("@T%s in a file with queries is not supported "
                                            "(the turtle knows @Ti @Td @Ts @Tp @Tf @Tx)" % sub,
                                            where)
                        if sub == "x" and not sv:
                            raise CpfgError("@Tx without a parameter in a file with queries is "
                                            "not supported (cpfg reads T and x again as "
                                            "modules)", where)
                    elif nxt == "G":
                        sub = mods[i + 2][0] if i + 2 < len(mods) else ""
                        if sub not in GC_SUBFUNCTIONS:
                            raise CpfgError("@G%s in a file with queries is not supported "
                                            "(the turtle knows @Gs @Gc @Ge @Gt @Gr)" % sub,
                                            where)
                    elif nxt not in BLACKBOX_KNOWN:
                        raise CpfgError("@%s in a file with queries is not supported "
                                        "(the turtle knows @o @O @c @v @M @G @T)" % nxt, where)
        self.ls.queries = True

    def productions(self):
        prods = []
        while True:
            self.eols()
            if self.peek()[0] in ("STARTDECOMP", "STARTHOMO", "END", "EOF"):
                return prods
            prods.append(self.production())

    # -- productions ------------------------------------------------------
    def production(self):
        p = Production(self.peek()[2])
        table = {}
        self.tables = [table, self.lsys_table, self.globals]
        first = self.formal_or_null()
        if self.peek()[0] == "LSEP":
            self.take()
            p.lc = first
            p.pred = self.formal_or_null()
        else:
            p.pred = first
        if p.pred is None:
            raise self.err("a strict predecessor cannot be *")
        if self.peek()[0] == "RSEP":
            self.take()
            p.rc = self.formal_or_null()
            if p.rc and p.rc[-1][0] == "=":
                raise self.err("= cannot end a right context (cpfg crashes)")
        for sym, _ in p.pred:
            self.check_symbol(sym, p.where)
        for mods in (p.lc, p.pred, p.rc):
            if mods:
                self.check_queries(mods, p.where)
        if self.peek()[0] == "COLON":
            self.take()
            if self.peek()[0] == "LBRACE":
                p.pre = self.block()
                p.has_pre = True
            if self.peek() == ("OP", "*", self.peek()[2]) and self.peek(1)[0] in ("YIELDS", "OYIELDS", "LBRACE"):
                self.take()
            else:
                p.cond = self.expression()
            if self.peek()[0] == "LBRACE":
                p.post = self.block()
                p.has_post = True
        t = self.take()
        if t[0] == "OYIELDS":
            raise self.err("-o> (object productions) are not supported", t)
        if t[0] != "YIELDS":
            raise self.err("expected -->, found %r" % (t[1] or t[0]), t)
        if self.peek()[0] == "NULL" and self.peek()[1] == "*":
            self.take()
            p.succ = []
        else:
            p.succ = self.modules()
            self.check_queries(p.succ, p.where, branches_restore=self.section == "H")
        if self.peek()[0] == "COLON":
            self.take()
            p.prob = self.expression()
            if not self.ls.stochastic and self.section == "L":
                warn("probability given for a deterministic production (no seed:): ignored", p.where)
        self.expect("EOL", "end of line")
        self.tables = [self.lsys_table, self.globals]
        return p

    def check_symbol(self, sym, where):
        # (`?` is checked with the modules after it: check_queries)
        if sym == "$":
            raise CpfgError("$ (end of a sub-L-system) is not supported", where)

    def formal_or_null(self):
        if self.peek()[0] == "NULL" and self.peek()[1] == "*":
            self.take()
            return None
        mods = []
        while self.peek()[0] == "SYMBOL":
            t = self.take()
            cells = []
            if self.peek()[0] == "LPAREN":
                self.take()
                while True:
                    nt = self.expect("NAME", "a formal parameter")
                    if nt[1] in FUNCTIONS or nt[1] in UNSUPPORTED_FUNCTIONS or nt[1] in STATEMENT_WORDS:
                        raise self.err("%s is reserved" % nt[1], nt)
                    if nt[1] in self.tables[0]:
                        # SymbolTableAdd: an error in cpfg
                        raise self.err("multiple definition of formal parameter %s" % nt[1], nt)
                    cell = Cell(nt[1])
                    self.tables[0][nt[1]] = cell
                    cells.append(cell)
                    if self.peek()[0] == "COMMA":
                        self.take()
                        continue
                    break
                self.expect("RPAREN", ")")
            mods.append((t[1], cells))
        if not mods:
            raise self.err("expected a module")
        return mods

    def modules(self):
        mods = []
        while self.peek()[0] == "SYMBOL":
            t = self.take()
            self.check_symbol(t[1], t[2])
            if t[1] == "S" and mods and mods[-1][0] == "@":
                raise CpfgError("@S is not supported", t[2])
            params = []
            if self.peek()[0] == "LPAREN":
                self.take()
                while True:
                    params.append(self.expression())
                    if self.peek()[0] == "COMMA":
                        self.take()
                        continue
                    break
                self.expect("RPAREN", ")")
                if t[1] == "%":
                    raise CpfgError("% with parameters is not supported", t[2])
            mods.append((t[1], params))
        return mods

    # -- define: { array A[d1][d2] = {e, ...}, B[n]; ... } ----------------
    def define_block(self):
        self.expect("LBRACE", "{")
        arrays = []
        if self.peek()[0] == "RBRACE":
            raise self.err("an empty define: block (a syntax error in cpfg)")
        while self.peek()[0] != "RBRACE":
            t = self.peek()
            if t[0] == "NAME" and t[1] == "external":
                raise self.err("external (sub-L-systems' shared variables) is not supported")
            if t[0] != "NAME" or t[1] != "array":
                raise self.err("define: holds only `array` statements (found %r)"
                               % (t[1] if t[1] is not None else t[0]))
            self.take()
            while True:
                arrays.append(self.array_def())
                if self.peek()[0] == "COMMA":
                    self.take()
                    continue
                break
            self.expect("SEMI", ";")
        self.take()
        return arrays

    def array_def(self):
        """ArrayDef (lsys_input.y): the dimensions are evaluated when the
        file is read (AllocateArray, (int) of each), then the initializers
        once (InitializeArray: as many as there are elements); the name is
        defined only after its initializers were read."""
        nt = self.expect("NAME", "an array name")
        name = nt[1]
        if name in FUNCTIONS or name in UNSUPPORTED_FUNCTIONS or name in STATEMENT_WORDS:
            raise self.err("%s is reserved" % name, nt)
        dims = []
        while self.peek()[0] == "LBRACKET":
            self.take()
            dims.append(self.expression())
            self.expect("RBRACKET", "]")
        if not dims:
            raise self.err("array %s needs its dimensions: %s[n]" % (name, name), nt)
        inits = None
        if self.peek()[0] == "ASSIGN":
            self.take()
            self.expect("LBRACE", "{")
            inits = [self.expression()]
            while self.peek()[0] == "COMMA":
                self.take()
                inits.append(self.expression())
            self.expect("RBRACE", "}")
        # CurrentSymbolTableFind: the L-system's own table
        if name in self.lsys_table:
            raise self.err("Identifier %s previously defined" % name, nt)
        # (an array named Q or Z hides cpfg's global: the L-system's table
        # is searched first, and Derive sets the global table's Q)
        sizes = []
        total = 1
        for d in dims:
            try:
                n = c_int(self.rt.eval(d))
            except CpfgError as e:
                e.where = e.where or nt[2]
                raise
            if n < 1:
                raise self.err("dimension %d of array %s is %d (it must be at least 1)"
                               % (len(sizes) + 1, name, n), nt)
            sizes.append(n)
            total *= n
            if total > ArrayCell.MAX_ELEMENTS:
                raise self.err("array %s has more than %d elements" % (name, ArrayCell.MAX_ELEMENTS), nt)
        cell = ArrayCell(name, sizes, inits, nt[2])
        if inits is not None:
            self.rt.initialize_array(cell, at_start=False)
        self.lsys_table[name] = cell
        return cell

    # -- statements -------------------------------------------------------
    def block(self):
        self.expect("LBRACE", "{")
        stmts = []
        while self.peek()[0] != "RBRACE":
            stmts.append(self.statement())
        self.take()
        return stmts

    def statement(self):
        t = self.peek()
        if t[0] == "NAME" and t[1] == "if":
            self.take()
            self.expect("LPAREN", "(")
            c = self.expression()
            self.expect("RPAREN", ")")
            a = self.block()
            b = []
            if self.peek()[0] == "NAME" and self.peek()[1] == "else":
                self.take()
                b = self.block()
            return ("if", c, a, b)
        if t[0] == "NAME" and t[1] == "while":
            self.take()
            self.expect("LPAREN", "(")
            c = self.expression()
            self.expect("RPAREN", ")")
            return ("while", c, self.block())
        if t[0] == "NAME" and t[1] == "do":
            self.take()
            body = self.block()
            w = self.expect("NAME", "while")
            if w[1] != "while":
                raise self.err("expected while", w)
            self.expect("LPAREN", "(")
            c = self.expression()
            self.expect("RPAREN", ")")
            self.expect("SEMI", ";")
            return ("do", c, body)
        if t[0] == "NAME" and self.peek(1)[0] == "ASSIGN":
            if t[1] in FUNCTIONS or t[1] in UNSUPPORTED_FUNCTIONS or t[1] in STATEMENT_WORDS:
                raise self.err("%s is reserved" % t[1])
            self.take()
            self.take()
            cell = self.lookup(t[1], t, assign=True)
            if isinstance(cell, ArrayCell):
                raise self.err("Identifier %s previously defined as an array" % t[1], t)
            e = self.expression()
            self.expect("SEMI", ";")
            return ("assign", cell, e)
        e = self.expression()
        if self.peek()[0] == "ASSIGN" and e[0] == "aref":
            # LHS: tNAME ArrayRefs
            self.take()
            rhs = self.expression()
            self.expect("SEMI", ";")
            return ("aset", e, rhs)
        self.expect("SEMI", ";")
        return ("expr", e)

    # -- expressions ------------------------------------------------------
    def expression(self):
        c = self.binary(0)
        if self.peek()[0] == "QUESTION":
            self.take()
            a = self.expression()
            self.expect("COLON", ":")
            b = self.expression()
            return ("?", c, a, b)
        return c

    def binary(self, lvl):
        if lvl == len(BIN_LEVELS):
            return self.unary()
        e = self.binary(lvl + 1)
        while self.peek()[0] == "OP" and self.peek()[1] in BIN_LEVELS[lvl]:
            op = self.take()[1]
            e = ("bin", op, e, self.binary(lvl + 1))
        return e

    def unary(self):
        t = self.peek()
        if t[0] == "OP" and t[1] == "-":
            self.take()
            # unary minus binds tighter than ^ but looser than !
            return ("neg", self.unary())
        if t[0] == "OP" and t[1] == "!":
            self.take()
            return ("not", self.unary())
        return self.atom()

    def atom(self):
        t = self.take()
        if t[0] == "VALUE":
            return ("num", t[1])
        if t[0] == "STRING":
            return ("str", t[1][0], t[1][1])
        if t[0] == "LPAREN":
            e = self.expression()
            self.expect("RPAREN", ")")
            return e
        if t[0] == "NAME":
            name = t[1]
            if name in UNSUPPORTED_FUNCTIONS:
                raise self.err("%s is not supported (it needs cpfg's files, "
                               "curves, view or animation)" % name, t)
            if name in FUNCTIONS:
                self.expect("LPAREN", "(")
                args = []
                if self.peek()[0] != "RPAREN":
                    while True:
                        if name == "fprintf" and not args and self.peek()[0] == "NAME" \
                                and self.peek()[1] == "stderr":
                            self.take()
                            args.append(("str", "<stderr>"))
                        else:
                            args.append(self.expression())
                        if self.peek()[0] == "COMMA":
                            self.take()
                            continue
                        break
                self.expect("RPAREN", ")")
                arity = FUNCTIONS[name]
                if name == "fprintf" and (not args or args[0] != ("str", "<stderr>")):
                    raise self.err("fprintf is supported only on stderr", t)
                if arity is not None and len(args) != arity:
                    raise self.err("%s takes %d argument(s)" % (name, arity), t)
                if name in ("atan", "atan2") and len(args) not in (1, 2):
                    raise self.err("%s takes 1 or 2 arguments" % name, t)
                if name == "atan2":
                    raise self.err("atan2 is reserved in cpfg but a syntax error there", t)
                return ("call", name, args, t[2])
            if name in STATEMENT_WORDS:
                raise self.err("unexpected %s" % name, t)
            if self.peek()[0] == "LBRACKET":
                return self.array_ref(t)
            if self.peek()[0] == "LPAREN":
                raise self.err("unknown function %s" % name, t)
            cell = self.lookup(name, t)
            if isinstance(cell, ArrayCell):
                raise self.err("Identifier %s previously defined as an array" % name, t)
            return ("var", cell)
        raise self.err("unexpected %r in an expression" % (t[1] if t[1] is not None else t[0]), t)


    def array_ref(self, t):
        """Name: tNAME ArrayRefs (an element, in any expression), or the
        LHS of an assignment."""
        subs = []
        while self.peek()[0] == "LBRACKET":
            self.take()
            subs.append(self.expression())
            self.expect("RBRACKET", "]")
        cell = None
        for tab in self.tables:
            if t[1] in tab:
                cell = tab[t[1]]
                break
        if not isinstance(cell, ArrayCell):
            raise self.err("Identifier %s not previously defined as an array" % t[1], t)
        if len(subs) != len(cell.sizes):
            # (cpfg checks this for an element read, not for an assignment)
            raise self.err("Array identifier %s requires %d dimensions, not %d"
                           % (t[1], len(cell.sizes), len(subs)), t)
        return ("aref", cell, subs, t[2])


# ---------------------------------------------------------------------------
# cpfg's functions: func(id, x) (splinefun.cpp, splinearr.cpp), the view
# file's `function:` / `function set:` lines (interpret.c) and the macros a
# function set's names become (generate.c's PreprocessLsystem)
# ---------------------------------------------------------------------------

F32_TOKEN = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def f32_bits(v):
    return struct.unpack("<I", struct.pack("<f", v))[0]


def f32_from_bits(b):
    return struct.unpack("<f", struct.pack("<I", b))[0]


def parse_f32(tok, where):
    """A decimal number read as a 32-bit float (fscanf %f, std::stof): the
    float nearest to the decimal value itself (ties to even), not the float
    nearest to the double nearest to it (which can differ)."""
    from fractions import Fraction

    if not F32_TOKEN.fullmatch(tok):
        raise CpfgError("%r is not a number (the reference reads plain decimals)" % tok, where)
    exact = Fraction(tok)
    v = f32(float(exact))
    if math.isinf(v):
        raise CpfgError("%s does not fit a 32-bit float" % tok, where)
    if v == 0.0:
        return math.copysign(0.0, -1.0) if tok.startswith("-") else 0.0
    best = v
    bits = f32_bits(v)
    for nb in (bits - 1, bits + 1):
        c = f32_from_bits(nb & 0xFFFFFFFF)
        if math.isinf(c) or math.isnan(c) or (c > 0) != (v > 0):
            continue
        dc = abs(Fraction(c) - exact)
        db = abs(Fraction(best) - exact)
        if dc < db or (dc == db and f32_bits(c) % 2 == 0):
            best = c
    return best


class SplineFunction:
    """One function: a uniform open cubic B-spline through `points` (x, y)
    in [0, 1], evaluated as SplineFunction::GetValue."""

    ORDER = 4
    MAX_ERROR = 0.001

    def __init__(self, points, samples, name=None, where=None):
        if len(points) < 4:
            raise CpfgError("a function needs at least 4 points (it has %d)" % len(points), where)
        self.points = [(float(x), float(y)) for x, y in points]
        self.n = len(points) - 1
        self.name = name
        self.where = where
        self.samples = samples
        self.vals = None
        if samples > 2:
            # cpfg fills the table when it reads the file (with the
            # bisection): a bisection that never ends hangs it there.
            self.vals = [self.exact(i / float(samples - 1)) for i in range(samples)]

    # knots: 0 0 0 0 1 2 ... n-3 n-2 n-2 n-2 n-2
    def knot(self, j):
        if j < self.ORDER:
            return 0
        if j > self.n:
            return self.n - self.ORDER + 2
        return j - self.ORDER + 1

    def basis(self, k, t, u):
        """Cox-de Boor, as splinefun.cpp's N/Nk1/Nkt order their
        operations."""
        if t == 1:
            return 1.0 if self.knot(k) <= u < self.knot(k + 1) else 0.0
        s = 0.0
        div = self.knot(k + t - 1) - self.knot(k)
        if div != 0:
            s = (u - self.knot(k)) / div * self.basis(k, t - 1, u)
        div = self.knot(k + t) - self.knot(k + 1)
        if div != 0:
            s += (self.knot(k + t) - u) / div * self.basis(k + 1, t - 1, u)
        return s

    def point(self, d):
        u = d * (self.n - self.ORDER + 2)
        sx = 0.0
        sy = 0.0
        for k in range(self.n + 1):
            b = self.basis(k, self.ORDER, u)
            x, y = self.points[k]
            sx += x * b
            sy += y * b
        return sx, sy

    def point_de_boor(self, d):
        """The same curve by de Boor's algorithm (for the self-test): on the
        span [knot(j), knot(j+1)) holding u, with the same knots; nothing
        (0, 0) where no span holds u (u = n-2, d = 1), as in cpfg."""
        p = self.ORDER - 1
        u = d * (self.n - p + 1)
        span = None
        for j in range(p, self.n + 1):
            if self.knot(j) <= u < self.knot(j + 1):
                span = j
                break
        if span is None:
            return 0.0, 0.0
        dx = [self.points[span - p + i][0] for i in range(p + 1)]
        dy = [self.points[span - p + i][1] for i in range(p + 1)]
        for r in range(1, p + 1):
            for i in range(p, r - 1, -1):
                lo = self.knot(span - p + i)
                hi = self.knot(span + 1 + i - r)
                a = (u - lo) / (hi - lo)
                dx[i] = (1 - a) * dx[i - 1] + a * dx[i]
                dy[i] = (1 - a) * dy[i - 1] + a * dy[i]
        return dx[p], dy[p]

    def exact(self, x):
        """The bisection of SplineFunction::_Value on the curve's
        parameter until the curve's x is within 0.001 of `x`."""
        if math.isnan(x):
            raise CpfgError("func of NaN (cpfg reads outside its table, or "
                            "gives the curve's y at the middle)")
        low, high = 0.0, 1.0
        while True:
            check = (low + high) / 2.0
            px, py = self.point(check)
            if px > x:
                nlow, nhigh = low, check
            else:
                nlow, nhigh = check, high
            if abs(px - x) <= self.MAX_ERROR:
                return py
            if (nlow, nhigh) == (low, high):
                raise CpfgError(
                    "function %s: its curve's x never comes within 0.001 of %r "
                    "(cpfg's bisection never ends)" % (self.label(), x), self.where)
            low, high = nlow, nhigh

    def label(self):
        if self.name:
            return self.name
        if self.where:
            return self.where[0]
        return "?"

    def value(self, x):
        """SplineFunction::GetValue."""
        if x < 0.0:
            x = 0.0
        elif x > 1.0:
            x = 1.0
        if self.vals is None:
            return self.exact(x)
        if math.isnan(x):
            raise CpfgError("func of NaN (cpfg reads outside its table)")
        s = self.samples
        index = x * (s - 1)
        i = int(math.floor(index))
        w1 = 1 - index + i
        w2 = index - i
        if i == s - 1:
            return self.vals[i]
        return w1 * self.vals[i] + w2 * self.vals[i + 1]


class TextStream:
    """A file read as cpfg reads it: by lines (fgets) and by characters."""

    def __init__(self, text, fname):
        self.text = text
        self.pos = 0
        self.fname = fname

    def line_no(self):
        return self.text.count("\n", 0, self.pos) + 1

    def where(self):
        return (self.fname, self.line_no())

    def eof(self):
        return self.pos >= len(self.text)

    def peek(self):
        return self.text[self.pos] if self.pos < len(self.text) else ""

    def gets(self):
        """fgets: the rest of the line, its newline included."""
        k = self.text.find("\n", self.pos)
        k = len(self.text) if k < 0 else k + 1
        s = self.text[self.pos:k]
        self.pos = k
        return s

    def skip_space(self):
        """A blank in an fscanf format: any white space, newlines too."""
        while self.pos < len(self.text) and self.text[self.pos] in " \t\n\r\f\v":
            self.pos += 1


def scan_int(s):
    """sscanf's %d at the start of s (after blanks), or None."""
    m = re.match(r"[ \t\r\n\f\v]*([+-]?[0-9]+)", s)
    return int(m.group(1)) if m else None


def read_function(src, old_samples):
    """One function from src (its first line next): SplineFunction's
    constructors. `old_samples`: the samples of the old (`range:`)
    format, which has none of its own."""
    where = src.where()
    first = src.gets()
    if re.match(r"range:\s*" + F32_TOKEN.pattern + r"\s+" + F32_TOKEN.pattern, first):
        # fscanf "points: %zd\n", then N times "%f %f\n"
        rest = src.text[src.pos:]
        m = re.match(r"points:\s*([0-9]+)\s*", rest)
        if not m:
            raise CpfgError("expected `points: N` after `range:`", src.where())
        src.pos += m.end()
        count = int(m.group(1))
        pts = []
        for _ in range(count):
            w = src.where()
            m = re.match(r"(\S+)\s+(\S+)\s*", src.text[src.pos:])
            if not m:
                raise CpfgError("expected a point `x y`", w)
            pts.append((parse_f32(m.group(1), w), parse_f32(m.group(2), w)))
            src.pos += m.end()
        return SplineFunction(pts, old_samples, None, where)
    m = re.match(r"fver\s*([+-]?[0-9]+)\s*([+-]?[0-9]+)", first)
    if not m:
        raise CpfgError("a function file starts with `fver 1 1` or `range: LOW HIGH`", where)
    if (int(m.group(1)), int(m.group(2))) != (1, 1):
        raise CpfgError("function format %s.%s is not supported (cpfg reads 1.1)"
                        % (m.group(1), m.group(2)), where)
    w = src.where()
    m = re.match(r"name:\s*(\S+)", src.gets())
    if not m:
        raise CpfgError("expected `name: NAME`", w)
    name = m.group(1)
    w = src.where()
    m = re.match(r"samples:\s*([+-]?[0-9]+)", src.gets())
    if not m:
        raise CpfgError("expected `samples: N`", w)
    samples = int(m.group(1))
    if src.peek() == "b":  # background: two lines, ignored
        src.gets()
        src.gets()
    if src.peek() == "m":  # markers: K, then K lines, ignored
        w = src.where()
        k = scan_int(src.gets()[len("markers:"):])
        if k is None:
            raise CpfgError("expected `markers: K`", w)
        for _ in range(k):
            src.gets()
    src.gets()  # the `flip:` line, whatever it says
    w = src.where()
    m = re.match(r"points:\s*([0-9]+)", src.gets())
    if not m:
        raise CpfgError("expected `points: N`", w)
    count = int(m.group(1))
    if count < 4:
        raise CpfgError("a function needs at least 4 points (it has %d)" % count, w)
    pts = []
    for _ in range(count):
        w = src.where()
        k = src.text.find("\n", src.pos)
        if k < 0:
            # cpfg reads characters until a newline: it never stops
            raise CpfgError("a point's line without a newline at the end of the file", w)
        line = src.text[src.pos:k]
        src.pos = k + 1
        toks = [t for t in line.split(" ") if t != ""]
        if not 2 <= len(toks) <= 3:
            raise CpfgError("a point is `x y` or `x y multiplicity`, with blanks "
                            "between (cpfg splits at spaces only)", w)
        toks = [t.rstrip("\r") for t in toks]
        x = parse_f32(toks[0], w)
        y = parse_f32(toks[1], w)
        mult = 1
        if len(toks) == 3:
            mv = parse_f32(toks[2], w)
            mult = int(mv)  # (int) of a float: toward zero
        pts.extend([(x, y)] * max(mult, 0))
    return SplineFunction(pts, samples, name, where)


C_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class FunctionSet:
    """The functions of the --functions files, numbered from 1 in the order
    met, and the macros (name -> number) of the function sets' names."""

    def __init__(self):
        self.functions = []
        self.macros = {}
        self.curves = []

    def add_file(self, path, samples=-1):
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise CpfgError("cannot read %s: %s" % (path, e.strerror))
        text = text.replace("\r\n", "\n")
        src = TextStream(text, path)
        first = text.split("\n", 1)[0]
        if re.match(r"funcgalleryver\b", first):
            self.add_gallery(src)
        elif first.startswith("version:") or path.endswith(".con"):
            # a contour file given directly: 100 samples, as `curve: FILE`
            self.curves.append(read_contour(text, path, 100))
        elif re.match(r"fver\b", first) or re.match(r"range:", first):
            self.functions.append(read_function(src, samples))
        else:
            self.add_view(path, text)

    def add_gallery(self, src):
        """splinearr.cpp's ReadGallery: fscanf "funcgalleryver %d %d\\n",
        "items: %d\\n", then the functions one after the other (an old
        format one there has 100 samples)."""
        w = src.where()
        m = re.match(r"funcgalleryver\s*([+-]?[0-9]+)\s*([+-]?[0-9]+)\s*", src.text)
        if not m:
            raise CpfgError("expected `funcgalleryver 1 1`", w)
        if (int(m.group(1)), int(m.group(2))) != (1, 1):
            raise CpfgError("function set version %s.%s is not supported (cpfg reads 1.1)"
                            % (m.group(1), m.group(2)), w)
        src.pos = m.end()
        w = src.where()
        m = re.match(r"items:\s*([+-]?[0-9]+)\s*", src.text[src.pos:])
        if not m:
            raise CpfgError("expected `items: N`", w)
        src.pos += m.end()
        for _ in range(int(m.group(1))):
            if src.eof():
                raise CpfgError("the function set ends before its items", src.where())
            fn = read_function(src, 100)
            self.functions.append(fn)
            if fn.name is not None:
                if C_IDENT.fullmatch(fn.name):
                    self.macros[fn.name] = len(self.functions)
                else:
                    warn("function name %s is not a C identifier: no macro" % fn.name, fn.where)

    def add_view(self, path, text):
        """The `function:` and `function set:` lines of a view file (the
        label before the first `:`, blanks collapsed); the rest is not
        read. As cpfg's interpret.c reads them: a `function set:` resets
        the functions (splinearr.cpp's Reset; here those this view file
        listed before it), and a `function:` line after a set turns the
        set's macros off (SetFunctionsFromGallery(FALSE))."""
        text = splice_and_strip(text, path)
        base = os.path.dirname(path)
        first = len(self.functions)
        before = dict(self.macros)
        for i, line in enumerate(text.split("\n")):
            if ":" not in line:
                continue
            label, rest = line.split(":", 1)
            label = " ".join(label.split())
            if label not in ("function", "function set", "curve"):
                continue
            where = (path, i + 1)
            args = rest.split()
            if not args:
                raise CpfgError("`%s:` needs a file" % label, where)
            target = os.path.join(base, args[0])
            if label == "curve":
                # fscanf " %s %d": without a number, 100 samples; a table
                # apart from the functions (CurveXYZArray)
                v = scan_int(args[1]) if len(args) > 1 else None
                try:
                    with open(target, encoding="utf-8") as f:
                        body = f.read()
                except OSError as e:
                    raise CpfgError("cannot read %s: %s" % (target, e.strerror), where)
                self.curves.append(read_contour(body, target, 100 if v is None else v))
                continue
            if label == "function set":
                del self.functions[first:]
                self.macros = dict(before)
                self.add_file_kind(target, "set", -1, where)
            else:
                self.macros = dict(before)
                samples = -1
                if len(args) > 1:
                    v = scan_int(args[1])
                    samples = -1 if v is None else v
                self.add_file_kind(target, "function", samples, where)

    def add_file_kind(self, path, kind, samples, where):
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise CpfgError("cannot read %s: %s" % (path, e.strerror), where)
        src = TextStream(text.replace("\r\n", "\n"), path)
        if kind == "set":
            self.add_gallery(src)
        else:
            self.functions.append(read_function(src, samples))



# ---------------------------------------------------------------------------
# cpfg's curves: curveX/Y/Z(id, t) and curveGAL(id) (curveXYZ.cpp's
# CCurveXYZ, curveXYZc.cpp's CurveCXS/CurveCYS/CurveCZS/CurveGAL, the view
# file's `curve: FILE [SAMPLES]` in interpret.c, a table of their own)
# ---------------------------------------------------------------------------

C_SPACE = " \t\n\v\f\r"
STRTOD_RE = re.compile(r"[+-]?(?:infinity|inf|nan|(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)",
                       re.IGNORECASE)
SCANF_INT_RE = re.compile(r"[ \t\n\v\f\r]*([+-]?)(0[xX][0-9a-fA-F]+|0[0-7]*|[1-9][0-9]*)")
CONTOUR_LABELS = ["//", "version:", "contact:", "end:", "heading:", "up:", "size:",
                  "points:", "range:", "dim:", "dimension:", "type:"]


def c_atof(word, where, what="a contour file"):
    """atof: the number at the start of the word, 0 without one; the
    reference refuses hexadecimal (strtod reads it, lsgen does not) and a
    value that is not finite (in `what`)."""
    if re.match(r"[+-]?0[xX]", word):
        raise CpfgError("a hexadecimal number in %s" % what, where)
    m = STRTOD_RE.match(word)
    v = float(m.group(0)) if m else 0.0
    if math.isinf(v) or math.isnan(v):
        raise CpfgError("%s in %s is not a finite number" % (word, what), where)
    return v


def scanf_floats(s, n):
    """Does sscanf(" %f" * n) match n numbers at the start of s?"""
    pos = 0
    for _ in range(n):
        while pos < len(s) and s[pos] in C_SPACE:
            pos += 1
        m = STRTOD_RE.match(s, pos)
        if not m:
            return False
        pos = m.end()
    return True


def scanf_int(s):
    """sscanf's %i: decimal, 0x hexadecimal, 0 octal; None if no match."""
    m = SCANF_INT_RE.match(s)
    if not m:
        return None
    digits = m.group(2)
    if digits[:2] in ("0x", "0X"):
        v = int(digits[2:], 16)
    elif digits.startswith("0"):
        v = int(digits, 8)
    else:
        v = int(digits)
    return -v if m.group(1) == "-" else v


class Curve:
    """One curve as CCurveXYZ holds it after its constructor: `_ppoint`
    (createPPoints) and the arc-length table `_apoint` (createAPoints)."""

    def __init__(self, kind, control, samples, where):
        # createPPoints: each point its multiplicity times; bspline-closed
        # adds the first three again, bspline-phantom a point at each end.
        count = sum(m for _, m in control)
        extra, offset = {"closed": (3, 0), "phantom": (2, 1)}.get(kind, (0, 0))
        size = count + extra
        if size < 4:
            # (cpfg's calcPValue gives (0, 0, 0) for fewer than 4)
            raise CpfgError("a curve needs at least 4 points (it has %d)" % size, where)
        pp = [(0.0, 0.0, 0.0)] * size
        p = 0
        for point, mult in control:
            for _ in range(mult):
                pp[p + offset] = point
                p += 1
        if kind == "closed":
            for i in range(3):
                pp[size - 3 + i - offset] = pp[i]
        if kind == "phantom":
            pp[0] = tuple(2 * pp[1][c] - pp[2][c] for c in range(3))
            pp[size - 1] = tuple(2 * pp[size - 2][c] - pp[size - 3][c] for c in range(3))
        self.kind = kind
        self.pp = pp
        self.where = where
        # createAPoints
        self.asize = samples
        self.apoint = []
        self.alength = 0.0
        prev = None
        for i in range(samples):
            t = i / float(samples - 1)
            pt = self.p_value(t)
            if i > 0:
                dx = pt[0] - prev[0]
                dy = pt[1] - prev[1]
                dz = pt[2] - prev[2]
                self.alength += math.sqrt(dx * dx + dy * dy + dz * dz)
            self.apoint.append(self.alength)
            prev = pt
        self.apoint = [l / self.alength if self.alength != 0 else float("nan")
                       for l in self.apoint]

    @staticmethod
    def b_uniform(order, i, t):
        """Bi1 .. Bi4: knots ti(i) = i."""
        if order == 1:
            return 1.0 if float(i) <= t < float(i + 1) else 0.0
        return ((t - float(i)) / (float(i + order - 1) - float(i)) * Curve.b_uniform(order - 1, i, t)
                + (float(i + order) - t) / (float(i + order) - float(i + 1))
                * Curve.b_uniform(order - 1, i + 1, t))

    @staticmethod
    def n_clamped(order, k, u, psize):
        """Nk1 .. Nk4 on uk(k): 0 below 4, psize - 3 past psize - 1."""
        def uk(j):
            if j < 4:
                return 0.0
            if j > psize - 1:
                return float(psize) - 3.0
            return float(j) - 3.0
        if order == 1:
            return 1.0 if uk(k) <= u < uk(k + 1) else 0.0
        result = 0.0
        if uk(k + order - 1) - uk(k) != 0.0:
            result += (u - uk(k)) / (uk(k + order - 1) - uk(k)) * Curve.n_clamped(order - 1, k, u, psize)
        if uk(k + order) - uk(k + 1) != 0.0:
            result += ((uk(k + order) - u) / (uk(k + order) - uk(k + 1))
                       * Curve.n_clamped(order - 1, k + 1, u, psize))
        return result

    def p_value(self, t):
        """calcPValue(0, t, 0, 0)."""
        pp = self.pp
        n = len(pp)
        if self.kind == "bezier":
            segs = 1 + (n - 4) // 3
            c = int(t / (1.000001 / float(segs)))
            i = c * 3
            t = (t - float(c) * (1.0 / float(segs))) * float(segs) / 1.000001
            b = [Curve.n_clamped(4, k, t, 4) for k in range(4)]
            return tuple(pp[i][d] * b[0] + pp[i + 1][d] * b[1] + pp[i + 2][d] * b[2]
                         + pp[i + 3][d] * b[3] for d in range(3))
        if self.kind == "endpoint":
            u = t * (float(n) - 3.000001)
            h = [0.0, 0.0, 0.0]
            for i in range(n):
                b = Curve.n_clamped(4, i, u, n)
                for d in range(3):
                    h[d] += pp[i][d] * b
            return tuple(h)
        i = 3 + int(t * (n - 3.000001))
        u = 3.0 + t * (float(n) - 3.000001)
        b = [Curve.b_uniform(4, i - 3 + j, u) for j in range(4)]
        return tuple(pp[i - 3][d] * b[0] + pp[i - 2][d] * b[1] + pp[i - 1][d] * b[2]
                     + pp[i][d] * b[3] for d in range(3))

    def value(self, cid, t, coord, where):
        """CurveCXS and the like: t clamped, then calcAValue."""
        if t < 0:
            t = 0.0
        if t > 1:
            t = 1.0
        if math.isnan(t):
            raise CpfgError("curve%s(%d, NaN) (cpfg's search is undefined)" % ("XYZ"[coord], cid),
                            where)
        lo, hi = 0, self.asize - 1
        while hi - lo > 1:
            med = (lo + hi) // 2
            if self.apoint[med] > t:
                hi = med
            else:
                lo = med
        num = t - self.apoint[lo]
        den = self.apoint[hi] - self.apoint[lo]
        if den == 0 or math.isnan(den) or math.isnan(num):
            raise CpfgError("curve %d has no arc-length parameter at %r (0 / 0 in cpfg)"
                            % (cid, t), where)
        u = (lo + num / den) / float(self.asize - 1)
        return self.p_value(u)[coord]


def read_contour(text, fname, samples):
    """CCurveXYZ's openCurve and readCurve: lines (each must end with a
    newline: cpfg reads on to one), labels by prefix in cpfg's order, point
    lines of `dimension` words (atof), all after one `points: N`."""
    if not 2 <= samples <= 65536:
        raise CpfgError("a curve's samples must be 2 to 65536 (%d)" % samples, (fname, 1))
    if text and not text.endswith("\n"):
        raise CpfgError("the last line has no newline (cpfg reads past its buffer)",
                        (fname, text.count("\n") + 1))
    kind = "bspline"
    declared = None
    dim = 2
    control = []
    for no, line in enumerate(text.split("\n")[:-1], 1):
        where = (fname, no)
        if len(line.encode("utf-8")) > 255:
            raise CpfgError("a line longer than cpfg's buffer", where)
        label = next((l for l in CONTOUR_LABELS if line.startswith(l)), None)
        rest = line[len(label):] if label else ""
        nums = {"contact:": 3, "end:": 3, "heading:": 3, "up:": 3, "size:": 1, "range:": 2}
        if label == "//":
            continue
        if label == "version:":
            if not rest.strip(C_SPACE):
                raise CpfgError("expected `version: V`", where)
        elif label in nums:
            if not scanf_floats(rest, nums[label]):
                raise CpfgError("expected %d numbers after %s" % (nums[label], label), where)
        elif label == "points:":
            v = scanf_int(rest)
            if v is None:
                raise CpfgError("expected `points: N`", where)
            if declared is not None:
                raise CpfgError("a nested curve (a second points:) is not read", where)
            if v < 0 or v > 65536:
                raise CpfgError("points: %d" % v, where)
            declared = v
            dim = 2
        elif label in ("dim:", "dimension:"):
            v = scanf_int(rest)
            if v is None or declared is None or v not in (2, 3, 4):
                raise CpfgError("bad or early dimension", where)
            dim = v
        elif label == "type:":
            words = rest.split()
            if not words or declared is None:
                raise CpfgError("bad or early type", where)
            if words[0] == "bezier-surface":
                raise CpfgError("bezier-surface curves are not read", where)
            kind = {"bezier": "bezier", "bspline-phantom": "phantom",
                    "bspline-endpoint": "endpoint", "bspline-closed": "closed"}.get(words[0], "bspline")
        elif len(line.encode("utf-8")) > 2 and ":" not in line:
            # sscanf("%s %s %s %s") must match `dim` words
            words = [w for w in re.split("[" + C_SPACE + "]", line) if w]
            if declared is None:
                raise CpfgError("a point before points:", where)
            if min(len(words), 4) != dim:
                raise CpfgError("a point of %d words, dimension %d" % (len(words), dim), where)
            if len(control) >= declared:
                raise CpfgError("more points than points: says", where)
            v = [c_atof(w, where) for w in words[:dim]]
            mult = 1
            if dim == 4:
                m = math.trunc(v[3])
                if m < 0:
                    raise CpfgError("a negative multiplicity", where)
                mult = m
            if sum(m for _, m in control) + mult > 65536:
                raise CpfgError("too many points", where)
            control.append(((v[0], v[1], v[2] if dim > 2 else 0.0), mult))
    # CCPoint's defaults for points promised but missing: the origin, once
    while declared is not None and len(control) < declared:
        control.append(((0.0, 0.0, 0.0), 1))
    return Curve(kind, control, samples, (fname, 1))


# ---------------------------------------------------------------------------
# Runtime: expressions, statements, derivation
# ---------------------------------------------------------------------------


def c_int(v):
    """C's (int) conversion of a double: truncation toward zero; a value no
    32-bit int holds (NaN, infinities included) is undefined behaviour."""
    if math.isnan(v) or math.isinf(v) or not -2147483649.0 < v < 2147483648.0:
        raise CpfgError("conversion of %r to an integer (undefined in C)" % v)
    return int(v)


class Runtime:
    def __init__(self):
        self.q_cell = Cell("Q")
        self.z_cell = Cell("Z")
        self.rng = None
        self.functions = []  # SplineFunction, func's id 1 first
        self.curves = []  # Curve, curveX's id 1 first

    def eval(self, e):
        k = e[0]
        if k == "num":
            return e[1]
        if k == "var":
            return e[1].value
        if k == "neg":
            return -self.eval(e[1])
        if k == "not":
            return 1.0 if self.eval(e[1]) == 0 else 0.0
        if k == "?":
            c = self.eval(e[1])
            a = self.eval(e[2])  # cpfg evaluates both branches
            b = self.eval(e[3])
            return a if c != 0 else b
        if k == "str":
            # A string's value is its number in the global string table.
            return float(e[2])
        if k == "call":
            return self.call(e)
        if k == "aref":
            return e[1].values[self.array_index(e)]
        op = e[1]
        a = self.eval(e[2])
        b = self.eval(e[3])  # no short circuit
        if op == "||":
            return 1.0 if (a != 0 or b != 0) else 0.0
        if op == "&&":
            return 1.0 if (a != 0 and b != 0) else 0.0
        if op == "==":
            return float(a == b)
        if op == "!=":
            return float(a != b)
        if op == "<":
            return float(a < b)
        if op == "<=":
            return float(a <= b)
        if op == ">":
            return float(a > b)
        if op == ">=":
            return float(a >= b)
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            if b == 0.0:
                warn("division by 0 (cpfg divides by 1)")
                b = 1.0
            return a / b
        if op == "%":
            x, y = c_int(a), c_int(b)
            if y == 0:
                raise CpfgError("remainder by zero (cpfg crashes)")
            r = abs(x) % abs(y)
            return float(-r if x < 0 else r)
        if op == "^":
            try:
                return math.pow(a, b)
            except (ValueError, OverflowError):
                # C's pow: NaN for a negative base and a fraction, else an
                # infinity (overflow, or 0 to a negative power), negative
                # for a negative base and an odd power
                odd = b == math.floor(b) and math.fmod(b, 2) != 0
                if a < 0 and b != math.floor(b):
                    return math.nan
                return -math.inf if (a < 0 or math.copysign(1, a) < 0) and odd else math.inf
        raise CpfgError("bad operator %s" % op)

    def call(self, e):
        name, args = e[1], e[2]
        if name in ("printf", "fprintf"):
            if name == "fprintf":
                args = args[1:]
            if not args or args[0][0] != "str":
                raise CpfgError("printf needs a format string", e[3])
            vals = [self.eval(a) for a in args[1:]]
            fmt = args[0][1]
            try:
                sys.stderr.write(fmt % tuple(vals))
            except (TypeError, ValueError):
                sys.stderr.write(fmt + "\n")
            return 0.0
        v = [self.eval(a) for a in args]
        d = math.radians
        r = math.degrees
        # C's libm results: NaN and infinities are values (a comparison
        # with NaN is false, NaN is true as a condition).
        try:
            if name == "sin":
                return math.sin(d(v[0]))
            if name == "cos":
                return math.cos(d(v[0]))
            if name == "tan":
                return math.tan(d(v[0]))
            if name == "asin":
                return r(math.asin(v[0]))
            if name == "acos":
                return r(math.acos(v[0]))
            if name == "atan":
                # cpfg stacks only one argument: atan(a, b) is atan(b)
                return r(math.atan(v[-1]))
            if name == "exp":
                return math.exp(v[0])
            if name == "log":
                return -math.inf if v[0] == 0 else math.log(v[0])
            if name == "sqrt":
                return math.sqrt(v[0])
        except OverflowError:
            return math.inf
        except ValueError:
            return math.nan
        if name in ("floor", "ceil", "trunc") and not math.isfinite(v[0]):
            return v[0]
        if name == "floor":
            return float(math.floor(v[0]))
        if name == "ceil":
            return float(math.ceil(v[0]))
        if name == "trunc":
            return float(math.floor(v[0] + 0.5))
        if name == "fabs":
            return abs(v[0])
        if name == "sign":
            return 0.0 if v[0] == 0 else (1.0 if v[0] > 0 else -1.0)
        if name == "ran":
            return self.rng.ran(v[0])
        if name == "nran":
            return self.rng.nran(v[0], v[1])
        if name == "bran":
            return self.rng.bran(v[0], v[1])
        if name == "biran":
            return self.rng.biran(c_int(v[0]), v[1])
        if name == "func":
            # generate.c: id = (int) of the first value; splinefun.cpp's
            # SplineFuncValue warns and gives 0 for an id out of range
            # (an error here, as in lsgen)
            fid = c_int(v[0])
            if not 1 <= fid <= len(self.functions):
                raise CpfgError("func(%d, ...): there %s %d function%s (--functions)"
                                % (fid, "is" if len(self.functions) == 1 else "are",
                                   len(self.functions), "" if len(self.functions) == 1 else "s"),
                                e[3])
            try:
                return self.functions[fid - 1].value(v[1])
            except CpfgError as err:
                if err.where is None:
                    err.where = e[3]
                raise
        if name in ("curveX", "curveY", "curveZ", "curveGAL"):
            # generate.c: id = (int) of the first value; curveXYZc.cpp warns
            # and gives 0 for an id out of range (an error here, as in lsgen)
            cid = c_int(v[0])
            if not 1 <= cid <= len(self.curves):
                raise CpfgError("%s(%d, ...): there are %d curves" % (name, cid, len(self.curves)),
                                e[3])
            c = self.curves[cid - 1]
            if name == "curveGAL":
                return c.alength
            return c.value(cid, v[1], "XYZ".index(name[-1]), e[3])
        if name == "srand":
            # (long int) in generate.c's Eval
            if math.isnan(v[0]) or math.isinf(v[0]):
                raise CpfgError("srand of %r (undefined in C)" % v[0])
            self.rng.srand(int(v[0]))
            return 0.0
        raise CpfgError("unknown function %s" % name)

    def array_index(self, e):
        """generate.c's tARRAYREF / tARRAYLHS: the subscripts (doubles, left
        to right), each out of [0, size) replaced by 0 or size - 1, then
        temp = (temp + s[x-1]) * size[x] for x = 1..k-1 and the index
        (int)(temp + s[k-1]). cpfg reads or writes outside the array for a
        NaN subscript or an index past its end (fractional subscripts):
        an error here."""
        cell, where = e[1], e[3]
        subs = [self.eval(x) for x in e[2]]
        sizes = cell.sizes
        for x in range(len(subs) - 1, -1, -1):
            v = subs[x]
            if math.isnan(v):
                raise CpfgError("subscript %d of %s is NaN" % (x + 1, cell.name), where)
            if v >= sizes[x] or v < 0:
                fix = 0 if v < 0 else sizes[x] - 1
                warn("Subscript # %d = %.0f out of range for %s; using %d"
                     % (x + 1, v, cell.name, fix), where)
                subs[x] = float(fix)
        temp = 0.0
        for x in range(1, len(subs)):
            temp = (temp + subs[x - 1]) * sizes[x]
        index = int(temp + subs[-1])  # finite and >= 0 here: C's (int)
        if index >= cell.total:
            raise CpfgError("%s[%s]: element %d of an array of %d (cpfg reads outside it)"
                            % (cell.name, "][".join(fmt_g(v) for v in subs), index, cell.total),
                            where)
        return index

    def initialize_array(self, cell, at_start):
        """InitializeArray (when the file is read: only as many
        initializers as there are elements are evaluated) or
        ProcessArrayDef (at the start of the run, before Start:: every
        element, 0 past the initializers)."""
        inits = cell.inits or []
        if at_start:
            for i in range(cell.total):
                cell.values[i] = self.eval(inits[i]) if i < len(inits) else 0.0
        else:
            for i in range(min(cell.total, len(inits))):
                cell.values[i] = self.eval(inits[i])
        if len(inits) > cell.total:
            warn("Too many initialisers (array %s)" % cell.name, cell.where)
        elif cell.inits is not None and len(inits) < cell.total:
            warn("Too few initialisers (array %s)" % cell.name, cell.where)

    def run(self, stmts):
        for s in stmts:
            k = s[0]
            if k == "assign":
                s[1].value = self.eval(s[2])
            elif k == "aset":
                # AssignArrayElement(LHS, Eval(expression)): the value
                # first, then the subscripts
                v = self.eval(s[2])
                s[1][1].values[self.array_index(s[1])] = v
            elif k == "expr":
                self.eval(s[1])
            elif k == "if":
                self.run(s[2] if self.eval(s[1]) != 0 else s[3])
            elif k == "while":
                guard = 0
                while self.eval(s[1]) != 0:
                    self.run(s[2])
                    guard += 1
                    if guard > 10 ** 7:
                        raise CpfgError("while loop runs away")
            elif k == "do":
                guard = 0
                while True:
                    self.run(s[2])
                    guard += 1
                    if guard > 10 ** 7:
                        raise CpfgError("do loop runs away")
                    if self.eval(s[1]) == 0:
                        break


class Deriver:
    def __init__(self, ls, rt):
        self.ls = ls
        self.rt = rt
        self.by_first = {}
        for p in ls.prods:
            self.by_first.setdefault(p.pred[0][0], []).append(p)
        self.decomp_first = {}
        for p in ls.decomp or []:
            self.decomp_first.setdefault(p.pred[0][0], []).append(p)
        self.homo_first = {}
        for p in ls.homo or []:
            self.homo_first.setdefault(p.pred[0][0], []).append(p)

    # -- context matching on the current string S ------------------------
    def ignored(self, sym):
        if self.ls.consider is not None:
            return sym not in self.ls.consider
        return sym in self.ls.ignore

    def skipright(self, S, p):
        """Index of the ']' closing the branch that contains p (or len)."""
        level = 0
        n = len(S)
        while p < n:
            s = S[p][0]
            if s == "[":
                level += 1
            elif s == "]":
                if level == 0:
                    return p
                level -= 1
            p += 1
        return n

    def skipleft(self, S, p):
        """From a ']' at p: the index just left of its '[' (or -1)."""
        level = 0
        q = p - 1
        while q >= 0:
            s = S[q][0]
            if s == "]":
                level += 1
            elif s == "[":
                if level == 0:
                    return q - 1
                level -= 1
            q -= 1
        return -1

    def rcon(self, S, rc, p):
        binds = []
        n = len(S)
        i = 0
        while True:
            pat = rc[i]
            if pat[0] == "=":
                p = self.skipright(S, p)
                i += 1
                continue
            if p >= n:
                return None
            s = S[p][0]
            if self.ignored(s):
                p += 1
            elif pat[0] != "[" and s == "[":
                p = self.skipright(S, p + 1) + 1
            else:
                if pat[0] != s or len(pat[1]) != len(S[p][1]):
                    return None
                binds.append((pat, S[p]))
                p += 1
                i += 1
                if i == len(rc):
                    return binds

    def lcon(self, S, lc, p):
        binds = []
        for pat in reversed(lc):
            while True:
                if p < 0:
                    return None
                s = S[p][0]
                if s == "]":
                    p = self.skipleft(S, p)
                elif s == "[":
                    p -= 1
                elif self.ignored(s):
                    p -= 1
                else:
                    if pat[0] != s or len(pat[1]) != len(S[p][1]):
                        return None
                    binds.append((pat, S[p]))
                    p -= 1
                    break
        return binds

    @staticmethod
    def pred_match(pred, seq, k):
        if k + len(pred) > len(seq):
            return False
        for j, (sym, cells) in enumerate(pred):
            m = seq[k + j]
            if m[0] != sym or len(m[1]) != len(cells):
                return False
        return True

    @staticmethod
    def bind(binds):
        for (sym, cells), mod in binds:
            for c, v in zip(cells, mod[1]):
                c.value = float(v)

    def try_prod(self, p, seq, k, S, left, right):
        try:
            return self._try_prod(p, seq, k, S, left, right)
        except CpfgError as e:
            e.where = e.where or p.where
            raise

    def _try_prod(self, p, seq, k, S, left, right):
        """PredDiff, RconDiff, LconDiff, CondDiff in cpfg's order."""
        if not self.pred_match(p.pred, seq, k):
            return False
        rb = []
        if p.rc is not None:
            rb = self.rcon(S, p.rc, right)
            if rb is None:
                return False
        lb = []
        if p.lc is not None:
            lb = self.lcon(S, p.lc, left)
            if lb is None:
                return False
        self.bind([(pat, seq[k + j]) for j, pat in enumerate(p.pred)])
        self.bind(rb)
        self.bind(lb)
        self.rt.run(p.pre)
        if p.cond is None:
            return True
        return self.rt.eval(p.cond) != 0

    def successor(self, p):
        try:
            self.rt.run(p.post)
            return [(sym, tuple(f32(self.rt.eval(e)) for e in params)) for sym, params in p.succ]
        except CpfgError as e:
            e.where = e.where or p.where
            raise

    # -- decomposition ---------------------------------------------------
    def decompose(self, seq, k, S, left, right, depth, out):
        """cpfg's ApplyRecursiveProductions; returns (applied, next k)."""
        found = None
        for p in self.decomp_first.get(seq[k][0], []):
            if self.try_prod(p, seq, k, S, left, right):
                found = p
                break
        D = self.ls.decomp_depth
        if depth >= D:
            if D > 0:
                out.append(seq[k])
                if found is not None and self.ls.decomp_warning:
                    warn("maximum depth in a decomposition reached")
                return True, k + 1
            return False, k
        if found is None:
            if depth == 0:
                return False, k
            out.append(seq[k])
            return True, k + 1
        res = self.successor(found)
        j = 0
        while j < len(res):
            _, j = self.decompose(res, j, S, left, right, depth + 1, out)
        return True, k + len(found.pred)

    # -- one derivation step -------------------------------------------------
    def step(self, S, last, k):
        rt = self.rt
        # generate.c's Derive: `current++`, then SymbolTableReplace("Q",
        # current): the step number, whatever a block assigned to `Q`.
        rt.q_cell.value = float(k)
        rt.run(self.ls.start_each)
        out = []
        n = len(S)
        i = 0
        decomp = self.ls.decomp is not None
        while i < n:
            cands = self.by_first.get(S[i][0], [])
            chosen = None
            if self.ls.stochastic:
                appl = []
                total = f32(0.0)
                for p in cands:
                    if self.try_prod(p, S, i, S, i - 1, i + len(p.pred)):
                        prob = f32(rt.eval(p.prob)) if p.prob is not None else 1.0
                        total = f32(total + prob)
                        appl.append((p, prob))
                r = f32(total * rt.rng.main.next())
                for p, prob in appl:
                    r = f32(r - prob)
                    if r <= 0:
                        chosen = p
                        break
            else:
                for p in cands:
                    if self.try_prod(p, S, i, S, i - 1, i + len(p.pred)):
                        chosen = p
                        break
            if chosen is not None:
                res = self.successor(chosen)
                nxt = i + len(chosen.pred)
                if decomp:
                    j = 0
                    while j < len(res):
                        ok, j2 = self.decompose(res, j, S, i - 1, nxt, 0, out)
                        if not ok:
                            out.append(res[j])
                            j2 = j + 1
                        j = j2
                else:
                    out.extend(res)
                i = nxt
                continue
            if decomp:
                # a multi-module decomposition predecessor may span modules
                # of the old string here; its right context starts after
                # the first one (ApplyProd passes that pointer)
                ok, nxt = self.decompose(S, i, S, i - 1, i + 1, 0, out)
                if ok:
                    i = nxt
                    continue
            if S[i][0] == "%" and not S[i][1]:
                # cut: drop % and the rest of its branch (the ] stays)
                i = branch_rest_end(S, i + 1)
                continue
            out.append(S[i])
            i += 1
        rt.run(self.ls.end_each)
        if last:
            rt.run(self.ls.end)
        return out

    # -- homomorphism --------------------------------------------------------
    def homomorphism(self, S):
        out = []
        hx = None
        if self.ls.homo_seed >= 0:
            s = self.ls.homo_seed
            hx = Rand48.from_xsubi(0x330E, s & 0xFFFF, (s >> 16) & 0xFFFF)
        i = 0
        while i < len(S):
            # contexts: the derived string around the module (interpret.c)
            i = self.homo_apply(S, i, S, i - 1, i + 1, 0, out, hx)
        return out

    def homo_apply(self, seq, k, S, left, right, depth, out, hx):
        found = None
        for p in self.homo_first.get(seq[k][0], []):
            if self.try_prod(p, seq, k, S, left, right):
                found = p
                break
        if depth >= self.ls.homo_depth:
            out.append(seq[k])
            if found is not None and self.ls.homo_warning:
                warn("maximum depth in a homomorphism reached for module %s" % seq[k][0])
            return k + 1
        if found is None:
            out.append(seq[k])
            return k + 1
        rng = self.rt.rng
        if depth == 0 and hx is not None:
            saved = rng.xsubi
            rng.xsubi = hx
        res = self.successor(found)
        j = 0
        while j < len(res):
            j = self.homo_apply(res, j, S, left, right, depth + 1, out, hx)
        if depth == 0 and hx is not None:
            rng.xsubi = saved
        return k + len(found.pred)

    def derive(self, steps, homomorphism=True):
        rt = self.rt
        # InitialiseForStart: the last define: block (ProcessArrayDef), then
        # Start:, then the axiom
        for cell in self.ls.define:
            rt.initialize_array(cell, at_start=True)
        rt.run(self.ls.start)
        S = [(sym, tuple(f32(rt.eval(e)) for e in params)) for sym, params in self.ls.axiom]
        # The queries: filled on the string each step rewrites, before its
        # StartEach: (Derive's ProcessEnvironment), and on the final string
        turtle = QueryTurtle(rt.turtle_view) if self.ls.queries else None
        for k in range(1, steps + 1):
            last = k == steps and k >= self.ls.n
            if turtle:
                S = turtle.fill(S, self)
            S = self.step(S, last, k)
        # The saved string: cpfg interprets it to fit its view volume
        # (control.c, CalculateViewVolume: only without `box:`, which turns
        # auto_window off), or after the last step with `environment
        # display: before` (generate.c, the end of Derive); else it is
        # left as the last step made it.
        if turtle and (not rt.turtle_view.box or rt.turtle_view.display_before):
            S = turtle.fill(S, self)
        if homomorphism and self.ls.homo:
            S = self.homomorphism(S)
        return S


# ---------------------------------------------------------------------------
# Turtle queries ?P ?H ?L ?U (interpret.c's InterpretSymbol, change_dir,
# TurtleRotate, bend, InitializeTurtle, ReadViewData; blackbox.c's @v and
# @M; generate.c's SkipCutPart and the ProcessEnvironment call in Derive;
# utility.c's DCrossProduct, DNormalize, DDotProduct; learnt, not copied).
# The vectors are doubles, the values cpfg keeps in floats (angle,
# elasticity, scale, a segment's length, the parameters) are rounded with
# f32, and every operation is written in cpfg's order, so that the values
# are cpfg's to the bit.
# ---------------------------------------------------------------------------

QUERY_MODULES = "PHLU"
# the @ functions a file with queries may use: o O c draw (nothing for the
# queries), v rolls the turtle to the vertical, M moves it
BLACKBOX_KNOWN = ("o", "O", "c", "v", "M")
# @G's subfunctions (generalized cylinders, blackbox.c's case 'G'): spline
# state only, the turtle does not move; cpfg reads the subfunction module
# when G has no parameter
GC_SUBFUNCTIONS = ("s", "c", "e", "t", "r")
# the modules cpfg's turtle changes on; every other module is "still"
MOVING = set("FfGg+-&^/\\|_[]@~?%$")
# calls cpfg evaluates at each interpretation with an effect on the
# random streams
RANDOM_CALLS = ("ran", "nran", "bran", "biran", "srand")


def expr_calls(e):
    """The names of the functions an expression tree calls."""
    if isinstance(e, tuple):
        if e and e[0] == "call":
            yield e[1]
        for x in e[1:]:
            yield from expr_calls(x)
    elif isinstance(e, list):
        for x in e:
            yield from expr_calls(x)


def check_followed_homomorphism(p):
    """A homomorphism production in a file with queries: cpfg's turtle
    interprets the string through the homomorphism (interpret.c's
    TurtleDrawNsteps, InterpretHomomorphism), which the query turtle does
    too (QueryTurtle.fill); accepted only when it changes nothing but the
    turtle: no blocks, no probability, no ran & co.; a predecessor
    without a module the turtle reads with the next one or changes on
    without moving (`[ ] ? @ % $ ~`); a successor without `?`, without `%`
    or `$` outside its own brackets, whose brackets balance."""
    if p.has_pre or p.has_post:
        raise CpfgError("a homomorphism production with a pre- or post-condition block in a "
                        "file with queries is not supported", p.where)
    if p.prob is not None:
        raise CpfgError("a homomorphism production with a probability in a file with "
                        "queries is not supported", p.where)
    exprs = [p.cond] + [params for _, params in p.succ]
    for name in expr_calls(exprs):
        if name in RANDOM_CALLS:
            raise CpfgError("%s in a homomorphism production in a file with queries is not "
                            "supported (cpfg calls it at each interpretation)" % name, p.where)
    for sym, _ in p.pred:
        if sym in "[]?@%$~":
            raise CpfgError("a homomorphism predecessor with %s in a file with queries is not "
                            "supported" % sym, p.where)
    level = 0
    for sym, _ in p.succ:
        if sym == "?":
            raise CpfgError("? in a homomorphism successor in a file with queries is not "
                            "supported", p.where)
        if sym == "[":
            level += 1
        elif sym == "]":
            level -= 1
            if level < 0:
                raise CpfgError("an unmatched ] in a homomorphism successor in a file with "
                                "queries is not supported", p.where)
        elif level == 0 and sym in "%$":
            raise CpfgError("%s outside brackets in a homomorphism successor in a file with "
                            "queries is not supported" % sym, p.where)
    if level != 0:
        raise CpfgError("an unclosed [ in a homomorphism successor in a file with queries is "
                        "not supported", p.where)


def homomorphism_moves(p):
    """Can the homomorphism production p move the turtle: a moving module
    in its predecessor (which it replaces) or outside its successor's
    brackets (whose ] gives the whole turtle back), or an `@T` anywhere in
    its successor (movements: their global sums are not on the turtle's
    stack, the `]` gives them back by a difference, rounding included)?"""
    if any(sym in MOVING for sym, _ in p.pred):
        return True
    for k in range(len(p.succ) - 1):
        if p.succ[k][0] == "@" and not p.succ[k][1] and p.succ[k + 1][0] == "T":
            return True
    level = 0
    for sym, _ in p.succ:
        if sym == "[":
            level += 1
        elif sym == "]":
            level -= 1
        elif level == 0 and sym in MOVING:
            return True
    return False


def read_past(lists):
    """The symbols right after a `?` in the lists (the query modules), and
    those right after a `?`, an `@`, an `@G` or an `@T`."""
    queried, read = set(), set()
    for mods, _ in lists:
        after = None
        for sym, params in mods:
            if after:
                read.add(sym)
                if after == "?":
                    queried.add(sym)
                after = "G" if after == "@" and sym in "GT" and not params else None
            elif sym in "?@" and not params:
                after = sym
    return queried, read


# ---------------------------------------------------------------------------
# cpfg's movements (movements.c, turtle.c's adjust_up_and_left,
# quaternions.c): the view's `tropism:` and `torque:` lines, moved by @T.
# All doubles (struct MOVEMENTPARAM, TROPISMPARAM, TWISTPARAM, the turtle's
# vectors and MOVEMENTPARAM2), in cpfg's operation order.
# ---------------------------------------------------------------------------

MAXMOVEMENTS = 10
MT_TROPISM, MT_TWIST = 0, 1
# @T's subfunctions the query turtle follows (blackbox.c's case 'T')
T_SUBFUNCTIONS = ("i", "d", "s", "p", "f", "x")
VIEW_LINE_MAX = 254  # fgets(input_line, 255, fp): 254 bytes and the NUL


def c_strtok(state, delims):
    """strtok(NULL, delims) on state = [text, pos]: skip delimiters, the
    token up to the next delimiter (which is consumed), None at the end."""
    s, p = state
    while p < len(s) and s[p] in delims:
        p += 1
    if p >= len(s):
        state[1] = p
        return None
    q = p
    while q < len(s) and s[q] not in delims:
        q += 1
    state[1] = q + 1 if q < len(s) else q
    return s[p:q]


def dcross(v1, v2):
    """utility.c's DCrossProduct."""
    return [v1[1] * v2[2] - v1[2] * v2[1],
            v1[2] * v2[0] - v1[0] * v2[2],
            v1[0] * v2[1] - v1[1] * v2[0]]


def mult_quats(q1, q2):
    return [q1[0] * q2[0] - (q1[1] * q2[1] + q1[2] * q2[2] + q1[3] * q2[3]),
            q1[0] * q2[1] + q2[0] * q1[1] + q1[2] * q2[3] - q1[3] * q2[2],
            q1[0] * q2[2] + q2[0] * q1[2] + q1[3] * q2[1] - q1[1] * q2[3],
            q1[0] * q2[3] + q2[0] * q1[3] + q1[1] * q2[2] - q1[2] * q2[1]]


def rot_by_quat(v, q):
    """quaternions.c's rot_by_quat: v' = q^-1 (0, v) q, in place."""
    size = 1.0 / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    msize = -size
    qi = [size * q[0], msize * q[1], msize * q[2], msize * q[3]]
    qr = mult_quats(qi, [0.0, v[0], v[1], v[2]])
    qv = mult_quats(qr, q)
    v[0], v[1], v[2] = qv[1], qv[2], qv[3]


def axis_quat(angle, axis):
    """q[0] = cos(angle), q[1..3] = (bendsin = sin(angle)) * axis."""
    s = math.sin(angle)
    return [math.cos(angle), s * axis[0], s * axis[1], s * axis[2]]


def adjust_up_and_left(st):
    """turtle.c's adjust_up_and_left: U = prev_up turned by the rotation
    taking prev_heading to H (when |H x prev_H| > 1e-6), then L = H x U."""
    H, pH = st["H"], st["pH"]
    rot = dcross(H, pH)
    ln = math.sqrt(rot[0] * rot[0] + rot[1] * rot[1] + rot[2] * rot[2])
    if ln > 0.000001:
        st["U"] = list(st["pU"])
        if ln > 1:
            ln = 1.0
        angle = math.asin(ln) * 0.5
        if dot(H, pH) < 0:
            angle = math.pi * 0.5 - angle
        rot = [rot[0] / ln, rot[1] / ln, rot[2] / ln]
        rot_by_quat(st["U"], axis_quat(angle, rot))
    st["L"] = dcross(H, st["U"])


class MovementSlot:
    """One EPr.movements[] entry (a line cpfg ignores leaves its fields
    there for the next line: its dir)."""

    def __init__(self):
        self.type = MT_TROPISM
        self.dir = [0.0, 0.0, 0.0]
        self.gamma = 0.0
        self.elasticity = 0.0
        self.initial = 0.0
        self.incr = 0.0

    def copy(self):
        m = MovementSlot()
        m.__dict__.update(self.__dict__)
        m.dir = list(self.dir)
        return m


class Movements:
    """The global movement state: EPr.movements, number_of_movements,
    tropism_param (gea, geb, gec, cos/sin/esin gamma) and twist_param."""

    def __init__(self):
        self.slots = [MovementSlot() for _ in range(MAXMOVEMENTS)]
        self.n = 0
        self.ge = [0.0, 0.0, 0.0]
        self.cosg = [0.0] * MAXMOVEMENTS
        self.sing = [0.0] * MAXMOVEMENTS
        self.esing = [0.0] * MAXMOVEMENTS
        self.twist = [0.0, 0.0, 0.0]
        self.twist_len = 0.0

    def copy(self):
        m = Movements()
        m.slots = [s.copy() for s in self.slots]
        m.n = self.n
        m.ge = list(self.ge)
        m.cosg, m.sing, m.esing = list(self.cosg), list(self.sing), list(self.esing)
        m.twist = list(self.twist)
        m.twist_len = self.twist_len
        return m

    def read(self, line, mtype, where):
        """read_movement(input_line, type): `line` is what fgets left after
        the label's `:` (its newline included). Returns whether cpfg keeps
        the movement; raises CpfgError where cpfg would crash (atof of a
        missing number) or the reference does not follow it."""
        index = self.n
        if index == MAXMOVEMENTS:
            warn("no room for a new movement: ignored (cpfg's MAXMOVEMENTS)", where)
            return False
        m = self.slots[index]
        m.type = mtype
        m.gamma = m.elasticity = m.incr = 0.0
        state = [line, 0]

        def get_double():
            tok = c_strtok(state, " ,\t:")
            if tok is None:
                raise CpfgError("a movement line that ends before its number (cpfg's atof "
                                "of NULL)", where)
            return c_atof(tok.lstrip(C_SPACE), where, "a movement line")

        ln = 0.0
        tok = c_strtok(state, " \t:")
        while tok is not None:
            c = tok[0]
            if c == "T":
                m.dir[0] = get_double()
                m.dir[1] = get_double()
                m.dir[2] = get_double()
                ln = dot(m.dir, m.dir)
                if ln == 0.0:
                    warn("a movement with a 0 vector: ignored", where)
                    return False
                ln = 1.0 / math.sqrt(ln)
            elif c == "I":
                ln *= get_double()
                if ln == 0.0:
                    warn("a movement with 0 intensity: ignored", where)
                    return False
                if ln > 1.0:
                    ln = 1.0
                if ln < -1.0:
                    ln = -1.0
            elif c == "A":
                m.gamma = get_double()
            elif c == "E":
                m.elasticity = get_double()
            elif c == "S":
                m.incr = get_double()
            else:
                warn("a movement with an unknown command %r: ignored" % c, where)
                return False
            tok = c_strtok(state, " \t:\n")
        self.n += 1
        if self.n == MAXMOVEMENTS:
            # movement_adjust's loop runs to i <= number_of_movements: the
            # 11th entry is outside cpfg's arrays
            raise CpfgError("%d movements: cpfg's movement_adjust reads past its arrays"
                            % MAXMOVEMENTS, where)
        m.dir = [m.dir[0] * ln, m.dir[1] * ln, m.dir[2] * ln]
        m.initial = m.elasticity
        a, b, c = m.dir
        elast = m.elasticity
        if index == 0:
            self.twist = [0.0, 0.0, 0.0]
            self.ge = [0.0, 0.0, 0.0]
        if mtype == MT_TROPISM:
            g = m.gamma * math.pi / 180.0  # D_TO_R
            self.cosg[index] = math.cos(g)
            self.sing[index] = math.sin(g)
            self.esing[index] = elast * self.sing[index]
            self.ge[0] += self.cosg[index] * elast * a
            self.ge[1] += self.cosg[index] * elast * b
            self.ge[2] += self.cosg[index] * elast * c
        else:
            self.twist[0] += elast * a
            self.twist[1] += elast * b
            self.twist[2] += elast * c
            self.twist_len = math.sqrt(dot(self.twist, self.twist))
        return True

    def update(self, index, delta):
        """update_movement(index, delta_elast)."""
        m = self.slots[index]
        a, b, c = m.dir
        m.elasticity += delta
        if m.type == MT_TROPISM:
            if self.cosg[index] != 0.0:
                self.ge[0] += self.cosg[index] * delta * a
                self.ge[1] += self.cosg[index] * delta * b
                self.ge[2] += self.cosg[index] * delta * c
            if self.sing[index] != 0.0:
                self.esing[index] += delta * self.sing[index]
        else:
            self.twist[0] += delta * a
            self.twist[1] += delta * b
            self.twist[2] += delta * c
            self.twist_len = math.sqrt(dot(self.twist, self.twist))

    def start(self, st):
        """InitializeTurtle: each movement's turtle elasticity is its
        initial one, and the global one follows by the difference."""
        st["me"] = [self.slots[i].initial for i in range(self.n)]
        for i in range(self.n):
            self.update(i, self.slots[i].initial - self.slots[i].elasticity)

    def adjust(self, st):
        """movement_adjust(tu), before F G f g."""
        if self.n == 0:
            return
        H = st["H"]
        des = list(self.ge)
        # cpfg's loop runs to i <= number_of_movements; the extra entry
        # has sin gamma 0 (set only for a movement kept), so it adds nothing
        for i in range(self.n + 1):
            m = self.slots[i]
            if m.type == MT_TROPISM and self.sing[i] != 0.0:
                vec = dcross(H, m.dir)
                ln = math.sqrt(vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2])
                if ln < 0.0000001:
                    vec = list(st["L"])
                    ln = 1.0
                vec2 = dcross(m.dir, vec)
                ln = self.esing[i] / ln
                des[0] += ln * vec2[0]
                des[1] += ln * vec2[1]
                des[2] += ln * vec2[2]
        rot = dcross(H, des)
        # adjust_by_orthotropism
        ln = math.sqrt(rot[0] * rot[0] + rot[1] * rot[1] + rot[2] * rot[2])
        if not ln < 0.000001:
            if ln > 1.0:
                ln = 1.0
            angle = -ln * 0.5
            ln = 1.0 / ln
            rot = [rot[0] * ln, rot[1] * ln, rot[2] * ln]
            rot_by_quat(H, axis_quat(angle, rot))
            adjust_up_and_left(st)
        # twist (torque) movements
        t = self.twist
        if t[0] != 0.0 or t[1] != 0.0 or t[2] != 0.0:
            vec2 = list(t)
            nrm = math.sqrt(dot(vec2, vec2))
            if nrm != 0:
                inv = 1.0 / nrm
                vec2 = [vec2[0] * inv, vec2[1] * inv, vec2[2] * inv]
            vec = dcross(H, vec2)
            if dot(vec, vec) > 0.00000001:
                des = dcross(vec, H)
                des = [des[0] * self.twist_len, des[1] * self.twist_len,
                       des[2] * self.twist_len]
                # rotate_to_vector(tu->up, des_dir)
                U = st["U"]
                v = dcross(U, des)
                ln = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                if not ln < 0.0000001:
                    if ln > 1.0:
                        ln = 1.0
                    angle = ln * 0.5
                    v = [v[0] / ln, v[1] / ln, v[2] / ln]
                    rot_by_quat(U, axis_quat(angle, v))
                    st["L"] = dcross(H, U)
                st["pH"] = list(H)
                st["pU"] = list(st["U"])

    def pop(self, st, saved):
        """`]`: each movement whose turtle elasticity differs from the
        saved one is updated by the difference (saved - current)."""
        for i in range(self.n):
            aux = saved["me"][i] - st["me"][i]
            if aux != 0:
                self.update(i, aux)

    def blackbox(self, st, sub, sv):
        """call_blackbox's case 'T' for @T + sub(sv): sv are the
        subfunction's parameters (T has none: refused before)."""
        parm2 = len(sv) > 0
        if sub == "x":
            if parm2:
                return  # the texture only
            raise CpfgError("@Tx without a parameter in a string with queries (cpfg reads T "
                            "and x again as modules)")
        if not parm2:
            index = 0
        else:
            t = float(sv[0]) - 1.0
            if math.isnan(t) or not -32768.0 < t < 32768.0:
                raise CpfgError("@T%s(%s): an index outside a C short" % (sub, fmt_g(sv[0])))
            index = int(t)  # (short), toward 0
            if index < 0 or index >= self.n:
                warn("@T%s: movement index out of range, ignored" % sub)
                return
        if len(sv) >= 2:
            aux = float(sv[1])
        else:
            aux = self.slots[index].incr
        if sub == "d":
            aux = -aux
        elif sub == "s":
            if len(sv) >= 2:
                aux = float(sv[1]) - st["me"][index]
            else:
                aux = -st["me"][index] if index < len(st["me"]) else 0.0
        elif sub == "p":
            adjust_up_and_left(st)
            return
        elif sub == "f":
            st["pH"] = list(st["H"])
            st["pU"] = list(st["U"])
            return
        if parm2:
            st["me"][index] += aux
            self.update(index, aux)


class TurtleView:
    """The settings of a view file the query turtle reads (ReadViewData):
    `angle factor:` / `angle increment:` (the later wins), `tropism
    direction:`, `initial elasticity:`, `elasticity increment:`, `initial
    scale:` (0 is 1), `interpretation past %:`, `box:` and `environment
    display:` (whether the saved string's queries are filled), and the
    `tropism:` and `torque:` lines (`movements`, as read_movement leaves
    them; each derivation run works on its own copy)."""

    def __init__(self):
        self.angle = f32(45.0)
        self.tropism = (0.0, 1.0, 0.0)
        self.elasticity = 0.0
        self.elasticity_increment = 0.0
        self.scale = 1.0
        self.past_cut = True
        self.movements = Movements()
        self.box = False
        self.display_before = False

    def sin_cos(self):
        r = self.angle * math.pi / 180.0  # D_TO_R: times pi, then / 180
        return math.sin(r), math.cos(r)


def view_float(rest, where, what):
    """fscanf(" %f"): the number at the start of `rest` (blanks skipped)
    as a float, and what follows it."""
    pos = 0
    while pos < len(rest) and rest[pos] in C_SPACE:
        pos += 1
    m = STRTOD_RE.match(rest, pos)
    if not m:
        raise CpfgError("`%s:` needs a number" % what, where)
    v = float(m.group())
    if math.isnan(v) or math.isinf(v):
        raise CpfgError("`%s:` needs a finite number" % what, where)
    return f32(v), rest[m.end():]


def read_turtle_view(path):
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise CpfgError("cannot read %s: %s" % (path, e.strerror))
    tv = TurtleView()
    # the label and line of the angle read last
    angle_at = ("angle increment", (path, 1))
    lines = splice_and_strip(text, path).split("\n")
    for i, line in enumerate(lines):
        if ":" not in line:
            continue
        label, rest = line.split(":", 1)
        label = " ".join(label.split())
        where = (path, i + 1)
        if label == "angle factor":
            n, _ = view_float(rest, where, label)
            # 360.0 / angle_increment in double, stored in the float
            tv.angle = f32(360.0 / n) if n != 0 else None
            angle_at = (label, where)
        elif label == "angle increment":
            tv.angle, _ = view_float(rest, where, label)
            angle_at = (label, where)
        elif label == "tropism direction":
            # fscanf(" %f,%f,%f") into floats; the length and the
            # quotients are float arithmetic too (temp_x, temp_length
            # are floats: interpret.c, ReadViewData, case 28)
            xs = []
            for k in range(3):
                v, rest = view_float(rest, where, label)
                xs.append(v)
                if k < 2:
                    if not rest.startswith(","):
                        raise CpfgError("`tropism direction:` needs x,y,z", where)
                    rest = rest[1:]
            x, y, z = xs
            sq = f32(f32(f32(x * x) + f32(y * y)) + f32(z * z))
            length = f32(math.sqrt(sq))
            if length == 0:
                raise CpfgError("`tropism direction:` of length 0", where)
            tv.tropism = (f32(x / length), f32(y / length), f32(z / length))
        elif label == "initial elasticity":
            tv.elasticity, _ = view_float(rest, where, label)
        elif label == "elasticity increment":
            tv.elasticity_increment, _ = view_float(rest, where, label)
        elif label == "initial scale":
            tv.scale, _ = view_float(rest, where, label)
            if tv.scale == 0:
                tv.scale = 1.0
        elif label == "interpretation past %":
            words = rest.split()
            tv.past_cut = not (words and words[0].startswith("off"))
        elif label in ("tropism", "torque"):
            # fgets: the rest of the line, its newline included (a file's
            # last line may lack it)
            line = rest + ("\n" if i + 1 < len(lines) else "")
            if len(line.encode("utf-8")) > VIEW_LINE_MAX:
                raise CpfgError("a `%s:` line longer than cpfg's fgets reads" % label, where)
            tv.movements.read(line, MT_TROPISM if label == "tropism" else MT_TWIST, where)
        elif label == "environment display":
            # `before`: the queries filled after each step (the end of
            # generate.c's Derive) and on the axiom (control.c) instead of
            # before each step: the same strings, but for the last one
            words = rest.split()
            tv.display_before = bool(words and words[0][:6] == "before")
        elif label == "box":
            tv.box = True
    if tv.angle is None or math.isinf(tv.angle):
        label, where = angle_at
        raise CpfgError("`%s:` gives no finite angle (360 / 0, or past the largest float)" % label,
                        where)
    return tv


def branch_rest_end(S, i, stop_at_dollar=False):
    """From S[i], the index of the `]` that closes the current branch (or
    len(S)): where a cut's rest ends (generate.c's cut), and where the
    turtle's skip after `%` ends (SkipCutPart, which also stops at a
    `$`)."""
    level = 1
    while i < len(S):
        s = S[i][0]
        if s == "[":
            level += 1
        elif s == "]":
            level -= 1
            if level == 0:
                break
        elif s == "$" and stop_at_dollar:
            break
        i += 1
    return i


def rotate(a, b, s, c):
    """change_dir(temp, a, b, s, c): a' = c a + s b, b' = c b + (-s) a."""
    na = [c * a[0] + s * b[0], c * a[1] + s * b[1], c * a[2] + s * b[2]]
    ms = -s
    nb = [c * b[0] + ms * a[0], c * b[1] + ms * a[1], c * b[2] + ms * a[2]]
    return na, nb


def dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def cross(u, v):
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


class QueryTurtle:
    """One interpretation of a string from its start, for its queries."""

    def __init__(self, tv):
        self.tv = tv
        self.sin, self.cos = tv.sin_cos()
        self.strict = False
        # the global movement state: one per derivation run (this turtle
        # fills every string of the run), kept from one fill to the next
        self.mv = tv.movements.copy()

    def bend(self, st, top=True):
        """`top`: not in a homomorphism's successor. There (always in one
        of its branches: a file with queries has no other moving module
        in a homomorphism successor) a sine outside [-1, 1] gives cpfg's
        NaN (sqrt of a negative number), which the branch's ] discards."""
        e = st["e"]
        if e == 0.0:
            return
        T = self.tv.tropism
        for other in ("U", "L"):
            s = e * dot(T, st[other])
            if -1.0 <= s <= 1.0:
                c = math.sqrt(1 - s * s)
            elif top:
                raise CpfgError("the tropism's bend has a sine of %r (elasticity %g): "
                                "outside [-1, 1]" % (s, e))
            else:
                c = math.nan
            st["H"], st[other] = rotate(st["H"], st[other], s, c)

    def fill(self, S, deriver=None):
        """A copy of S with each query module's first (up to 3) parameters
        set to the turtle's position or vector where its `?` is met. With
        a homomorphism (deriver.ls.homo), the string is interpreted
        through it as cpfg's TurtleDrawNsteps does: each module of the
        string goes to InterpretHomomorphism (here `through`), whose
        productions' successors are interpreted in turn (to `maximum
        depth:`), their contexts read in the string being filled."""
        self.st = {"P": [0.0, 0.0, 0.0], "H": [0.0, 1.0, 0.0], "L": [-1.0, 0.0, 0.0],
                   "U": [0.0, 0.0, -1.0], "e": self.tv.elasticity}
        # InitializeTurtle: the movements' elasticities, then the previous
        # heading and up
        self.mv.start(self.st)
        self.st["pH"] = list(self.st["H"])
        self.st["pU"] = list(self.st["U"])
        self.stack = []
        out = list(S)
        homo = deriver is not None and bool(deriver.ls.homo)
        self.strict = homo and deriver.ls.homo_moves
        if homo:
            rng = deriver.rt.rng
            before = (rng.main.x, rng.xsubi.x, rng.iset, rng.gset)
        i = 0
        while i < len(out):
            if homo:
                # contexts: the module before and after the one read
                i = self.through(out, i, out, i - 1, i + 1, 0, deriver)
            else:
                i = self.interpret(out, i, True)
        if homo and (rng.main.x, rng.xsubi.x, rng.iset, rng.gset) != before:
            raise CpfgError("internal: the homomorphism of the query turtle drew random numbers")
        return out

    def through(self, seq, k, S, left, right, depth, d):
        """InterpretHomomorphism: the first applicable homomorphism
        production for seq[k] (contexts read in S around left/right), its
        successor interpreted module by module one level deeper, or
        seq[k] interpreted (InterpretSymbol, in_homo when depth > 0).
        Returns the index after what was read from seq."""
        found = None
        for p in d.homo_first.get(seq[k][0], []):
            if d.try_prod(p, seq, k, S, left, right):
                found = p
                break
        if depth >= d.ls.homo_depth or found is None:
            return self.interpret(seq, k, depth == 0)
        res = d.successor(found)
        j = 0
        while j < len(res):
            j = self.through(res, j, S, left, right, depth + 1, d)
        return k + len(found.pred)

    def interpret(self, seq, i, top):
        """InterpretSymbol for seq[i]; `?`, `@` and `%` read further
        modules of seq (the queried module, the @ function, the cut part),
        which do not go through the homomorphism. `top`: seq is the string
        being filled (not a homomorphism successor: in_homo is 0).
        Returns the index after what was read."""
        tv = self.tv
        st = self.st
        n = len(seq)
        sym, vals = seq[i]
        i += 1
        if sym in "+-&^/\\":
            if vals:
                r = vals[0] * math.pi / 180.0
                s, c = math.sin(r), math.cos(r)
            else:
                s, c = self.sin, self.cos
            if sym in "-^\\":
                s = -s
            a, b = {"+": "HL", "-": "HL", "&": "HU", "^": "HU", "/": "LU", "\\": "LU"}[sym]
            st[a], st[b] = rotate(st[a], st[b], s, c)
        elif sym == "|":
            st["H"], st["L"] = rotate(st["H"], st["L"], 0.0, -1.0)
        elif sym in ("F", "G", "f", "g"):
            # movement_adjust before the move
            self.mv.adjust(st)
            d = f32((vals[0] if vals else 1.0) * tv.scale)
            P, H = st["P"], st["H"]
            P[0] += d * H[0]
            P[1] += d * H[1]
            P[2] += d * H[2]
            # (With a homomorphism that moves the turtle, lsgen refuses a
            # bend past 1 in its successors' branches too, where cpfg's
            # NaN is discarded by the ]: the reference does the same.)
            self.bend(st, top or self.strict)
            if sym in "FG":
                st["pH"] = list(st["H"])
                st["pU"] = list(st["U"])
        elif sym == "_":
            st["e"] = f32(vals[0]) if vals else f32(st["e"] + tv.elasticity_increment)
        elif sym == "[":
            self.stack.append({k: (list(v) if k != "e" else v) for k, v in st.items()})
        elif sym == "]":
            if not self.stack:
                raise CpfgError("an unmatched ] in a string with queries")
            saved = self.stack.pop()
            self.mv.pop(st, saved)
            self.st = saved
        elif sym == "%" and not vals and not tv.past_cut and top:
            # SkipCutPart: to the ] closing the branch (interpreted
            # next), a $, or the end; ignored in a homomorphism's
            # successor (in_homo)
            i = branch_rest_end(seq, i, stop_at_dollar=True)
        elif sym == "@":
            f = seq[i][0] if i < n else ""
            if f == "T":
                # movements (call_blackbox's case 'T'), in a homomorphism's
                # successor too: it changes the global sums
                if seq[i][1]:
                    raise CpfgError("@T with parameters in a string with queries (cpfg reads "
                                    "T again as a module)")
                if i + 1 >= n:
                    raise CpfgError("@T at the end of a string with queries")
                sub, sv = seq[i + 1]
                if sub not in T_SUBFUNCTIONS:
                    raise CpfgError("@T%s in a string with queries (the turtle knows @Ti @Td "
                                    "@Ts @Tp @Tf @Tx)" % sub)
                self.mv.blackbox(st, sub, sv)
                return i + 2
            if not top and f not in BLACKBOX_KNOWN:
                # In a homomorphism's successor only inside a branch
                # (with a homomorphism that cannot move the turtle): whatever the function does
                # to the turtle (@R sets the heading, @D the scale, ...),
                # the branch's ] gives the turtle back. Its module (and
                # @G's subfunction) is read, not interpreted.
                if f == "G" and not seq[i][1]:
                    return i + 2
                return i + 1
            if f == "G":
                # the subfunction is read when G has no parameter
                sub = seq[i + 1][0] if i + 1 < n else ""
                if sub not in GC_SUBFUNCTIONS:
                    raise CpfgError("@G%s in a string with queries (the turtle knows @Gs @Gc "
                                    "@Ge @Gt @Gr)" % sub)
                return i + 1 if seq[i][1] else i + 2
            if f not in BLACKBOX_KNOWN:
                raise CpfgError("@%s in a string with queries (the turtle knows @o @O "
                                "@c @v @M @G @T)" % f)
            f, fv = seq[i]
            i += 1
            if f == "v":
                H = st["H"]
                if H[1] < 1.0 and H[1] > -1.0:
                    L = cross([0.0, 1.0, 0.0], H)
                    norm = math.sqrt(dot(L, L))
                    if norm != 0:
                        inv = 1.0 / norm  # DNormalize multiplies by 1/n
                        L = [L[0] * inv, L[1] * inv, L[2] * inv]
                    st["L"] = L
                    st["U"] = cross(L, H)
            elif f == "M" and len(fv) >= 2:
                st["P"] = [fv[0], fv[1], fv[2] if len(fv) >= 3 else 0.0]
        elif sym == "?":
            if vals or i == n or seq[i][0] not in QUERY_MODULES:
                raise CpfgError("?%s in a string with queries (?P ?H ?L ?U)"
                                % (seq[i][0] if i < n else ""))
            if not top:
                raise CpfgError("? in a homomorphism successor in a string with queries")
            q, qv = seq[i]
            vec = st[q]
            k = min(3, len(qv))
            seq[i] = (q, tuple(f32(vec[j]) for j in range(k)) + tuple(qv[k:]))
            i += 1
        elif sym == "~":
            if top:
                raise CpfgError("~ in a string with queries")
            # (In a homomorphism's branch: the surface's module is read;
            # the turtle it moves is given back by the branch's ].)
            return i + 1 if i < n else i
        return i


def format_string(S):
    parts = []
    for sym, vals in S:
        if vals:
            parts.append(sym + "(" + ",".join(fmt_g(v) for v in vals) + ")")
        else:
            parts.append(sym)
    return "".join(parts)


def load(path, functions=(), view=None):
    """`functions`: the --functions files, in order; `view`: the
    --cpfg-view file (its settings for the queries' turtle, and its
    functions and curves, numbered before those of `functions`)."""
    fs = FunctionSet()
    if view is not None:
        try:
            with open(view, encoding="utf-8") as f:
                fs.add_view(view, f.read())
        except OSError as e:
            raise CpfgError("cannot read %s: %s" % (view, e.strerror))
    for f in functions:
        fs.add_file(f)
    pp = Preprocessor()
    # cpfg's -Dname=i+1 for a function set's names (PreprocessLsystem)
    for name, num in fs.macros.items():
        pp.macros[name] = Macro(None, pp_lex(str(num)))
    lines = pp.run(path)
    rt = Runtime()
    rt.functions = fs.functions
    rt.curves = fs.curves
    # ran() & co. may run while the file is read (array initializers,
    # settings): main_xsubi is not reset after that; drand48 is seeded
    # after reading (control.c)
    rt.rng = Randomness(0)
    toks = Lexer(lines).tokens()
    ls = Parser(toks, rt).parse()
    rt.rng.main = Randomness(ls.seed).main
    rt.turtle_view = None
    if ls.queries:
        if view is None:
            raise CpfgError("queries (?P ?H ?L ?U) need the view file (--cpfg-view)", (path, 1))
        rt.turtle_view = read_turtle_view(view)
    return ls, rt


def run_file(path, n=None, homomorphism=True, functions=(), view=None):
    ls, rt = load(path, functions, view)
    steps = ls.n if n is None else n
    return format_string(Deriver(ls, rt).derive(steps, homomorphism))


# ---------------------------------------------------------------------------
# Self test: facts that do not depend on the models
# ---------------------------------------------------------------------------


def self_test():
    ok = True

    def check(what, got, want):
        nonlocal ok
        if got != want:
            ok = False
            print("FAIL %s: got %r, want %r" % (what, got, want))

    # drand48 after srand48(0) (X = 0x330E): the POSIX LCG by hand.
    r = Rand48(0x330E)
    x1 = (0x5DEECE66D * 0x330E + 0xB) % (1 << 48)
    check("drand48 step", r.next(), x1 / 2.0 ** 48)
    # unseeded glibc drand48 (X = 0): first X is c = 11
    check("unseeded", Rand48(0).next(), 11 / 2.0 ** 48)
    # seed48({7, 0, 155}) state
    check("seed48", Rand48.from_xsubi(7, 0, 155).x, (155 << 32) | 7)
    # values printed once by glibc's drand48/erand48 (gcc, Debian) for
    # comparison: unseeded, after seed48({7, 0, 155}), from {0x330E, 0, 0}
    r = Rand48(0)
    check("glibc unseeded", (r.next(), r.next()), (3.907985046680551e-14, 0.0009853946746503084))
    r = Randomness(7).main
    check("glibc seed48", (r.next(), r.next()), (0.5162368105493655, 0.4207841637977232))
    r = Randomness(0)
    check("glibc erand48", (r.ran(1), r.ran(1)), (0.17082803610628972, 0.7499019804849638))
    r.srand(42)
    check("srand(42)", r.ran(1), 0.7445250000610066)
    check("%g", fmt_g(f32(16777217.0)), "1.67772e+07")
    check("%g -0", fmt_g(-0.0), "-0")
    check("f32 0.1", fmt_g(f32(0.1) * 3), "0.3")
    rt = Runtime()
    rt.rng = Randomness(0)
    p = Parser(Lexer([("Lsystem: 1", ("t", 1)), ("derivation length: -2^2", ("t", 2))]).tokens(), rt)
    p.take()
    p.take()
    p.take()
    p.take()
    check("-2^2", rt.eval(p.expression()), 4.0)
    for text, want in [("2^3^2", 64.0), ("2.5 % 2", 0.0), ("-7 % 3", -1.0), ("1/0", 1.0),
                       ("trunc(2.5)", 3.0), ("trunc(-2.5)", -2.0), ("atan(1, 0)", 0.0),
                       ("1 ? 2 : 3", 2.0), ("!0 + 1", 2.0), ("3 <> 4", 1.0),
                       ("sin(90)", 1.0), ("1 + 2 * 3 ^ 2", 19.0), ("undefinedname", 0.0)]:
        toks = Lexer([("Lsystem: 1", ("t", 1)), ("seed: " + text, ("t", 2))]).tokens()
        p = Parser(toks, rt)
        p.pos = 4
        check(text, rt.eval(p.expression()), want)
    ok = self_test_functions() and ok
    ok = self_test_arrays() and ok
    ok = self_test_curves() and ok
    ok = self_test_turtle() and ok
    print("self-test %s" % ("passed" if ok else "FAILED"))
    return 0 if ok else 1


def self_test_functions():
    """func: the spline by a second method (de Boor's algorithm), values
    known by hand, the file formats and the macros."""
    import random
    import tempfile

    ok = True

    def check(what, good, detail=""):
        nonlocal ok
        if not good:
            ok = False
            print("FAIL %s %s" % (what, detail))

    # 1. cpfg's sum of basis functions against de Boor's algorithm, on
    # random control points (repeated points too) at many parameters.
    r = random.Random(5)
    worst = 0.0
    for _ in range(40):
        pts = []
        for _ in range(r.randint(4, 12)):
            p = (f32(r.random()), f32(r.uniform(-2, 2)))
            pts.extend([p] * r.choice([1, 1, 1, 2, 3]))
        fn = SplineFunction(pts, -1)
        for i in range(400):
            d = i / 400.0 if i % 2 else r.random()
            a = fn.point(d)
            b = fn.point_de_boor(d)
            worst = max(worst, abs(a[0] - b[0]), abs(a[1] - b[1]))
        # cpfg's curve at d = 1 (u = n-2, in no span) is (0, 0)
        check("P(1)", fn.point(1.0) == (0.0, 0.0) == fn.point_de_boor(1.0))
        check("P(0)", max(abs(fn.point(0.0)[0] - pts[0][0]), abs(fn.point(0.0)[1] - pts[0][1])) < 1e-15)
    check("de Boor", worst <= 1e-12, "worst %r" % worst)

    # 2. four points on y = x, evenly spaced: one cubic segment, P(d) = (d, d)
    third = [f32(0.0), f32(1 / 3.0), f32(2 / 3.0), f32(1.0)]
    lin = SplineFunction([(v, v) for v in third], -1)
    lin10 = SplineFunction([(v, v) for v in third], 10)
    for x in [0.0, 0.001, 0.1, 0.25, 0.5, 0.7, 0.9999, 1.0]:
        check("y = x at %r" % x, abs(lin.value(x) - x) <= 0.001 + 1e-7, repr(lin.value(x)))
        check("y = x sampled at %r" % x, abs(lin10.value(x) - x) <= 0.001 + 1e-7, repr(lin10.value(x)))
    check("clamp low", lin.value(-3.0) == lin.value(0.0))
    check("clamp high", lin.value(7.0) == lin.value(1.0))
    check("clamp inf", lin10.value(math.inf) == lin10.value(1.0) == lin10.vals[9])
    # the table's ends and its linear interpolation
    check("table", lin10.value(1 / 3.0 + 1e-9) != lin10.vals[3] and
          abs(lin10.value(0.5) - (0.5 * lin10.vals[4] + 0.5 * lin10.vals[5])) < 1e-15)

    # 3. the shape of a Lilac-like elasticity function (4 points, so one
    # Bezier segment): the value at x against the Bezier solved for x by
    # Newton's method; the bisection stops within 0.001 in x, so the
    # difference is at most 0.001 times the slope (< 1 here).
    elas = [(0.0, 0.49528), (0.301001, 0.479716), (0.621178, 0.408565), (1.0, 0.235135)]
    elas = [(f32(x), f32(y)) for x, y in elas]
    fe = SplineFunction(elas, -1)

    def bez(c, d):
        e = 1 - d
        return e * e * e * c[0] + 3 * e * e * d * c[1] + 3 * e * d * d * c[2] + d * d * d * c[3]

    xs = [p[0] for p in elas]
    ys = [p[1] for p in elas]
    for x in [0.0, 0.1, 0.3, 0.5, 0.75, 0.95, 1.0]:
        d = x
        for _ in range(60):
            e = 1 - d
            dx = 3 * (e * e * (xs[1] - xs[0]) + 2 * e * d * (xs[2] - xs[1]) + d * d * (xs[3] - xs[2]))
            d = min(1.0, max(0.0, d - (bez(xs, d) - x) / dx))
        want = bez(ys, d)
        check("elas(%r)" % x, abs(fe.value(x) - want) < 0.001, "%r vs %r" % (fe.value(x), want))
    check("elas decreasing", fe.value(0.2) > fe.value(0.6) > fe.value(0.9))

    # 4. a curve whose x never reaches the target: cpfg's bisection hangs
    flat = SplineFunction([(0.0, 1.0)] * 4, -1)
    try:
        flat.value(0.5)
        check("no convergence", False, "not refused")
    except CpfgError:
        pass
    check("flat at 0", flat.value(0.0) == 1.0)
    try:
        SplineFunction([(0.0, 1.0)] * 4, 5)
        check("no convergence in the table", False, "not refused")
    except CpfgError:
        pass

    # 5. decimals read as 32-bit floats: the nearest float to the decimal
    # (1 + 2^-24 and a bit: the double rounds to the tie, the float up)
    check("f32 read", parse_f32("1.000000059604644775390625000000000001", None)
          == 1.0 + 2.0 ** -23)
    check("f32 read 0.1", parse_f32("0.1", None) == f32(0.1))

    # 6. the files: a view file, a function set with names, multiplicity,
    # the old format, background and markers
    with tempfile.TemporaryDirectory() as tmp:
        def put(name, text):
            with open(os.path.join(tmp, name), "w") as f:
                f.write(text)
            return os.path.join(tmp, name)

        put("old.func", "range: 0.0 1.0\npoints: 4\n0 0\n0.333333 0.333333\n"
            "0.666667\t0.666667\n1 1\n")
        put("new.func", "fver 1 1\nname: new\nsamples: 3\nflip: off\npoints: 4\n"
            "0 1\n0.5 2 2\n0.7 2.5\n1 3\n")
        put("s.fset", "funcgalleryver 1 1\nitems: 2\nfver 1 1\nname: up\nsamples: 0\n"
            "background: none\nbg line 2\nmarkers: 1\nm1 0.5 0.5\nflip: on\npoints: 4\n"
            "0 0\n0.333333 0.333333\n0.666667 0.666667\n1 1\n"
            "fver 1 1\nname: 2bad\nsamples: 10\nflip: off\npoints: 4\n"
            "0 5\n0.25 5\n0.75 5\n1 5\n")
        plain = put("p.v", "/* a view file */\nangle factor: 3\nfunction: old.func\n"
                    "function :  new.func 50\n")
        fs = FunctionSet()
        fs.add_file(plain)
        got = [(len(f.points), f.samples) for f in fs.functions]
        check("view", got == [(4, -1), (5, 3)], repr(got))
        check("multiplicity", fs.functions[1].points[1] == fs.functions[1].points[2] == (0.5, 2.0))
        check("tab in old format", fs.functions[0].points[2][0] == f32(0.666667))
        # A set resets what the view file listed before it; a function: line
        # after it turns its macros off (cpfg's Reset, SetFunctionsFromGallery).
        view = put("v.v", "function: old.func\nfunction   set: s.fset\n")
        fs = FunctionSet()
        fs.add_file(view)
        got = [(len(f.points), f.samples) for f in fs.functions]
        check("set resets", got == [(4, 0), (4, 10)], repr(got))
        check("macros", fs.macros == {"up": 1}, repr(fs.macros))
        later = FunctionSet()
        later.add_file(put("w.v", "function set: s.fset\nfunction: old.func 7\n"))
        got = [(len(f.points), f.samples) for f in later.functions]
        check("function after set", got == [(4, 0), (4, 10), (4, 7)], repr(got))
        check("macros off", later.macros == {}, repr(later.macros))
        check("set value", abs(fs.functions[0].value(0.4) - 0.4) < 0.0011)
        lfile = put("m.l", "Lsystem: 1\nderivation length: 1\nAxiom: A(0.4)\n"
                    "A(x) --> B(up, func(up, x), func(2, 2))\nendlsystem\n")
        out = run_file(lfile, functions=[view])
        check("run", out == "B(1,%s,%s)" % (fmt_g(f32(fs.functions[0].value(0.4))),
                                         fmt_g(f32(fs.functions[1].value(1.0)))), out)
        for bad, text in [("few.func", "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 3\n"
                           "0 0\n0.5 0.5 3\n1 1\n"),
                          ("zero.func", "fver 1 1\\nname: a\\nsamples: 0\\nflip: off\\npoints: 4\\n"
                           "0 0\\n0.5 0.5 0\\n0.7 0.7\\n1 1\\n"),
                          ("tab.func", "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 4\n"
                           "0\t0\n0.3 0.3\n0.6 0.6\n1 1\n"),
                          ("eof.func", "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 4\n"
                           "0 0\n0.3 0.3\n0.6 0.6\n1 1"),
                          ("ver.func", "fver 1 2\nname: a\n")]:
            try:
                FunctionSet().add_file(put(bad, text))
                check(bad, False, "not refused")
            except CpfgError:
                pass
        try:
            run_file(lfile, functions=[put("one.func", "range: 0 1\npoints: 4\n0 0\n0.3 0\n"
                                           "0.6 0\n1 0\n")])
            check("func id out of range", False, "not refused")
        except CpfgError as e:
            check("func id located", e.where is not None)
    return ok


def self_test_curves():
    """curves: lengths and points known by hand, and the clamped kind
    against func's spline (de Boor's algorithm on the same knots)."""
    import random
    import tempfile

    ok = True

    def check(what, good, detail=""):
        nonlocal ok
        if not good:
            ok = False
            print("FAIL curves: %s %s" % (what, detail))

    # 1. Control points k (3, 4), k = 0..3, uniform B-spline: the curve is
    #    (u - 2)(3, 4) for u from 3 to 4 - 1e-6: a segment of length
    #    5 (1 - 1e-6), at constant speed, so curveX(t) = 3 (1 + t (1 - 1e-6)).
    c = read_contour("points: 4\n0 0\n3 4\n6 8\n9 12\n", "line.con", 100)
    check("line length", abs(c.alength - 4.999995) < 1e-12, c.alength)
    for t in (0.0, 0.25, 0.5, 0.9, 1.0, -1.0, 3.0):
        tc = min(max(t, 0.0), 1.0)
        s = 1 + tc * (1 - 1e-6)
        x = c.value(1, t, 0, None)
        y = c.value(1, t, 1, None)
        check("line at %r" % t, abs(x - 3 * s) < 1e-12 and abs(y - 4 * s) < 1e-12, (x, y))
    # 2. the same with end points 3 times (as vlab's editor writes them,
    #    dimension 4): from (0, 0) to (3, 4); 100 chords of a straight
    #    line are its length, 5.
    c = read_contour("points: 2\ndimension: 4\n0 0 0 3\n3 4 0 3\n", "end.con", 100)
    check("ends length", abs(c.alength - 5.0) < 1e-5, c.alength)
    check("ends start", max(abs(v) for v in c.p_value(0.0)) < 1e-12, c.p_value(0.0))
    # 3. the closed uniform B-spline of the square (1,1) (-1,1) (-1,-1)
    #    (1,-1): it starts at (P0 + 4 P1 + P2) / 6 = (-2/3, 2/3), and half
    #    its length on it is the opposite point (to the chords' accuracy)
    c = read_contour("points: 4\ntype: bspline-closed\n1 1\n-1 1\n-1 -1\n1 -1\n", "sq.con", 101)
    p0 = c.p_value(0.0)
    check("closed start", abs(p0[0] + 2 / 3) < 1e-12 and abs(p0[1] - 2 / 3) < 1e-12, p0)
    check("closed half", abs(c.value(1, 0.5, 0, None) + c.value(1, 0.0, 0, None)) < 1e-3)
    # 4. bspline-endpoint is func's clamped spline: the same point at
    #    u = t (n - 3.000001), by de Boor's algorithm there
    r = random.Random(3)
    for n in (4, 5, 7, 9):
        pts = [(r.uniform(-1, 1), r.uniform(-1, 1)) for _ in range(n)]
        text = "points: %d\ntype: bspline-endpoint\n%s\n" % (
            n, "\n".join("%r %r" % p for p in pts))
        c = read_contour(text, "e.con", 10)
        f = SplineFunction(pts, 0)
        for t in (0.0, 0.1, 0.37, 0.5, 0.99, 1.0):
            d = t * (n - 3.000001) / (n - 3)
            a = c.p_value(t)
            b = f.point_de_boor(d)
            check("endpoint n=%d t=%r" % (n, t),
                  abs(a[0] - b[0]) < 1e-12 and abs(a[1] - b[1]) < 1e-12, (a, b))
    # 5. one Bezier segment: Bernstein polynomials at t / 1.000001
    pts = [(0, 0), (1, 2), (3, 3), (4, 0)]
    c = read_contour("points: 4\ntype: bezier\n%s\n" % "\n".join("%d %d" % p for p in pts),
                     "b.con", 10)
    for t in (0.0, 0.3, 0.5, 1.0):
        s = t / 1.000001
        w = [(1 - s) ** 3, 3 * s * (1 - s) ** 2, 3 * s * s * (1 - s), s ** 3]
        want = [sum(w[k] * pts[k][d] for k in range(4)) for d in range(2)]
        got = c.p_value(t)
        check("bezier %r" % t, abs(got[0] - want[0]) < 1e-12 and abs(got[1] - want[1]) < 1e-12,
              (got, want))
    # 6. a view file: functions and curves numbered apart; errors located
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "a.con"), "w") as f:
            f.write("points: 4\n0 0\n3 4\n6 8\n9 12\n")
        with open(os.path.join(d, "f.func"), "w") as f:
            f.write("range: 0 1\npoints: 4\n0 0\n0.3 0.3\n0.6 0.6\n1 1\n")
        with open(os.path.join(d, "m.v"), "w") as f:
            f.write("function: f.func\ncurve: a.con 11\ncurve: a.con\n")
        fs = FunctionSet()
        fs.add_file(os.path.join(d, "m.v"))
        check("numbering", (len(fs.functions), len(fs.curves)) == (1, 2))
        check("samples", (fs.curves[0].asize, fs.curves[1].asize) == (11, 100))
        for text, line in [("points: 4\n0 0\n1 1", 3), ("0 0\npoints: 4\n", 1),
                           ("points: 4\ndimension: 4\n0 0 0 -2\n", 3),
                           ("points: 1\n0 0\n1 1\n", 3), ("points: 3\n0 0\n1 1\n2 2\n", 1)]:
            try:
                read_contour(text, "bad.con", 100)
                check("refused %r" % text, False)
            except CpfgError as e:
                check("located %r" % text, e.where == ("bad.con", line), e.where)
    return ok


def self_test_turtle():
    """The queries' turtle: positions and vectors computed by hand (start:
    H = (0,1,0), L = (-1,0,0), U = (0,0,-1); a turn by a: H' = cos a H +
    sin a L, L' = cos a L - sin a H, and likewise for the other pairs),
    when the queries are filled, and what a file with queries may not
    have."""
    import tempfile

    ok = True

    def check(what, got, want):
        nonlocal ok
        if got != want:
            ok = False
            print("FAIL turtle %s: got %r, want %r" % (what, got, want))

    with tempfile.TemporaryDirectory() as tmp:
        def run(axiom, view="", n=0, prods="", view_file=True, homomorphism=True):
            path = os.path.join(tmp, "a.l")
            with open(path, "w") as f:
                f.write("Lsystem: 1\nderivation length: 1\nAxiom: %s\n%sendlsystem\n"
                        % (axiom, prods))
            vpath = os.path.join(tmp, "a.v")
            with open(vpath, "w") as f:
                f.write(view)
            return run_file(path, n, homomorphism, view=vpath if view_file else None)

        # F(2): P = (0,2,0). +(90): sin 1, cos 6.12323e-17 (cos of the
        # double nearest pi/2): H = (-1, cos, 0), L = (-cos, -1, 0). F(1):
        # P = (-1, 2 + cos, 0), 2 as a float. The 4th parameter of ?L stays.
        check("F(2)+(90)F(1)", run("F(2)+(90)F(1)?P(7,7,7)?H(0,0,0)?L(0,0,0,4)?U(0,0)"),
              "F(2)+(90)F(1)?P(-1,2,0)?H(-1,6.12323e-17,0)?L(-6.12323e-17,-1,0,4)?U(0,0)")
        # the default angle, 45: +F is (-sin 45, cos 45, 0); a query with
        # fewer parameters gets fewer values, with none it is left alone
        check("+F", run("+F?P(0)?P?P(0,0)"), "+F?P(-0.707107)?P?P(-0.707107,0.707107)")
        # angle factor: 12 is 30 degrees, turned by -: H = (sin 30, cos 30)
        check("angle factor", run("-F?P(0,0,0)", "angle factor: 12\n"), "-F?P(0.5,0.866025,0)")
        # |: H' = -1 H + 0 L, L' = -1 L + (-0) H: L = (1, -0, -0) in IEEE
        # (-1 * 0 = -0, -0 * 1 = -0, -0 + -0 = -0)
        check("|", run("|F?P(9,9,9)?L(9,9,9)"), "|F?P(0,-1,0)?L(1,-0,-0)")
        # &(90): H = (0, cos, -1), U = (0, -1, -cos); /(90) rolls: L =
        # (-cos, -1, -cos); @v: L = Y x H = (-1, 0, 0), U = L x H = (-0,
        # -1, -cos): the roll undone
        check("@v", run("&(90)/(90)?L(9,9,9)@v?L(9,9,9)?U(9,9,9)"),
              "&(90)/(90)?L(-6.12323e-17,-1,-6.12323e-17)@v?L(-1,0,0)?U(-0,-1,-6.12323e-17)")
        # @v with a vertical heading does nothing
        check("@v vertical", run("/(90)@v?L(9,9,9)"), "/(90)@v?L(-6.12323e-17,0,-1)")
        # @M: to (x, y, 0) or (x, y, z); one parameter: nothing
        check("@M", run("@M(3,4)?P(9,9,9)F@M(1,2,3)?P(9,9,9)@M(5)?P(9,9,9)"),
              "@M(3,4)?P(3,4,0)F@M(1,2,3)?P(1,2,3)@M(5)?P(1,2,3)")
        # [ ] restore; @o @O @c and other modules do nothing
        check("branches", run("F[+(90)F?P(9,9)]@o(2)A!(3);F?P(9,9)"),
              "F[+(90)F?P(-1,1)]@o(2)A!(3);F?P(0,2)")
        # tropism (1,0,0), elasticity 0.25: after F, the first bend (T.U = 0)
        # changes nothing, the second has sine 0.25 * (T.L) = -0.25 and
        # cosine sqrt(0.9375) = 0.968246: H = (0.25, 0.968246, 0); the next
        # F reaches (0.25, 1 + 0.968246, 0)
        check("bend", run("F?H(9,9,9)F?P(9,9,9)",
                          "tropism direction: 1,0,0\ninitial elasticity: 0.25\n"),
              "F?H(0.25,0.968246,0)F?P(0.25,1.96825,0)")
        # _(0) stops the bending, _ adds the increment (0 + 0.25)
        check("_", run("_(0)F?H(9,9,9)_F?H(9,9,9)",
                       "tropism direction: 1,0,0\nelasticity increment: 0.25\n"),
              "_(0)F?H(0,1,0)_F?H(0.25,0.968246,0)")
        # initial scale: F and f move p * scale
        check("scale", run("F(3)f?P(9,9,9)", "initial scale: 0.5\n"), "F(3)f?P(0,2,0)")
        # the tropism direction is normalized in float arithmetic: 1/3
        # rounded to a float, not the double 1/3
        tv = TurtleView()
        path = os.path.join(tmp, "t.v")
        with open(path, "w") as f:
            f.write("tropism direction: 1,2,2\n")
        tv = read_turtle_view(path)
        check("tropism in floats", tv.tropism, (f32(1 / 3), f32(2 / 3), f32(2 / 3)))
        # % with `interpretation past %: off`: the rest of the branch is
        # skipped (its query keeps its values), the ] still pops; with the
        # default (on) % does nothing to the turtle
        check("% off", run("F[%F?P(9,9)]F?P(9,9)", "interpretation past %: off\n"),
              "F[%F?P(9,9)]F?P(0,2)")
        check("% on", run("F[%F?P(9,9)]F?P(9,9)"), "F[%F?P(0,2)]F?P(0,2)")
        # when: the string a step rewrites is filled before the step (the
        # context sees y = 2, not the axiom's 0), and the final string too
        check("before the step",
              run("F(2)A?P(0,0)", n=1, prods="A > ?P(x,y) : y > 1.5 --> B(y)F\n"),
              "F(2)B(2)F?P(0,3)")
        check("a query predecessor",
              run("+(90)F?P(0,0,0)", n=1, prods="?P(x,y,z) : x < 0 --> ?P(x,y,z)F(1)\n"),
              "+(90)F?P(-1,6.12323e-17,0)F(1)")
        # the saved string: filled, but not with `box:` (no view volume
        # to work out) unless `environment display: before`
        box = "box: x: -1,1 y: -1,1 z: -1,1\n"
        check("box:", run("A", box, 2, "A --> F(1)?P(9,9)A\n"), "F(1)?P(0,1)F(1)?P(9,9)A")
        check("box: and before",
              run("A", box + "environment display: before\n", 2, "A --> F(1)?P(9,9)A\n"),
              "F(1)?P(0,1)F(1)?P(0,2)A")
        # a homomorphism that cannot change the turtle: the string is
        # interpreted through it (its successors' branches, `%` ignored in
        # them, @O, @G), with the same values as without it; the saved
        # string gets the homomorphism as usual
        for view in ("", "interpretation past %: off\n"):
            bare = run("F(2)A?P(9,9)+(90)B?P(9,9)C(1)?H(9,9,9)", view, 1,
                       "A --> F(1)A\n")
            check("a still homomorphism " + view,
                  run("F(2)A?P(9,9)+(90)B?P(9,9)C(1)?H(9,9,9)", view, 1,
                      "A --> F(1)A\nhomomorphism\nA --> [F(5)+F(3)@O]\n"
                      "B --> X[&%F(2)]Y;(2)[F@Gs[G]]\nY --> [g(4)]\n"
                      "C(x) : x > 0 --> [|F(x)]C\nP(x,y) --> [F]\n", homomorphism=False),
                  bare)
            check("a still homomorphism, the saved string " + view,
                  run("F(2)A?P(9,9)+(90)B?P(9,9)C(1)?H(9,9,9)", view, 1,
                      "A --> F(1)A\nhomomorphism\nA --> [F(5)+F(3)@O]\n"
                      "B --> X[&%F(2)]Y;(2)[F@Gs[G]]\nY --> [g(4)]\n"
                      "C(x) : x > 0 --> [|F(x)]C\n"),
                  bare.replace("A?", "[F(5)+F(3)@O]?").replace(
                      "B?", "X[&%F(2)]Y;(2)[F@Gs[G]]?").replace("C(1)?", "[|F(1)]C?"))
        # ... with maximum depth: 2, a production rewriting a module of
        # another's successor, contexts and conditions reading the queries
        check("a still homomorphism, depth 2",
              run("F(1)A?P(9,9)B?P(9,9)", "", 1,
                  "homomorphism\nmaximum depth: 2\nA --> [F]D(1)\n"
                  "?P(x,y) < B : y > 0.5 --> E[+F]D(2)\nD(x) > ?P(u,v) : v > 0.5 --> [G(x)]\n"),
              "F(1)[F][G(1)]?P(0,1)E[+F][G(2)]?P(0,1)")
        # the homomorphism's successors are really interpreted: a moving
        # module inside them (were the rule wrong) would show
        path = os.path.join(tmp, "a.l")
        with open(path, "w") as f:
            f.write("Lsystem: 1\nderivation length: 1\nAxiom: A?P(9,9)\n"
                    "homomorphism\nA --> [F]\nendlsystem\n")
        vpath = os.path.join(tmp, "a.v")
        with open(vpath, "w") as f:
            f.write("")
        ls, rt = load(path, view=vpath)
        ls.homo[0].succ = ls.homo[0].succ[1:2]  # A --> F, past the check
        check("interpreted through the homomorphism",
              format_string(QueryTurtle(rt.turtle_view).fill(
                  [("A", ()), ("?", ()), ("P", (9.0, 9.0))], Deriver(ls, rt))),
              "A?P(0,1)")
        # a bend past 1 in a homomorphism's branch: NaN there (cpfg's sqrt
        # of a negative number), discarded by its ]
        trop = "tropism direction: 1,0,0\n"
        check("a bend past 1 in a homomorphism branch",
              run("F(1)A?P(9,9)F?H(9,9)", trop, 1,
                  "homomorphism\nA --> [_(2)F(1)F(1)]\n", homomorphism=False),
              run("F(1)A?P(9,9)F?H(9,9)", trop, 1))
        # a homomorphism that moves the turtle: followed (I(2) as F(2), A
        # as -(90): H = (1, cos 90, 0)), to maximum depth (I(1) as two
        # J(1), each F(1)), through a moving predecessor (F as F+(90)),
        # and with a multi-module predecessor (A B as F(3))
        check("a moving homomorphism",
              run("I(2)A?P(9,9)?H(9,9,9)", "", 1,
                  "homomorphism\nI(l) --> F(l)\nA --> -(90)\n", homomorphism=False),
              "I(2)A?P(0,2)?H(1,6.12323e-17,0)")
        check("a moving homomorphism, depth 2",
              run("I(1)?P(9,9)", "", 1,
                  "homomorphism\nmaximum depth: 2\nI(l) --> J(l)J(l)\nJ(l) --> F(l)\n",
                  homomorphism=False),
              "I(1)?P(0,2)")
        check("a moving predecessor",
              run("F?H(9,9)", "", 1, "homomorphism\nF --> F+(90)\n", homomorphism=False),
              "F?H(-1,6.12323e-17)")
        check("a multi-module predecessor",
              run("AB?P(9,9)", "", 1, "homomorphism\nA B --> F(3)\n", homomorphism=False),
              "AB?P(0,3)")
        # @G + s c e t r does not move the turtle
        check("@G", run("F@Gs@Gc(2)F@Ge(2)@Gt(1,2)@Gr(1)?P(9,9)"),
              "F@Gs@Gc(2)F@Ge(2)@Gt(1,2)@Gr(1)?P(0,2)")
        # -- movements (view `tropism:` / `torque:`, @T); movements.c --
        # T: 1,0,0 E: 0.5 (gamma 0: cos 1, sin 0): the global sum (gea,
        # geb, gec) = 1 * 0.5 * T = (0.5, 0, 0). Before the F's move
        # (movement_adjust): rot = H x (0.5,0,0) = (0,0,-0.5), |rot| = 0.5
        # < 1, the quaternion q = (cos -0.25, sin -0.25 * (0,0,-1)) turns
        # H (q^-1 v q) by 0.5 rad about +z... towards T: H = (sin 0.5, cos
        # 0.5, 0) = (0.479426, 0.877583, 0), and the F moves along it. The
        # second F: rot = H x (0.5,0,0) has length 0.5 cos 0.5, so H turns
        # to the angle a = 0.5 + 0.5 cos 0.5 = 0.938791 from y: (0.806845,
        # 0.590764, 0); P = (sin 0.5 + sin a, cos 0.5 + cos a) = (1.28627,
        # 1.46835). adjust_up_and_left: U = prev U (0,0,-1) turned about z
        # stays; L = H x U = (-cos 0.5, sin 0.5, 0).
        mv1 = "tropism: T: 1,0,0 E: 0.5\n"
        check("tropism", run("F?H(9,9,9)?P(9,9,9)?L(9,9,9)?U(9,9,9)F?H(9,9,9)?P(9,9,9)", mv1),
              "F?H(0.479426,0.877583,0)?P(0.479426,0.877583,0)?L(-0.877583,0.479426,0)"
              "?U(0,0,-1)F?H(0.806845,0.590764,0)?P(1.28627,1.46835,0)")
        # a roll is undone by the next F's adjust_up_and_left: after F, H =
        # (sin 0.5, cos 0.5, 0), U = (0,0,-1) = prev U; /(90): U' = cos 90 U
        # - L = (cos 0.5, -sin 0.5, -6.12323e-17). The second F turns H
        # about z (rot = H x (0.5,0,0) is along -z): U = the previous U
        # (0,0,-1) turned about z, (0,0,-1), the roll lost
        check("a roll undone by the tropism",
              run("F/(90)?U(9,9,9)F?U(9,9,9)", mv1),
              "F/(90)?U(0.877583,-0.479426,-6.12323e-17)F?U(0,0,-1)")
        # the label's words: `tropism: Tropism 1 0 0 Elasticity: 0.5` (each
        # command by its first letter, numbers split by blanks, commas or
        # colons) is the same line
        check("tropism, other words",
              run("F?H(9,9,9)", "tropism: Tropism 1 0 0 Elasticity: 0.5\n"),
              "F?H(0.479426,0.877583,0)")
        # T: 0,-1,0 A: 90 E: 1 (plagiotropism): cos 90 = 6.12323e-17, so
        # gea.. = (0, -6.12323e-17, 0); sin 90 = 1, esin = 1. H = (0,1,0)
        # is parallel to T (|H x T| = 0 < 1e-7): the left vector (-1,0,0)
        # is the axis, T x L = (0,-0,-1), times esin / 1: des = (0,
        # -6.12323e-17, -1); rot = H x des = (-1, 0, ~0), length 1 (the
        # clamp): H turns 1 rad towards -z: H = (0, cos 1, -sin 1) =
        # (0, 0.540302, -0.841471). adjust_up_and_left turns the previous
        # U (0,0,-1) by the rotation from (0,1,0) to H (1 rad about -x):
        # U = (0, -sin 1, -cos 1).
        check("tropism, A: 90",
              run("F?H(9,9,9)?U(9,9,9)", "tropism: T: 0,-1,0 A: 90 E: 1\n"),
              "F?H(0,0.540302,-0.841471)?U(0,-0.841471,-0.540302)")
        # torque T: 1,0,0 E: 0.5: twist dir (0.5,0,0), length 0.5; the
        # tropism sum is 0 (no rotation of H). Twist: vec = H x (1,0,0) =
        # (0,0,-1), des = vec x H = (1,0,0) * 0.5; rotate_to_vector(U,
        # des): v = U x des = (0,-0.5,0), angle 0.25, q = (cos 0.25, sin
        # 0.25 * (0,-1,0)): q^-1 U q turns U by 0.5 rad about +y: U =
        # (-sin 0.5, 0, -cos 0.5) (away from des: cpfg's sign), L = H x U =
        # (-cos 0.5, 0, sin 0.5); H and P as without it.
        check("torque",
              run("F?U(9,9,9)?L(9,9,9)?H(9,9,9)?P(9,9,9)", "torque: T: 1,0,0 E: 0.5\n"),
              "F?U(-0.479426,0,-0.877583)?L(-0.877583,0,0.479426)?H(0,1,0)?P(0,1,0)")
        # @Ts(1,0.3) in a branch: aux = 0.3f - 0 (the turtle's elasticity),
        # gea = 0 + 1 * 0.3f * 1 = 0.3f: H turns by 0.3f rad: (sin 0.3f,
        # cos 0.3f) = (0.29552, 0.9553364856), which the query stores as
        # the float 0.9553365111 (%g 0.955337). At ]: 0 - 0.3f != 0, update by
        # -0.3f: gea = 0 exactly, so after the branch F does not bend.
        check("@Ts in a branch",
              run("[@Ts(1,0.3)F?H(9,9,9)]F?H(9,9,9)", "tropism: T: 1,0,0\n"),
              "[@Ts(1,0.3)F?H(0.29552,0.955337,0)]F?H(0,1,0)")
        # @Ti(1): + S (0.25), H turns by 0.25: (sin 0.25, cos 0.25) =
        # (0.247404, 0.968912); @Td(1): - 0.25, gea = 0, the next F keeps H.
        # Without a parameter @Ti does nothing; index 2 is out of range
        # (ignored); @Ti(1.9): (short)(1.9 - 1) = 0, movement 1.
        mvs = "tropism: T: 1,0,0 S: 0.25\n"
        check("@Ti @Td", run("@Ti(1)F?H(9,9)@Td(1)F?H(9,9)", mvs),
              "@Ti(1)F?H(0.247404,0.968912)@Td(1)F?H(0.247404,0.968912)")
        check("@Ti without a parameter, out of range",
              run("@TiF?H(9,9)@Ti(2)F?H(9,9)", mvs), "@TiF?H(0,1)@Ti(2)F?H(0,1)")
        check("@Ti(1.9)", run("@Ti(1.9)F?H(9,9)", mvs), "@Ti(1.9)F?H(0.247404,0.968912)")
        # @Ti(1,0.5): the second parameter instead of S: H = (sin 0.5, ...)
        check("@Ti(1,0.5)", run("@Ti(1,0.5)F?H(9,9)", mvs), "@Ti(1,0.5)F?H(0.479426,0.877583)")
        # @Tp: adjust_up_and_left. &(90): H = (0, cos 90, -1), U = (0, -1,
        # -cos 90); /(90) rolls U to (1, -cos, -cos^2). @Tp: the rotation
        # from the previous heading (0,1,0) to H is -90 degrees about x;
        # the previous U (0,0,-1) turned by it is (0,-1,~0): the roll is
        # undone, L = H x U = (-1, ~0, ~0)
        check("@Tp", run("&(90)/(90)?U(9,9)@Tp?U(9,9)?L(9)"),
              "&(90)/(90)?U(1,-6.12323e-17)@Tp?U(0,-1)?L(-1)")
        # F sets the previous heading and up (here H = (0, cos 90, -1), U =
        # (0, -1, -cos 90) after &(90)), f does not: after F, @Tp finds H
        # = prev H (|H x prev H| = 0) and keeps the rolled U; after f the
        # previous ones are still the start's, and the roll is undone as above
        check("F sets prev, f does not",
              run("&(90)F/(90)@Tp?U(9,9)"), "&(90)F/(90)@Tp?U(1,-6.12323e-17)")
        check("f does not set prev", run("&(90)f/(90)@Tp?U(9,9)"), "&(90)f/(90)@Tp?U(0,-1)")
        # @Tf sets the previous heading and up: @Tp after it changes nothing
        check("@Tf", run("&(90)/(90)@Tf@Tp?U(9,9)"), "&(90)/(90)@Tf@Tp?U(1,-6.12323e-17)")
        # @Tx(n): the texture only
        check("@Tx(1)", run("@Tx(1)F?P(9,9)", mv1), run("F?P(9,9)", mv1).replace("F", "@Tx(1)F"))
        # a line cpfg ignores (its first word `1` is no command): no movement
        check("an ignored torque: line", run("F?H(9,9)", "torque: 1\n"), "F?H(0,1)")
        # T: 0,10,0 I: 5: the clamp is on (1/|T|) * I = 0.5, not on I: dir
        # = (0, 5, 0)... * 0.1 * 5 = (0,5*0.5,0)? no: dir * 0.5 = (0,5,0);
        # with E: 0.1 gea.. = (0, 0.5, 0): parallel to H, no rotation; the
        # vector is kept as cpfg reads it
        tv = TurtleView()
        vpath2 = os.path.join(tmp, "m.v")
        with open(vpath2, "w") as f:
            f.write("tropism: T: 0,10,0 I: 5 E: 0.1\ntropism: T: 0,1,0 I: 3\n"
                    "tropism: E: 1 X\ntorque: E: 1\n")
        tv = read_turtle_view(vpath2)
        check("I: the clamp on 1/|T| times I",
              [m.dir for m in tv.movements.slots[:3]] + [tv.movements.n],
              # (0,10,0)/10*5; (0,1,0) * min(3, 1); the third line is
              # ignored (X), the torque line in its slot keeps the dir the
              # ignored line left there, times 0 (no T): (0, 1*0, 0)
              [[0.0, 5.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], 3])
        # the global sums persist from one fill to the next: E: 0.1 and a
        # top-level @Ti(1,0.7): gea = 0.1 + 0.7f = 0.799999988079071 after
        # the first fill; the second fill's init updates by 0.1 - gea:
        # gea = 0.799999988079071 + (0.1 - 0.799999988079071) =
        # 0.09999999999999998, not 0.1
        path = os.path.join(tmp, "a.l")
        with open(path, "w") as f:
            f.write("Lsystem: 1\nderivation length: 1\nAxiom: @Ti(1,0.7)?P(9)\nendlsystem\n")
        with open(vpath2, "w") as f:
            f.write("tropism: T: 1,0,0 E: 0.1\n")
        ls, rt = load(path, view=vpath2)
        qt = QueryTurtle(rt.turtle_view)
        d = Deriver(ls, rt)
        S = [("@", ()), ("T", ()), ("i", (1.0, f32(0.7))), ("?", ()), ("P", (9.0,))]
        qt.fill(S, d)
        check("the sums after a fill", qt.mv.ge[0], 0.1 + f32(0.7))
        qt.fill([("?", ()), ("P", (9.0,))], d)
        check("the sums persist", qt.mv.ge[0], 0.09999999999999998)
        check("a new run starts afresh", QueryTurtle(rt.turtle_view).mv.ge[0], 0.1)
        # a homomorphism with @T: followed (A as @Ti(1): H turns by 0.25)
        check("@T in a homomorphism",
              run("AF?H(9,9)", mvs, 1, "homomorphism\nA --> @Ti(1)\n", homomorphism=False),
              "AF?H(0.247404,0.968912)")
        # ... in its branch: the ] gives the elasticity back (gea 0)
        check("@T in a homomorphism's branch",
              run("AF?H(9,9)", mvs, 1, "homomorphism\nA --> [@Ti(1)F]\n", homomorphism=False),
              "AF?H(0,1)")
        # refused
        for what, axiom, view, prods in [
                ("?(1)", "?(1)F", "", ""), ("?E", "?E(1)", "", ""), ("?Q", "?Q(1,2,3,4)", "", ""),
                ("?X", "?A(1)", "", ""), ("? at the end", "F?", "", ""),
                ("?P in a successor at its end", "A", "", "A --> F?\n"),
                ("homomorphism: % at depth 0", "?P(1)", "", "homomorphism\nA --> F%\n"),
                ("homomorphism: a predecessor a ? reads", "A?P(1)", "",
                 "homomorphism\nP(x) --> F\n"),
                ("homomorphism: a predecessor an @ reads", "A@v?P(1)", "",
                 "homomorphism\nA --> F\nv --> M(1,2)\n"),
                ("homomorphism: @G's subfunction", "A@Gs?P(1)", "",
                 "homomorphism\nA --> F\ns --> B\n"),
                ("homomorphism: ~ in a branch of one that moves", "A?P(1)", "",
                 "homomorphism\nA --> F[~l]\n"),
                ("homomorphism: @R in a branch of one that moves", "A?P(1)", "",
                 "homomorphism\nA --> F[@R(1,0,0)]\n"),
                ("homomorphism: a query module as a left context of one that moves",
                 "?P(1)A", "", "homomorphism\nP(x) < A --> F\n"),
                ("homomorphism: a pre-condition block", "?P(1)", "",
                 "homomorphism\nA : {t = 1;} 1 --> B\n"),
                ("homomorphism: an empty post-condition block", "?P(1)", "",
                 "homomorphism\nA : 1 {} --> B\n"),
                ("homomorphism: a probability", "?P(1)", "", "homomorphism\nA --> B : 0.5\n"),
                ("homomorphism: ran", "?P(1)", "", "homomorphism\nA --> B(ran(1))\n"),
                ("homomorphism: nran in a condition", "?P(1)", "",
                 "homomorphism\nA : nran(0,1) > 0 --> B\n"),
                ("homomorphism: srand", "?P(1)", "", "homomorphism\nA --> [B(srand(2))]\n"),
                ("homomorphism: ? in a successor", "?P(1)", "",
                 "homomorphism\nA --> [?P(1)]\n"),
                ("homomorphism: an unmatched ]", "?P(1)", "", "homomorphism\nA --> B]\n"),
                ("homomorphism: ] then [", "?P(1)", "", "homomorphism\nA --> ][\n"),
                ("homomorphism: an unclosed [", "?P(1)", "", "homomorphism\nA --> [B\n"),
                ("~", "?P(1)~A", "", ""), ("s(x,y)", "?P(1)s(1,2)", "", ""),
                ("@Gx", "?P(1)@Gx", "", ""), ("@G at the end", "?P(1)@G", "", ""),
                ("@ at the end", "?P(1)@", "", ""),
                ("tropism:", "?P(1)", "tropism: T1\n", ""),
                ("tropism: a number missing (atof of NULL)", "?P(1)", "tropism: T: 1,0\n", ""),
                # (with the newline, `E:\n` is E 0: atof("\n"))
                ("torque: E at the file's end", "?P(1)", "torque: T: 1,0,0 E:", ""),
                ("10 movements", "?P(1)", "tropism: T: 1,0,0\n" * 10, ""),
                ("@T with parameters", "?P(1)@T(1)i", "", ""),
                ("@T at the end", "?P(1)@T", "", ""), ("@Tq", "?P(1)@Tq", "", ""),
                ("@Tx without a parameter", "?P(1)@Tx", "", ""),
                ("homomorphism: @T's subfunction", "A@Ti(1)?P(1)", "",
                 "homomorphism\nA --> [@Ti(1)]\ni(x) --> B\n"),
                ("unmatched ]", "F]?P(1)", "", ""),
                ("a bend past 1", "_(2)F?P(1)", "tropism direction: 1,0,0\n", ""),
                ("?X made by a step", "?P(1)", "", "P(x) --> X\n")]:
            try:
                run(axiom, view, 1, prods)
            except CpfgError:
                continue
            check("refused " + what, "accepted", "refused")
        try:
            run("?P(1)", view_file=False)
            check("without a view", "accepted", "refused")
        except CpfgError:
            pass
    return ok


def self_test_arrays():
    """define: and arrays: values derived by hand."""
    import tempfile

    ok = True

    def check(what, got, want):
        nonlocal ok
        if got != want:
            ok = False
            print("FAIL arrays %s: got %r, want %r" % (what, got, want))

    with tempfile.TemporaryDirectory() as tmp:
        def run(text, n=None):
            path = os.path.join(tmp, "a.l")
            with open(path, "w") as f:
                f.write(text)
            del WARNINGS[:]
            return run_file(path, n)

        # A = 1..6 (7 is one too many), B = 10 20 0 0 (too few), C = 0 0.
        # Start: C[0] = A[1][2] = 6 (row-major: 1*3+2), then C[-4] (clamped
        # to C[0]) = 6 + 100. Each step: B[3] + 1 (StartEach:), X's
        # pre-condition block B[2] + n, its post-condition block C[1] + 1,
        # EndEach: C[1] * 2. A[5][-1] is A[1][0] = 4; A[0.5][1] is element
        # (int)(0.5*3 + 1) = 2, 3.
        model = ("Lsystem: 1\nderivation length: 3\ndefine: {\n"
                 "\tarray A[2][3] = {1, 2, 3,\n\t\t4, 5, 6, 7}, B[4] = {10, 20};\n"
                 "\tarray C[2];\n}\n"
                 "Start: {C[0] = A[1][2]; C[-4] = C[0] + 100;}\n"
                 "StartEach: {B[3] = B[3] + 1;}\nEndEach: {C[1] = C[1] * 2;}\n"
                 "Axiom: X(0)\n"
                 "X(n) : {B[2] = B[2] + n;} * {C[1] = C[1] + 1;} --> "
                 "X(n+1) Y(A[5][-1], A[1][2], A[0.5][1], B[2], B[3], C[0], C[1])\n"
                 "endlsystem\n")
        check("step 1", run(model, 1), "X(1)Y(4,6,3,0,1,106,1)")
        check("warnings", sorted(w.split(": ", 1)[1] for w in WARNINGS
                                 if "initialisers" in w or "Subscript" in w),
              sorted(["Too many initialisers (array A)", "Too few initialisers (array B)"] * 2
                     + ["Subscript # 1 = -4 out of range for C; using 0",
                        "Subscript # 1 = 5 out of range for A; using 1",
                        "Subscript # 2 = -1 out of range for A; using 0"]))
        check("step 2", run(model, 2), "X(2)Y(4,6,3,1,2,106,3)Y(4,6,3,0,1,106,1)")
        check("step 3", run(model, 3),
              "X(3)Y(4,6,3,3,3,106,7)Y(4,6,3,1,2,106,3)Y(4,6,3,0,1,106,1)")
        # Doubles, not 32-bit floats: 16777217 survives in the array.
        check("doubles", run("Lsystem: 1\nderivation length: 1\n"
                             "define: {array D[1] = {16777216};}\n"
                             "Start: {D[0] = D[0] + 1;}\nAxiom: X\n"
                             "X --> Y(D[0] - 16777216)\nendlsystem\n"), "Y(1)")
        # The initializers run when the file is read (ran: 171, 750 of
        # erand48 from {0x330E, 0, 0}, as trunc(ran(1)*1000)), and the last
        # define: block's again before Start: (96); the axiom draws 870.
        check("read and start", run("Lsystem: 1\nderivation length: 1\n"
                                    "define: { array R[2] = {trunc(ran(1)*1000), 5}; }\n"
                                    "define: { array S[1] = {trunc(ran(1)*1000)}, T[1][2]; }\n"
                                    "Axiom: X(R[0], R[1], S[0], trunc(ran(1)*1000), T[0][1])\n"
                                    "endlsystem\n", 0), "X(171,5,96,870,0)")
        # an element of an earlier array in a dimension: M is [(int)2.9][2]
        # = 1 2 3 4; M[9][9] is M[1][1], M[0.99][0.5] element
        # (int)(0.99*2 + 0.5) = 2
        check("dimension", run("Lsystem: 1\nderivation length: 1\n"
                               "define: { array N[1] = {2.9}, M[N[0]][2] = {1,2,3,4,5}; }\n"
                               "Axiom: X(M[9][9], M[0.99][0.5])\nendlsystem\n", 0), "X(4,3)")
        for what, body in [
                ("no subscripts", "X(n) --> Y(A)"),
                ("not an array", "X(n) --> Y(n[0])"),
                ("too few subscripts", "X(n) --> Y(A[1])"),
                ("too many subscripts", "X(n) --> Y(A[1][1][1])"),
                ("assignment of the name", "X(n) : {A = 1;} * --> Y"),
                ("assignment, wrong count", "X(n) : {A[0] = 1;} * --> Y"),
                ("past the storage", "X(n) --> Y(A[1.9][2])"),
                ("NaN subscript", "X(n) --> Y(A[0][(0-1)^0.5])"),
                ("undefined array", "X(n) --> Y(Bx[0])")]:
            try:
                run("Lsystem: 1\nderivation length: 1\n"
                    "define: { array A[2][3]; }\nAxiom: X(1)\n%s\nendlsystem\n" % body)
                check(what, "accepted", "refused")
            except CpfgError as e:
                check(what + " located", e.where is not None, True)
        for what, define in [
                ("twice", "array A[2], A[3];"), ("dimension 0", "array A[0];"),
                ("dimension -1", "array A[2][-1];"), ("too large", "array A[1025][1025];"),
                ("statement", "x = 1;"), ("empty", ""), ("no dimension", "array A;"),
                ("empty initializer", "array A[2] = {};"),
                ("self reference", "array A[2] = {1, A[0]};")]:
            try:
                run("Lsystem: 1\nderivation length: 1\n"
                    "define: { %s }\nAxiom: X(1)\nendlsystem\n" % define)
                check(what, "accepted", "refused")
            except CpfgError as e:
                check(what + " located", e.where is not None, True)
        # an array Q hides the step number (set in cpfg's global table)
        check("array Q", run("Lsystem: 1\nderivation length: 2\ndefine: { array Q[2]; }\n"
                             "StartEach: {Q[1] = Q[1] + 1;}\nAxiom: X\nX --> X(Q[1])\n"
                             "endlsystem\n"), "X(1)")
        try:
            run("Lsystem: 1\nStart: {g = 1;}\n"
                "define: { array g[2]; }\nAxiom: X(1)\nendlsystem\n")
            check("a variable before", "accepted", "refused")
        except CpfgError:
            pass
    return ok


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file", nargs="?")
    ap.add_argument("-n", type=int, default=None, help="number of derivation steps")
    ap.add_argument("--no-homomorphism", action="store_true")
    ap.add_argument("--functions", action="append", default=[], metavar="FILE",
                    help="a view file (its function: and function set: lines), "
                    "a function set (.fset) or a function (.func); repeatable")
    ap.add_argument("--cpfg-view", metavar="FILE.v", default=None,
                    help="the view file: the settings of the turtle that fills the queries "
                    "?P ?H ?L ?U, and its function: and curve: lines")
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args(argv)
    if args.self_test:
        return self_test()
    if not args.file:
        ap.error("a file is needed")
    try:
        out = run_file(args.file, args.n, not args.no_homomorphism, args.functions,
                       args.cpfg_view)
    except CpfgError as e:
        print("cpfg_ref.py: %s" % e, file=sys.stderr)
        return 1
    sys.stdout.write(out + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
