/* Bench workload (bracketed D0L): ABOP figure 1.24d.
   The string roughly triples each step. */
define: delta = 20

productions:
X -> F[+X]F[-X]+X
F -> FF

axiom:
X
