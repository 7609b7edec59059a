/* Bracketed OL-system plant, ABOP figure 1.24e (p. 25).
   n = 7, delta = 25.7 degrees. */
view: angle = 25.7
view: width = 0.84
view: palette = #33691e
derivation length: 7
define: delta = 25.7

productions:
X -> F[+X][-X]FX
F -> FF

axiom:
X
