/* Bracketed OL-system plant, ABOP figure 1.24f (p. 25).
   n = 5, delta = 22.5 degrees. */
view: angle = 22.5
view: width = 0.26
view: palette = #33691e
derivation length: 5
define: delta = 22.5

productions:
X -> F-[[X]+X]+F[+FX]-X
F -> FF

axiom:
X
