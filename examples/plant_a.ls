/* Bracketed OL-system plant, ABOP figure 1.24a (p. 25).
   n = 5, delta = 25.7 degrees. */
view: angle = 25.7
view: width = 0.81
view: palette = #33691e
derivation length: 5
define: delta = 25.7

productions:
F -> F[+F]F[-F]F

axiom:
F
