/* Bench workload (parametric, conditions, constants): a branching tree.
   Every A forks while long enough and sprouts a short shoot once it is
   short; old segments keep elongating, so every F is rewritten too.
   The string roughly triples each step. */
define: R = 1.456     /* contraction ratio of the branches */
define: a = 30        /* branching angle */
define: lr = 1.05     /* elongation rate of old segments */
define: lmin = 1      /* below this length a bud stops forking */

productions:
A(l) : l >= lmin -> F(l)[+(a)A(l/R)][-(a)A(l/R)]F(l)A(l/R)
A(l) : l < lmin -> F(l)[+(a)A(l*R*R)]A(l*R*R*R)
F(l) -> F(l*lr)

axiom:
A(100)
