/* Bracketed OL-system plant, ABOP figure 1.24d (p. 25).
   n = 7, delta = 20 degrees. */
view: angle = 20
view: width = 0.83
view: palette = #33691e
derivation length: 7
define: delta = 20

productions:
X -> F[+X]F[-X]+X
F -> FF

axiom:
X
