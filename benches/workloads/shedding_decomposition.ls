/* Bench workload (issue 11: decomposition and the cut): a branching shoot
   whose internodes are decomposed into a segment and a small leaf branch
   the step they appear; each leaf ages and turns into the cut symbol %,
   which prunes the rest of its branch in the next step. The apices triple
   each step, so the string roughly triples; memory must stay flat. */
productions:
A -> I(1)[+A][-A]I(1)A
F(l) -> F(l*1.05)
L(a) : a < 2 -> L(a+1)
L(a) : a >= 2 -> %

decomposition:
maximum depth: 2
I(l) -> F(l)[&L(0)P]
P -> F(0.5)F(0.5)

axiom:
A
