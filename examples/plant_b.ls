/* Bracketed OL-system plant, ABOP figure 1.24b (p. 25).
   n = 5, delta = 20 degrees. */
view: angle = 20
view: width = 0.21
view: palette = #33691e
derivation length: 5
define: delta = 20

productions:
F -> F[+F]F[-F][F]

axiom:
F
