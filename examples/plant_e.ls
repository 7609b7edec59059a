/* Bracketed OL-system plant, ABOP figure 1.24e (p. 25).
   n = 7, delta = 25.7 degrees. */
derivation length: 7
define: delta = 25.7

productions:
X -> F[+X][-X]FX
F -> FF

axiom:
X
